/* Pass 'composite' (primary, last frame): sun and sky light on the G-buffer's
 * materials with the filtered visibility, the point lights, emission and,
 * with reflections, Fresnel times the denoised reflection, to linear HDR
 * radiance and albedo (render_composite.comp). */
#include "passes.h"

enum {
    USE_POSITION,
    USE_NORMAL,
    USE_VISIBILITY,
    USE_MATERIAL,
    USE_EMISSION,
    USE_LIGHTS,
    USE_REFLECTION, /* reflections on */
    USE_RADIANCE,
    USE_ALBEDO,
};

static bool enabled(const cv_render_frame *f) { return f->info.last; }

static cv_result declare(const cv_render_frame *f, cv_graph_builder *b, cv_graph_use *u, void *user) {
    (void)user;
    u[USE_POSITION] = cv_graph_pass_read(b, f->tex[TEX_POSITION], CV_GRAPH_STORAGE_READ);
    u[USE_NORMAL] = cv_graph_pass_read(b, f->tex[TEX_NORMAL], CV_GRAPH_STORAGE_READ);
    u[USE_VISIBILITY] = cv_graph_pass_read(b, f->tex[render_filtered_texture(f->info.filter_iterations)],
                                           CV_GRAPH_STORAGE_READ);
    u[USE_MATERIAL] = cv_graph_pass_read(b, f->tex[TEX_MATERIAL], CV_GRAPH_STORAGE_READ);
    u[USE_EMISSION] = cv_graph_pass_read(b, f->tex[TEX_EMISSION], CV_GRAPH_STORAGE_READ);
    u[USE_LIGHTS] = cv_graph_pass_read(b, f->buf[BUF_LIGHTS], CV_GRAPH_STORAGE_READ);
    if (f->info.reflections)
        u[USE_REFLECTION] = cv_graph_pass_read(b, f->tex[render_reflect_shown_texture()], CV_GRAPH_STORAGE_READ);
    u[USE_RADIANCE] = cv_graph_pass_write(b, f->tex[TEX_RADIANCE], CV_GRAPH_STORAGE_WRITE, CV_GRAPH_TRANSFER_AUTO);
    u[USE_ALBEDO] = cv_graph_pass_write(b, f->tex[TEX_ALBEDO], CV_GRAPH_STORAGE_WRITE, CV_GRAPH_TRANSFER_AUTO);
    return CV_OK;
}

static void record(const cv_render_frame *f, const cv_graph_pass_context *pc, cv_command_list *l,
                   const cv_graph_use *u, void *user) {
    (void)user;
    const render_scene_data *d = &f->data;
    struct {
        float sun[4], sun_color[4], sky[4];
        uint32_t width, height, material_count, light_count;
        float camera[4]; /* w: 1 = add the reflection */
    } push = { { f->sun_direction[0], f->sun_direction[1], f->sun_direction[2], d->sun_irradiance },
               { d->sun_color[0], d->sun_color[1], d->sun_color[2], 0.0f },
               { 0.12f, 0.15f, 0.2f, 0.0f },
               f->width,
               f->height,
               d->material_count,
               d->light_count,
               { f->camera.position[0], f->camera.position[1], f->camera.position[2],
                 f->info.reflections ? 1.0f : 0.0f } };
    /* Without reflections the shader reads no reflection (push.camera.w = 0):
     * its slot holds the material, a declared RGBA32F texture. */
    const int slots[9] = { USE_POSITION,   USE_NORMAL,
                           USE_VISIBILITY, USE_MATERIAL,
                           USE_RADIANCE,   USE_ALBEDO,
                           USE_LIGHTS,     f->info.reflections ? USE_REFLECTION : USE_MATERIAL,
                           USE_EMISSION };
    cv_binding b[9];
    for (int i = 0; i < 9; i++)
        b[i] = cv_graph_use_binding(pc, u[slots[i]]);
    cv_cmd_begin_marker(l, pc->queue, &(cv_begin_marker_args){ .label = "composite" });
    render_dispatch_image(f, l, pc->queue, PIPE_COMPOSITE, b, 9, &push, sizeof(push));
    cv_cmd_end_marker(l, pc->queue, &(cv_end_marker_args){ 0 });
}

const cv_render_pass_module render_pass_composite = { .name = "composite",
                                                      .queue = CV_QUEUE_COMPUTE,
                                                      .policy = CV_MGPU_PRIMARY_ONLY,
                                                      .enabled = enabled,
                                                      .declare = declare,
                                                      .record = record };
