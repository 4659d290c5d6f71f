/* Pass 'reflect_reproject' (primary, moving camera, reflections on): the
 * reflection history brought to this frame's pixels by the virtual point's
 * and the surface's motion (render_reflect_reproject.comp). */
#include "passes.h"

/* The roughness from which a reflection's history follows the surface alone
 * (below it the virtual point's weight is 1 - smoothstep(0, limit,
 * roughness); 0.2 and 1.0 changed the 1-degree figure of reflect_filter.c's
 * REFLECT_MAX_HISTORY measure by under 0.0003). */
#define REFLECT_ROUGH_LIMIT 0.5f

/* Binding order of render.reflect_reproject: the reads, then the writes. */
static const int reads[10] = { TEX_POSITION,         TEX_NORMAL,         TEX_MATERIAL, TEX_MOTION,
                               TEX_HISTORY_POSITION, TEX_HISTORY_NORMAL, TEX_REFLECT,  TEX_REFLECT_HISTORY,
                               TEX_REFLECT_OWN,      TEX_REFLECT_STATE };
static const int writes[3] = { TEX_REFLECT_REPROJECTED, TEX_REFLECT_OWN_REPROJECTED, TEX_REFLECT_STATE_REPROJECTED };
enum { USE_COUNT = 13 };

static bool present(const cv_render_frame *f) { return f->info.reflections && f->info.moving; }

static cv_result declare(const cv_render_frame *f, cv_graph_builder *b, cv_graph_use *u, void *user) {
    (void)user;
    for (int i = 0; i < 10; i++)
        u[i] = cv_graph_pass_read(b, f->tex[reads[i]], CV_GRAPH_STORAGE_READ);
    for (int i = 0; i < 3; i++)
        u[10 + i] = cv_graph_pass_write(b, f->tex[writes[i]], CV_GRAPH_STORAGE_WRITE, CV_GRAPH_TRANSFER_AUTO);
    return CV_OK;
}

static void record(const cv_render_frame *f, const cv_graph_pass_context *pc, cv_command_list *l,
                   const cv_graph_use *u, void *user) {
    (void)user;
    struct {
        float prev_view_proj[16];
        float eye[4];
        uint32_t width, height, has_history, material_count;
        float params[4];
    } push = { .eye = { f->camera.position[0], f->camera.position[1], f->camera.position[2],
                        RENDER_REPROJECT_PLANE_TOLERANCE },
               .width = f->width,
               .height = f->height,
               .has_history = f->info.frame > 0,
               .material_count = f->data.material_count,
               .params = { REFLECT_ROUGH_LIMIT, 0.0f, 0.0f, 0.0f } };
    float far_plane;
    render_view_proj(f, &f->previous_camera, push.prev_view_proj, &far_plane);
    cv_binding b[USE_COUNT];
    render_bind_uses(pc, u, USE_COUNT, b);
    render_dispatch_image(f, l, pc->queue, PIPE_REFLECT_REPROJECT, b, USE_COUNT, &push, sizeof(push));
}

const cv_render_pass_module render_pass_reflect_reproject = { .name = "reflect_reproject",
                                                              .queue = CV_QUEUE_COMPUTE,
                                                              .policy = CV_MGPU_PRIMARY_ONLY,
                                                              .present = present,
                                                              .declare = declare,
                                                              .record = record };
