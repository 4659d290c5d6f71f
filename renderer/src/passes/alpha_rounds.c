/* The alpha-mask rule's rounds (renderer.h), recorded by passes 'trace' and
 * 'reflect' after each trace in a scene with alpha-masked materials. */
#include "passes.h"

static cv_binding bind_buffer(cv_buffer b) { return (cv_binding){ .resource = cv_any(b) }; }

void render_record_alpha_rounds(const cv_render_frame *f, const cv_graph_pass_context *pc, cv_command_list *l,
                                const render_alpha_uses *scene, cv_buffer rays, cv_buffer hits, cv_buffer scratch,
                                uint32_t count, bool any_hit) {
    cv_binding b[9] = { bind_buffer(rays),
                        bind_buffer(hits),
                        bind_buffer(scratch),
                        cv_graph_use_binding(pc, scene->vertices),
                        cv_graph_use_binding(pc, scene->instances),
                        cv_graph_use_binding(pc, scene->uvs),
                        cv_graph_use_binding(pc, scene->materials),
                        cv_graph_use_binding(pc, scene->image_table),
                        cv_graph_use_binding(pc, scene->image_pool) };
    uint32_t g = render_groups(count, 64), gx = g < 32768 ? g : 32768, rounds = render_alpha_retraces(any_hit);
    for (uint32_t k = 0; k <= rounds; k++) {
        struct {
            uint32_t count, round, any_hit;
            float bias;
            uint32_t material_count, layers, pad[2];
        } push = { count,
                   k,
                   any_hit ? 1u : 0u,
                   render_ray_offset(&f->data),
                   f->data.material_count,
                   CV_RENDER_ALPHA_LAYERS,
                   { 0, 0 } };
        cv_cmd_dispatch(l, pc->queue,
                        &(cv_dispatch_args){ .pipeline = f->pipelines[PIPE_ALPHA_CONTINUE],
                                             .bindings = b,
                                             .bindings_count = 9,
                                             .push = &push,
                                             .push_size = sizeof(push),
                                             .groups_x = gx,
                                             .groups_y = render_groups(g, gx),
                                             .groups_z = 1 });
        if (k < rounds)
            cv_cmd_trace_rays(l, pc->queue,
                              &(cv_trace_rays_args){
                                  .accel = f->accel, .rays = rays, .hits = scratch, .count = count });
    }
}
