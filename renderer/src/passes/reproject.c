/* Pass 'reproject' (primary, moving camera): motion vectors and the history
 * brought to this frame's pixels (render_reproject.comp), so the history
 * follows the surfaces (disocclusion starts it again). */
#include "passes.h"

/* The longest history kept. The error of the reprojected history grows with
 * its length (room 160x90, 16 frames of an orbit of 0.05, 0.3 and 1 degree a
 * frame, unfiltered, against 1024 / 4096 samples at the last frame: shadow
 * RMSE 0.0101, 0.0230, 0.0256 with at most 4 frames; 0.0119, 0.0289, 0.0335
 * with 8; 0.0148, 0.0337, 0.0384 with 32; AO alike but at 0.05 degrees,
 * docs/renderer-quality.md), so 4. */
#define REPROJECT_MAX_HISTORY 4.0f

/* Binding order of render.reproject. */
enum {
    USE_POSITION,
    USE_NORMAL,
    USE_HISTORY_POSITION,
    USE_HISTORY_NORMAL,
    USE_HISTORY,
    USE_MOTION,
    USE_REPROJECTED,
    USE_COUNT
};

static bool present(const cv_render_frame *f) { return f->info.moving; }

static cv_result declare(const cv_render_frame *f, cv_graph_builder *b, cv_graph_use *u, void *user) {
    (void)user;
    static const int reads[5] = { TEX_POSITION, TEX_NORMAL, TEX_HISTORY_POSITION, TEX_HISTORY_NORMAL, TEX_HISTORY };
    for (int i = 0; i < 5; i++)
        u[USE_POSITION + i] = cv_graph_pass_read(b, f->tex[reads[i]], CV_GRAPH_STORAGE_READ);
    u[USE_MOTION] = cv_graph_pass_write(b, f->tex[TEX_MOTION], CV_GRAPH_STORAGE_WRITE, CV_GRAPH_TRANSFER_AUTO);
    u[USE_REPROJECTED] = cv_graph_pass_write(b, f->tex[TEX_REPROJECTED], CV_GRAPH_STORAGE_WRITE,
                                             CV_GRAPH_TRANSFER_AUTO);
    return CV_OK;
}

static void record(const cv_render_frame *f, const cv_graph_pass_context *pc, cv_command_list *l,
                   const cv_graph_use *u, void *user) {
    (void)user;
    struct {
        float prev_view_proj[16];
        float eye[4];
        uint32_t width, height, has_history;
        float max_history;
    } push = { .eye = { f->camera.position[0], f->camera.position[1], f->camera.position[2],
                        RENDER_REPROJECT_PLANE_TOLERANCE },
               .width = f->width,
               .height = f->height,
               .has_history = f->info.frame > 0,
               .max_history = REPROJECT_MAX_HISTORY };
    float far_plane;
    render_view_proj(f, &f->previous_camera, push.prev_view_proj, &far_plane);
    cv_binding b[USE_COUNT];
    render_bind_uses(pc, u, USE_COUNT, b);
    render_dispatch_image(f, l, pc->queue, PIPE_REPROJECT, b, USE_COUNT, &push, sizeof(push));
}

const cv_render_pass_module render_pass_reproject = { .name = "reproject",
                                                      .queue = CV_QUEUE_COMPUTE,
                                                      .policy = CV_MGPU_PRIMARY_ONLY,
                                                      .present = present,
                                                      .declare = declare,
                                                      .record = record };
