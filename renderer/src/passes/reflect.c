/* Pass 'reflect' (every device, its window; reflections on): for each band
 * of rows and each of the reflection_samples samples, one GGX reflection ray
 * per pixel (render.reflect_raygen), closest hit, a shadow ray from each hit
 * toward the sun (render.reflect_shadow), any hit, and the radiance each
 * reflection ray brings back (render.reflect_shade) into the window of the
 * sample's image of the reflection samples. The graph copies the sample
 * windows back to the primary, which reconstructs and accumulates them. */

#include "passes.h"

enum {
    USE_POSITION,
    USE_NORMAL,
    USE_MATERIAL,
    USE_VERTICES,
    USE_MATERIALS,
    USE_INSTANCES,
    USE_UVS,
    USE_IMAGE_TABLE,
    USE_IMAGE_POOL,
    USE_BLUE_NOISE,
    USE_RAYS,
    USE_HITS,
    USE_SHADOW_RAYS,
    USE_SHADOW_HITS,
    USE_SAMPLES,
    USE_ALPHA_HITS, /* masked scenes */
};

static bool present(const cv_render_frame *f) { return f->info.reflections; }

static cv_result declare(const cv_render_frame *f, cv_graph_builder *b, cv_graph_use *u, void *user) {
    (void)user;
    static const int textures[3] = { TEX_POSITION, TEX_NORMAL, TEX_MATERIAL };
    static const int buffers[7] = { BUF_VERTICES,    BUF_MATERIALS,  BUF_INSTANCES, BUF_UVS,
                                    BUF_IMAGE_TABLE, BUF_IMAGE_POOL, BUF_BLUE_NOISE };
    for (int i = 0; i < 3; i++)
        u[USE_POSITION + i] = cv_graph_pass_read(b, f->tex[textures[i]], CV_GRAPH_STORAGE_READ);
    for (int i = 0; i < 7; i++)
        u[USE_VERTICES + i] = cv_graph_pass_read(b, f->buf[buffers[i]], CV_GRAPH_STORAGE_READ);
    /* Transients of the pass, one band of any window each (render_reflect_capacity). */
    static const char *const labels[4] = { "reflect rays", "reflect hits", "reflect shadow rays",
                                           "reflect shadow hits" };
    uint64_t rays = f->graph_reflect_rays;
    for (int k = 0; k < 4; k++)
        u[USE_RAYS + k] = render_band_buffer(b, labels[k], rays * (k % 2 ? CV_HIT_BYTES : CV_RAY_BYTES));
    u[USE_SAMPLES] = cv_graph_pass_write(b, f->tex[TEX_REFLECT], CV_GRAPH_STORAGE_WRITE, CV_GRAPH_TRANSFER_AUTO);
    if (f->alpha_mask)
        u[USE_ALPHA_HITS] = render_band_buffer(b, "reflect alpha hits", rays * CV_HIT_BYTES);
    return CV_OK;
}

/* The push constants of one band (rows y0 .. y0 + h of the window). */
typedef struct reflect_push {
    struct {
        uint32_t x0, width, height, y0;
        float camera[4];
        uint32_t frame, material_count, quarter, samples, sample, pad[3];
    } gen;
    struct {
        uint32_t width, height;
        float bias;
        uint32_t pad;
        float sun[4];
    } shadow;
    struct {
        uint32_t x0, width, height, y0;
        float sun[4], sun_color[4], sky[4];
        uint32_t material_count, row_offset, pad[2];
    } shade;
} reflect_push;

static reflect_push band_push(const cv_render_frame *f, cv_column_range cols, uint32_t y0, uint32_t h) {
    const cv_render_settings *s = &f->settings;
    const render_scene_data *d = &f->data;
    float bias = render_ray_offset(d);
    reflect_push p = {
        .gen = { cols.x,
                 cols.width,
                 h,
                 y0,
                 { f->camera.position[0], f->camera.position[1], f->camera.position[2], bias },
                 s->first_frame + f->info.frame,
                 d->material_count,
                 s->reflection_scale < 1.0f ? 1u : 0u,
                 s->reflection_samples,
                 0,
                 { 0, 0, 0 } },
        .shadow = { cols.width, h, bias, 0, { d->sun_direction[0], d->sun_direction[1], d->sun_direction[2], 0.0f } },
        .shade = { cols.x,
                   cols.width,
                   h,
                   y0,
                   { d->sun_direction[0], d->sun_direction[1], d->sun_direction[2], d->sun_irradiance },
                   { d->sun_color[0], d->sun_color[1], d->sun_color[2], 0.0f },
                   { 0.12f, 0.15f, 0.2f, 0.0f },
                   d->material_count,
                   0,
                   { 0, 0 } },
    };
    return p;
}

