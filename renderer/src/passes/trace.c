/* Pass 'trace' (every device, its window): for each band of rows of the
 * window, ray generation, trace (the alpha-mask rule's rounds in a masked
 * scene), resolve into visibility. The primary's accumulate reads the
 * visibility, so the graph copies the secondaries' windows back. */
#include "passes.h"

enum {
    USE_POSITION,
    USE_NORMAL,
    USE_BLUE_NOISE,
    USE_RAYS,
    USE_HITS,
    USE_VISIBILITY,
    USE_VERTICES, /* masked scenes: the alpha-mask rule reads the hits' materials */
    USE_INSTANCES,
    USE_UVS,
    USE_MATERIALS,
    USE_IMAGE_TABLE,
    USE_IMAGE_POOL,
    USE_ALPHA_HITS,
};

static cv_result declare(const cv_render_frame *f, cv_graph_builder *b, cv_graph_use *u, void *user) {
    (void)user;
    u[USE_POSITION] = cv_graph_pass_read(b, f->tex[TEX_POSITION], CV_GRAPH_STORAGE_READ);
    u[USE_NORMAL] = cv_graph_pass_read(b, f->tex[TEX_NORMAL], CV_GRAPH_STORAGE_READ);
    u[USE_BLUE_NOISE] = cv_graph_pass_read(b, f->buf[BUF_BLUE_NOISE], CV_GRAPH_STORAGE_READ);
    uint64_t rays = f->graph_rays;
    u[USE_RAYS] = render_band_buffer(b, "rays", rays * CV_RAY_BYTES);
    u[USE_HITS] = render_band_buffer(b, "hits", rays * CV_HIT_BYTES);
    u[USE_VISIBILITY] = cv_graph_pass_write(b, f->tex[TEX_VISIBILITY], CV_GRAPH_STORAGE_WRITE,
                                            CV_GRAPH_TRANSFER_AUTO);
    if (f->alpha_mask) {
        static const int scene[6] = { BUF_VERTICES,  BUF_INSTANCES,   BUF_UVS,
                                      BUF_MATERIALS, BUF_IMAGE_TABLE, BUF_IMAGE_POOL };
        for (int i = 0; i < 6; i++)
            u[USE_VERTICES + i] = cv_graph_pass_read(b, f->buf[scene[i]], CV_GRAPH_STORAGE_READ);
        u[USE_ALPHA_HITS] = render_band_buffer(b, "alpha hits", rays * CV_HIT_BYTES);
    }
    return CV_OK;
}

static void record(const cv_render_frame *f, const cv_graph_pass_context *pc, cv_command_list *l,
                   const cv_graph_use *u, void *user) {
    (void)user;
    const cv_render_settings *s = &f->settings;
    cv_column_range cols = { pc->x, pc->width };
    cv_buffer rays = cv_graph_use_buffer(pc, u[USE_RAYS]), hits = cv_graph_use_buffer(pc, u[USE_HITS]);
    uint32_t per_pixel = cv_render_rays_per_pixel(s);
    uint32_t rows = render_band_rows(f, s, cols.width);
    cv_binding gen[4] = { cv_graph_use_binding(pc, u[USE_POSITION]), cv_graph_use_binding(pc, u[USE_NORMAL]),
                          cv_graph_use_binding(pc, u[USE_RAYS]), cv_graph_use_binding(pc, u[USE_BLUE_NOISE]) };
    cv_binding res_b[3] = { cv_graph_use_binding(pc, u[USE_HITS]), cv_graph_use_binding(pc, u[USE_RAYS]),
                            cv_graph_use_binding(pc, u[USE_VISIBILITY]) };
    render_alpha_uses alpha = { u[USE_VERTICES],  u[USE_INSTANCES],   u[USE_UVS],
                                u[USE_MATERIALS], u[USE_IMAGE_TABLE], u[USE_IMAGE_POOL] };
    for (uint32_t y0 = 0; y0 < f->height; y0 += rows) {
        uint32_t h = f->height - y0 < rows ? f->height - y0 : rows;
        uint64_t count = (uint64_t)cols.width * h * per_pixel;
        struct {
            uint32_t x0, width, height, ao_samples;
            float sun[4];
            uint32_t frame;
            float ao_radius, bias;
            uint32_t y0, shadow_samples;
        } raygen = { cols.x,
                     cols.width,
                     h,
                     s->ao_samples,
                     { f->sun_direction[0], f->sun_direction[1], f->sun_direction[2],
                       s->sun_cone_degrees * 3.14159265f / 180.0f },
                     s->first_frame + f->info.frame,
                     s->ao_radius,
                     render_ray_offset(&f->data),
                     y0,
                     s->shadow_samples };
        struct {
            uint32_t x0, width, height, ao_samples, y0, shadow_samples, pad[2];
        } resolve = { cols.x, cols.width, h, s->ao_samples, y0, s->shadow_samples, { 0 } };
        render_dispatch_pixels(f, l, pc->queue, PIPE_RAYGEN, gen, 4, &raygen, sizeof(raygen), cols.width, h);
        cv_cmd_trace_rays(
            l, pc->queue,
            &(cv_trace_rays_args){
                .accel = f->accel, .rays = rays, .hits = hits, .count = (uint32_t)count, .flags = CV_TRACE_ANY_HIT });
        if (f->alpha_mask)
            render_record_alpha_rounds(f, pc, l, &alpha, rays, hits, cv_graph_use_buffer(pc, u[USE_ALPHA_HITS]),
                                       (uint32_t)count, true);
        render_dispatch_pixels(f, l, pc->queue, PIPE_RESOLVE, res_b, 3, &resolve, sizeof(resolve), cols.width, h);
    }
}

const cv_render_pass_module render_pass_trace = {
    .name = "trace", .queue = CV_QUEUE_COMPUTE, .policy = CV_MGPU_ALL_DEVICES, .declare = declare, .record = record
};
