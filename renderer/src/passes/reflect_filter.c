/* Pass 'reflect_filter' (primary, every frame, reflections on): spatial reuse
 * of this frame's reflection samples, into the running mean
 * (render_reflect_filter.comp); a moving camera's into the reprojected
 * history. */
#include "passes.h"

/* Moving camera: the longest reflection history kept (frames). As for the
 * shadows (reproject.c's REPROJECT_MAX_HISTORY), a reprojected history's
 * error grows with its length even for slow motion; room 96x54, 16 frames,
 * reflection plane against 1024 samples at the last frame
 * (docs/renderer-quality.md, Reflections, "Moving camera"), RMSE with at most
 * 3 / 4 / 8 / 16 frames: 0.0554 / 0.0496 / 0.0462 / 0.0503 at 0.05 degrees a
 * frame, 0.0629 / 0.0612 / 0.0604 / 0.0634 at 0.3, 0.0762 / 0.0792 / 0.0861 /
 * 0.0900 at 1 (one frame alone about 0.10), so 4: within 0.004 of the best at
 * each speed. */
#define REFLECT_MAX_HISTORY 4u

enum {
    USE_BLUE_NOISE,
    USE_POSITION,
    USE_NORMAL,
    USE_MATERIAL,
    USE_SAMPLES,
    USE_HISTORY,
    USE_OWN,
    USE_HISTORY_WRITE,
    USE_OWN_WRITE,
    USE_OUT,
    USE_REPROJECTED, /* moving camera */
    USE_OWN_REPROJECTED,
    USE_STATE_REPROJECTED,
    USE_STATE,
};

static bool present(const cv_render_frame *f) { return f->info.reflections; }

static cv_result declare(const cv_render_frame *f, cv_graph_builder *b, cv_graph_use *u, void *user) {
    (void)user;
    static const int reads[6] = { TEX_POSITION, TEX_NORMAL,          TEX_MATERIAL,
                                  TEX_REFLECT,  TEX_REFLECT_HISTORY, TEX_REFLECT_OWN };
    static const int writes[3] = { TEX_REFLECT_HISTORY, TEX_REFLECT_OWN, TEX_REFLECT_OUT };
    u[USE_BLUE_NOISE] = cv_graph_pass_read(b, f->buf[BUF_BLUE_NOISE], CV_GRAPH_STORAGE_READ);
    for (int i = 0; i < 6; i++)
        u[USE_POSITION + i] = cv_graph_pass_read(b, f->tex[reads[i]], CV_GRAPH_STORAGE_READ);
    for (int i = 0; i < 3; i++)
        u[USE_HISTORY_WRITE + i] = cv_graph_pass_write(b, f->tex[writes[i]], CV_GRAPH_STORAGE_WRITE,
                                                       CV_GRAPH_TRANSFER_AUTO);
    if (f->info.moving) {
        static const int moving[3] = { TEX_REFLECT_REPROJECTED, TEX_REFLECT_OWN_REPROJECTED,
                                       TEX_REFLECT_STATE_REPROJECTED };
        for (int i = 0; i < 3; i++)
            u[USE_REPROJECTED + i] = cv_graph_pass_read(b, f->tex[moving[i]], CV_GRAPH_STORAGE_READ);
        u[USE_STATE] = cv_graph_pass_write(b, f->tex[TEX_REFLECT_STATE], CV_GRAPH_STORAGE_WRITE,
                                           CV_GRAPH_TRANSFER_AUTO);
    }
    return CV_OK;
}

/* A still camera's pass binds the history again in the slots it does not use. */
static void record(const cv_render_frame *f, const cv_graph_pass_context *pc, cv_command_list *l,
                   const cv_graph_use *u, void *user) {
    (void)user;
    const cv_render_settings *s = &f->settings;
    bool moving = f->info.moving;
    struct {
        uint32_t width, height, frame, accumulated;
        float camera[4];
        int32_t radius;
        uint32_t material_count, quarter, moving_cap, samples, pad[3];
    } push = { f->width,
               f->height,
               s->first_frame + f->info.frame,
               /* A moving camera: per-pixel history lengths (the reprojected state). */
               moving ? 0u : f->info.frame,
               { f->camera.position[0], f->camera.position[1], f->camera.position[2], f->data.diagonal * 0.01f },
               s->reflection_scale < 1.0f ? s->reflection_radius + 1 : s->reflection_radius,
               f->data.material_count,
               s->reflection_scale < 1.0f ? 1u : 0u,
               moving ? REFLECT_MAX_HISTORY : 0u,
               s->reflection_samples,
               { 0, 0, 0 } };
    const int slots[12] = { USE_POSITION,
                            USE_NORMAL,
                            USE_MATERIAL,
                            USE_SAMPLES,
                            USE_HISTORY,
                            USE_OWN,
                            USE_OUT,
                            moving ? USE_REPROJECTED : USE_HISTORY,
                            moving ? USE_OWN_REPROJECTED : USE_OWN,
                            moving ? USE_STATE_REPROJECTED : USE_HISTORY,
                            moving ? USE_STATE : USE_OWN,
                            USE_BLUE_NOISE };
    cv_binding b[12];
    for (int i = 0; i < 12; i++)
        b[i] = cv_graph_use_binding(pc, u[slots[i]]);
    render_dispatch_image(f, l, pc->queue, PIPE_REFLECT_FILTER, b, 12, &push, sizeof(push));
}

const cv_render_pass_module render_pass_reflect_filter = { .name = "reflect_filter",
                                                           .queue = CV_QUEUE_COMPUTE,
                                                           .policy = CV_MGPU_PRIMARY_ONLY,
                                                           .present = present,
                                                           .declare = declare,
                                                           .record = record };
