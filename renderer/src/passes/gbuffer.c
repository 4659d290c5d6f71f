/* Pass 'gbuffer' (primary; the first frame, every frame for a moving camera):
 * position and normal by rasterization, then the material at each pixel
 * (base color, roughness, emission, metalness, textures evaluated) by a
 * second draw of the same geometry into the material and emission targets:
 * the registry's render passes have two color targets. Both draws compute
 * the same depth and discard the same fragments (render_gbuffer.frag), so
 * each pixel's material is that of the surface in the position target.
 *
 * The trace and reflect passes on other devices read it, each at the pixels
 * of its own window. A still camera's G-buffer is multicast whole: it is
 * rendered once and the balancer moves the windows in later frames. A moving
 * camera's is rendered every frame, so each device gets only that frame's
 * window of it. */
#include <string.h>

#include "passes.h"

enum {
    USE_VERTICES,
    USE_UVS,
    USE_MATERIALS,
    USE_IMAGE_TABLE,
    USE_IMAGE_POOL,
    USE_POSITION,
    USE_NORMAL,
    USE_MATERIAL,
    USE_EMISSION,
    USE_DEPTH,
};

static bool enabled(const cv_render_frame *f) { return f->info.first || f->info.moving; }

static cv_result declare(const cv_render_frame *f, cv_graph_builder *b, cv_graph_use *u, void *user) {
    (void)user;
    cv_graph_transfer rule = f->info.moving ? CV_GRAPH_TRANSFER_PRIMARY_TO_WINDOWS : CV_GRAPH_TRANSFER_MULTICAST;
    u[USE_VERTICES] = cv_graph_pass_read(b, f->buf[BUF_VERTICES], CV_GRAPH_STORAGE_READ);
    u[USE_UVS] = cv_graph_pass_read(b, f->buf[BUF_UVS], CV_GRAPH_STORAGE_READ);
    u[USE_MATERIALS] = cv_graph_pass_read(b, f->buf[BUF_MATERIALS], CV_GRAPH_STORAGE_READ);
    u[USE_IMAGE_TABLE] = cv_graph_pass_read(b, f->buf[BUF_IMAGE_TABLE], CV_GRAPH_STORAGE_READ);
    u[USE_IMAGE_POOL] = cv_graph_pass_read(b, f->buf[BUF_IMAGE_POOL], CV_GRAPH_STORAGE_READ);
    u[USE_POSITION] = cv_graph_pass_write(b, f->tex[TEX_POSITION], CV_GRAPH_COLOR_TARGET, rule);
    u[USE_NORMAL] = cv_graph_pass_write(b, f->tex[TEX_NORMAL], CV_GRAPH_COLOR_TARGET, rule);
    u[USE_MATERIAL] = cv_graph_pass_write(b, f->tex[TEX_MATERIAL], CV_GRAPH_COLOR_TARGET, rule);
    u[USE_EMISSION] = cv_graph_pass_write(b, f->tex[TEX_EMISSION], CV_GRAPH_COLOR_TARGET, CV_GRAPH_TRANSFER_AUTO);
    u[USE_DEPTH] = cv_graph_pass_write(b, f->tex[TEX_DEPTH], CV_GRAPH_DEPTH_TARGET, CV_GRAPH_TRANSFER_AUTO);
    return CV_OK;
}

static void record(const cv_render_frame *f, const cv_graph_pass_context *pc, cv_command_list *l,
                   const cv_graph_use *u, void *user) {
    (void)user;
    const cv_camera *camera = &f->camera;
    struct {
        float view_proj[16];
        float camera[4];
        uint32_t mode[4];
    } push = { .mode = { 0 } };
    float far_plane;
    render_view_proj(f, camera, push.view_proj, &far_plane);
    memcpy(push.camera, camera->position, sizeof(camera->position));
    push.camera[3] = 1.0f / far_plane; /* render.gbuffer writes depth = view depth / far */
    cv_binding b[5];
    for (int i = 0; i < 5; i++)
        b[i] = cv_graph_use_binding(pc, u[USE_VERTICES + i]);
    const int targets[2][2] = { { USE_POSITION, USE_NORMAL }, { USE_MATERIAL, USE_EMISSION } };
    for (uint32_t mode = 0; mode < 2; mode++) {
        push.mode[0] = mode;
        cv_cmd_begin_render_pass(l, pc->queue,
                                 &(cv_begin_render_pass_args){
                                     .color0 = cv_graph_use_texture(pc, u[targets[mode][0]]),
                                     .color1 = cv_graph_use_texture(pc, u[targets[mode][1]]),
                                     .depth = cv_graph_use_texture(pc, u[USE_DEPTH]),
                                     .clear = 1,
                                     .clear_depth = 1.0f });
        cv_cmd_draw(l, pc->queue,
                    &(cv_draw_args){ .pipeline = f->pipelines[PIPE_GBUFFER],
                                     .bindings = b,
                                     .bindings_count = 5,
                                     .push = &push,
                                     .push_size = sizeof(push),
                                     .vertex_count = (uint32_t)f->data.vertex_count,
                                     .instance_count = 1 });
        cv_cmd_end_render_pass(l, pc->queue, &(cv_end_render_pass_args){ 0 });
    }
}

const cv_render_pass_module render_pass_gbuffer = { .name = "gbuffer",
                                                    .queue = CV_QUEUE_GRAPHICS,
                                                    .policy = CV_MGPU_PRIMARY_ONLY,
                                                    .enabled = enabled,
                                                    .declare = declare,
                                                    .record = record };