static void record(const cv_render_frame *f, const cv_graph_pass_context *pc, cv_command_list *l,
                   const cv_graph_use *u, void *user) {
    (void)user;
    const cv_render_settings *s = &f->settings;
    cv_column_range cols = { pc->x, pc->width };
    cv_buffer rays = cv_graph_use_buffer(pc, u[USE_RAYS]), hits = cv_graph_use_buffer(pc, u[USE_HITS]),
              shadow_rays = cv_graph_use_buffer(pc, u[USE_SHADOW_RAYS]),
              shadow_hits = cv_graph_use_buffer(pc, u[USE_SHADOW_HITS]),
              alpha_hits = cv_graph_use_buffer(pc, u[USE_ALPHA_HITS]);
    cv_binding b[USE_ALPHA_HITS];
    render_bind_uses(pc, u, USE_ALPHA_HITS, b);
    cv_binding gen_b[5] = { b[USE_POSITION], b[USE_NORMAL], b[USE_MATERIAL], b[USE_RAYS], b[USE_BLUE_NOISE] };
    cv_binding shadow_b[5] = { b[USE_RAYS], b[USE_HITS], b[USE_VERTICES], b[USE_INSTANCES], b[USE_SHADOW_RAYS] };
    cv_binding shade_b[12] = { b[USE_POSITION],    b[USE_RAYS],     b[USE_HITS],        b[USE_SHADOW_RAYS],
                               b[USE_SHADOW_HITS], b[USE_VERTICES], b[USE_INSTANCES],   b[USE_MATERIALS],
                               b[USE_SAMPLES],     b[USE_UVS],      b[USE_IMAGE_TABLE], b[USE_IMAGE_POOL] };
    render_alpha_uses alpha = { u[USE_VERTICES],  u[USE_INSTANCES],   u[USE_UVS],
                                u[USE_MATERIALS], u[USE_IMAGE_TABLE], u[USE_IMAGE_POOL] };
    uint64_t rows64 = render_reflect_capacity(f, s) / cols.width;
    uint32_t rows = rows64 == 0 ? 1 : rows64 < f->height ? (uint32_t)rows64 : f->height;
    for (uint32_t y0 = 0; y0 < f->height; y0 += rows) {
        uint32_t h = f->height - y0 < rows ? f->height - y0 : rows, count = cols.width * h;
        reflect_push p = band_push(f, cols, y0, h);
        for (uint32_t k = 0; k < s->reflection_samples; k++) {
            p.gen.sample = k;
            p.shade.row_offset = k * f->height;
            render_dispatch_pixels(f, l, pc->queue, PIPE_REFLECT_RAYGEN, gen_b, 5, &p.gen, sizeof(p.gen), cols.width,
                                   h);
            cv_cmd_trace_rays(l, pc->queue,
                              &(cv_trace_rays_args){ .accel = f->accel, .rays = rays, .hits = hits, .count = count });
            if (f->alpha_mask)
                render_record_alpha_rounds(f, pc, l, &alpha, rays, hits, alpha_hits, count, false);
            render_dispatch_pixels(f, l, pc->queue, PIPE_REFLECT_SHADOW, shadow_b, 5, &p.shadow, sizeof(p.shadow),
                                   cols.width, h);
            cv_cmd_trace_rays(l, pc->queue,
                              &(cv_trace_rays_args){ .accel = f->accel,
                                                     .rays = shadow_rays,
                                                     .hits = shadow_hits,
                                                     .count = count,
                                                     .flags = CV_TRACE_ANY_HIT });
            if (f->alpha_mask)
                render_record_alpha_rounds(f, pc, l, &alpha, shadow_rays, shadow_hits, alpha_hits, count, true);
            render_dispatch_pixels(f, l, pc->queue, PIPE_REFLECT_SHADE, shade_b, 12, &p.shade, sizeof(p.shade),
                                   cols.width, h);
        }
    }
}

const cv_render_pass_module render_pass_reflect = { .name = "reflect",
                                                    .queue = CV_QUEUE_COMPUTE,
                                                    .policy = CV_MGPU_ALL_DEVICES,
                                                    .present = present,
                                                    .declare = declare,
                                                    .record = record };
