/* Pass 'reflect_denoise' (primary, last frame, reflections on):
 * REFLECT_DENOISE_ITERATIONS a-trous steps of render.reflect_denoise
 * (render_reflect_denoise.comp) over the reconstructed reflection, ping-pong;
 * the last one's texture is the reflection the composite shows. */
#include "passes.h"

/* Measured on the room at 640x360 against 4096 samples
 * (docs/renderer-quality.md, "Reflections: the denoise pass"):
 * - iterations 2 / 3 / 4: one frame's reflection RMSE 0.0426 / 0.0363 /
 *   0.0359 (seed 1, sigma_l 32); 3 from here on;
 * - sigma_l with the spatial variance (fewer than 8 frames) 2 / 4 / 8 / 16 /
 *   32 / none: 0.0539 / 0.0433 / 0.0389 / 0.0372 / 0.0365 / 0.0363, bias
 *   -0.0043 ... -0.0019 / +0.0004: the signal weight pulls toward the
 *   commonest value (darker: bright samples are rare); 32 keeps real edges a
 *   little at SSIM 0.944 against none's 0.951;
 * - sigma_l with the temporal variance (8 frames on) 4 / 16: 64 frames 0.0113
 *   / 0.0121 (no denoise: 0.0145);
 * - lobe scale 0.5 / 1 / 2 / 4: 0.0452 / 0.0433 / 0.0424 / 0.0420 (sigma_l 4). */
#define REFLECT_DENOISE_ITERATIONS 3
#define REFLECT_DENOISE_SIGMA_L_SPATIAL 32.0f
#define REFLECT_DENOISE_SIGMA_L_TEMPORAL 4.0f
#define REFLECT_DENOISE_LOBE_SCALE 2.0f

enum {
    USE_POSITION,
    USE_NORMAL,
    USE_MATERIAL,
    USE_SAMPLES,
    USE_RECONSTRUCTED,
    USE_PING_READ,
    USE_PING,
    USE_PONG_READ,
    USE_PONG,
};

int render_reflect_shown_texture(void) {
    return REFLECT_DENOISE_ITERATIONS % 2 ? TEX_REFLECT_DENOISE_PING : TEX_REFLECT_DENOISE_PONG;
}

static bool present(const cv_render_frame *f) { return f->info.reflections; }
static bool enabled(const cv_render_frame *f) { return f->info.last; }

static cv_result declare(const cv_render_frame *f, cv_graph_builder *b, cv_graph_use *u, void *user) {
    (void)user;
    static const int reads[5] = { TEX_POSITION, TEX_NORMAL, TEX_MATERIAL, TEX_REFLECT, TEX_REFLECT_OUT };
    for (int i = 0; i < 5; i++)
        u[USE_POSITION + i] = cv_graph_pass_read(b, f->tex[reads[i]], CV_GRAPH_STORAGE_READ);
    for (int k = 0; k < 2; k++) {
        cv_graph_resource t = f->tex[TEX_REFLECT_DENOISE_PING + k];
        u[USE_PING_READ + 2 * k] = cv_graph_pass_read(b, t, CV_GRAPH_STORAGE_READ);
        u[USE_PING + 2 * k] = cv_graph_pass_write(b, t, CV_GRAPH_STORAGE_WRITE, CV_GRAPH_TRANSFER_AUTO);
    }
    return CV_OK;
}

static void record(const cv_render_frame *f, const cv_graph_pass_context *pc, cv_command_list *l,
                   const cv_graph_use *u, void *user) {
    (void)user;
    bool copy = f->info.filter_iterations == 0; /* unfiltered: the reconstruction as it is */
    for (uint32_t i = 0; i < REFLECT_DENOISE_ITERATIONS; i++) {
        int src = i == 0 ? USE_RECONSTRUCTED : (i % 2 ? USE_PING : USE_PONG);
        int dst = i % 2 ? USE_PONG : USE_PING;
        struct {
            uint32_t width, height, step, flags;
            float camera[4];
            float sigma_l_spatial, lobe_scale, pixel_angle, sigma_l_temporal;
        } push = { f->width,
                   f->height,
                   1u << i,
                   (i == 0 ? 1u : 0u) | (i + 1 == REFLECT_DENOISE_ITERATIONS ? 2u : 0u) | (copy ? 4u : 0u),
                   { f->camera.position[0], f->camera.position[1], f->camera.position[2], f->data.diagonal * 0.01f },
                   REFLECT_DENOISE_SIGMA_L_SPATIAL,
                   REFLECT_DENOISE_LOBE_SCALE,
                   render_pixel_angle(f),
                   REFLECT_DENOISE_SIGMA_L_TEMPORAL };
        const int slots[6] = { USE_POSITION, USE_NORMAL, USE_MATERIAL, USE_SAMPLES, src, dst };
        cv_binding b[6];
        for (int k = 0; k < 6; k++)
            b[k] = cv_graph_use_binding(pc, u[slots[k]]);
        render_dispatch_image(f, l, pc->queue, PIPE_REFLECT_DENOISE, b, 6, &push, sizeof(push));
    }
}

const cv_render_pass_module render_pass_reflect_denoise = { .name = "reflect_denoise",
                                                            .queue = CV_QUEUE_COMPUTE,
                                                            .policy = CV_MGPU_PRIMARY_ONLY,
                                                            .present = present,
                                                            .enabled = enabled,
                                                            .declare = declare,
                                                            .record = record };
