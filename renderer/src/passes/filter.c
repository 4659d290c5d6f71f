/* Pass 'filter' (primary, last frame, filter_iterations > 0): variance-guided
 * a-trous iterations over the accumulated shadow and AO (steps 1, 2, 4, ...;
 * render_filter.comp), history -> ping -> pong -> ping ... */
#include <math.h>

#include "passes.h"

/* sigma_l: SVGF's 4; 8 while the variance is the spatial estimate (fewer
 * than 4 frames), where 4 stopped at noise it could have smoothed: room
 * 160x90, one frame, against 4096 samples, 8 took shadow / AO RMSE from
 * 0.0262 / 0.0467 to 0.0252 / 0.0458 (16 and 32 gained less than 0.0005
 * more); at 64 frames 8 blurred (AO 0.0043 -> 0.0057).
 * Converged: a channel whose variance of the mean is below FILTER_CONVERGED_STD^2
 * (standard error 0.02; a binary shadow ray gets there by 625 frames) is left
 * unfiltered.
 * Shadow sigma: FILTER_PENUMBRA_SIGMA x P^(2/3) x footprint^(1/3), P the
 * penumbra's width (render_filter.comp). A sigma of a fixed number of
 * penumbra widths was best at 2 at 64x36 and 160x90, at 1 at 640x360 (the
 * room; docs/renderer-quality.md, "Filter reach from the pixel footprint");
 * the constant 1 / 1.5 / 1.75 / 2 / 3 measured from 64x36 to 640x360 and on
 * the glTF engine: 1.75 is within 0.0017 of the best at every size. With
 * shadow_samples rays a frame the whole sigma (floors included) is divided
 * by sqrt(shadow_samples), as the noise is: one frame of the glTF engine at
 * 640x360, 2 / 4 / 8 rays, was best at 0.7 / 0.5 / 0.35 of the one-ray sigma
 * (docs/renderer-quality.md, "AO: a local linear fit; shadow rays per
 * pixel").
 * AO sigma: FILTER_AO_SIGMA x sqrt(4 / ao_samples) x ao_radius^(2/3) x
 * footprint^(1/3) (render_filter.comp). The AO's estimate is a local linear
 * fit, not a weighted mean, which lets the kernel be wider than the mean's
 * best (0.7 with 4 rays) without the mean's bias at creases: with the fit,
 * 1 / 1.5 / 2 (x 0.7) measured on the room and the glTF engine at 640x360,
 * and 1 and 16 rays a frame (docs/renderer-quality.md, same section). */
#define FILTER_SIGMA_L 4.0f
#define FILTER_SIGMA_L_SPATIAL 8.0f
#define FILTER_CONVERGED_STD 0.02f
#define FILTER_PENUMBRA_SIGMA 1.75f
#define FILTER_AO_SIGMA 1.05f

enum {
    USE_POSITION,
    USE_NORMAL,
    USE_HISTORY,
    USE_VISIBILITY,
    USE_MOTION, /* moving camera */
    USE_PING,
    USE_PONG, /* two iterations or more */
};

int render_filtered_texture(uint32_t iterations) {
    return iterations == 0 ? TEX_HISTORY : (iterations % 2 ? TEX_PING : TEX_PONG);
}

/* The use of the texture holding the visibility after `iterations` steps. */
static int filtered_use(uint32_t iterations) {
    return iterations == 0 ? USE_HISTORY : (iterations % 2 ? USE_PING : USE_PONG);
}

/* The penumbra's width per unit of blocker distance: 2 tan(cone). */
static float penumbra_scale(const cv_render_frame *f) {
    return 2.0f * tanf(f->settings.sun_cone_degrees * 3.14159265f / 180.0f);
}

static bool present(const cv_render_frame *f) { return f->info.filter_iterations > 0; }
static bool enabled(const cv_render_frame *f) { return f->info.last; }

static cv_result declare(const cv_render_frame *f, cv_graph_builder *b, cv_graph_use *u, void *user) {
    (void)user;
    static const int reads[4] = { TEX_POSITION, TEX_NORMAL, TEX_HISTORY, TEX_VISIBILITY };
    for (int i = 0; i < 4; i++)
        u[USE_POSITION + i] = cv_graph_pass_read(b, f->tex[reads[i]], CV_GRAPH_STORAGE_READ);
    if (f->info.moving)
        u[USE_MOTION] = cv_graph_pass_read(b, f->tex[TEX_MOTION], CV_GRAPH_STORAGE_READ);
    u[USE_PING] = cv_graph_pass_write(b, f->tex[TEX_PING], CV_GRAPH_STORAGE_WRITE, CV_GRAPH_TRANSFER_AUTO);
    if (f->info.filter_iterations > 1)
        u[USE_PONG] = cv_graph_pass_write(b, f->tex[TEX_PONG], CV_GRAPH_STORAGE_WRITE, CV_GRAPH_TRANSFER_AUTO);
    return CV_OK;
}

static void record(const cv_render_frame *f, const cv_graph_pass_context *pc, cv_command_list *l,
                   const cv_graph_use *u, void *user) {
    (void)user;
    const cv_render_settings *s = &f->settings;
    uint32_t iterations = f->info.filter_iterations;
    bool moving = f->info.moving;
    cv_cmd_begin_marker(l, pc->queue, &(cv_begin_marker_args){ .label = "filter" });
    for (uint32_t i = 0; i < iterations; i++) {
        struct {
            uint32_t width, height, step, frames;
            float position_sigma, sigma_l, converged_variance;
            uint32_t flags;
            float penumbra_scale, sigma_l_spatial, pixel_angle, ao_sigma_scale;
            float eye[4];
            float shadow_sigma_scale;
        } push = { f->width,
                   f->height,
                   1u << i,
                   s->frames,
                   f->data.diagonal * 0.01f,
                   FILTER_SIGMA_L,
                   FILTER_CONVERGED_STD * FILTER_CONVERGED_STD,
                   (i == 0 ? 1u : 0u) | (i + 1 == iterations ? 2u : 0u) | (moving ? 4u : 0u),
                   penumbra_scale(f),
                   FILTER_SIGMA_L_SPATIAL,
                   render_pixel_angle(f),
                   FILTER_AO_SIGMA * sqrtf(4.0f / (float)s->ao_samples) * cbrtf(s->ao_radius * s->ao_radius),
                   { f->camera.position[0], f->camera.position[1], f->camera.position[2], FILTER_PENUMBRA_SIGMA },
                   1.0f / sqrtf((float)s->shadow_samples) };
        /* A still camera's history length is `frames` everywhere: no motion texture. */
        const int slots[7] = { USE_POSITION,        USE_NORMAL,  filtered_use(i),
                               filtered_use(i + 1), USE_HISTORY, moving ? USE_MOTION : USE_HISTORY,
                               USE_VISIBILITY };
        cv_binding b[7];
        for (int k = 0; k < 7; k++)
            b[k] = cv_graph_use_binding(pc, u[slots[k]]);
        render_dispatch_image(f, l, pc->queue, PIPE_FILTER, b, 7, &push, sizeof(push));
    }
    cv_cmd_end_marker(l, pc->queue, &(cv_end_marker_args){ 0 });
}

const cv_render_pass_module render_pass_filter = { .name = "filter",
                                                   .queue = CV_QUEUE_COMPUTE,
                                                   .policy = CV_MGPU_PRIMARY_ONLY,
                                                   .present = present,
                                                   .enabled = enabled,
                                                   .declare = declare,
                                                   .record = record };
