/* Pass 'present' (primary, whenever 'composite' runs): the composite's linear
 * HDR radiance tone-mapped for a screen into one image of the display ring
 * (render_present.comp): times 2^settings.exposure, ACES, sRGB-encoded to
 * RGBA8, as image/'s cv_tonemap_to_srgb8 with CV_TONEMAP_ACES does it on the
 * CPU (within 1 in 255). The ring (RENDER_DISPLAY_SLOTS images, frame.h's
 * TEX_DISPLAY) lets a reader encode one image while the next frames render
 * into the others. */
#include <math.h>

#include "passes.h"

enum {
    USE_RADIANCE,
    USE_DISPLAY, /* + slot: the pass writes one of them a frame (f->display_slot) */
};

static bool enabled(const cv_render_frame *f) { return f->info.last; }

/* Every image of the ring is declared written, so the graph keeps the pass
 * (they are outputs); the dispatch binds only this frame's. The others are
 * named in no command (nothing else touches them, so the graph places no
 * barrier on them), so a reader of one waits only for the frame that wrote it. */
static cv_result declare(const cv_render_frame *f, cv_graph_builder *b, cv_graph_use *u, void *user) {
    (void)user;
    u[USE_RADIANCE] = cv_graph_pass_read(b, f->tex[TEX_RADIANCE], CV_GRAPH_STORAGE_READ);
    for (uint32_t i = 0; i < RENDER_DISPLAY_SLOTS; i++)
        u[USE_DISPLAY + i] = cv_graph_pass_write(b, f->tex[TEX_DISPLAY + i], CV_GRAPH_STORAGE_WRITE,
                                                 CV_GRAPH_TRANSFER_AUTO);
    return CV_OK;
}

static void record(const cv_render_frame *f, const cv_graph_pass_context *pc, cv_command_list *l,
                   const cv_graph_use *u, void *user) {
    (void)user;
    /* The scale as the CPU's tone map computes it (exp2f of the exposure), so both multiply by the same float. */
    struct {
        uint32_t width, height;
        float scale, pad;
    } push = { f->width, f->height, exp2f(f->settings.exposure), 0.0f };
    cv_binding b[2] = { cv_graph_use_binding(pc, u[USE_RADIANCE]),
                        cv_graph_use_binding(pc, u[USE_DISPLAY + f->display_slot]) };
    render_dispatch_image(f, l, pc->queue, PIPE_PRESENT, b, 2, &push, sizeof(push));
}

const cv_render_pass_module render_pass_present = { .name = "present",
                                                    .queue = CV_QUEUE_COMPUTE,
                                                    .policy = CV_MGPU_PRIMARY_ONLY,
                                                    .enabled = enabled,
                                                    .declare = declare,
                                                    .record = record };
