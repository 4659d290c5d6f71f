/* The renderer's pass modules (one file each in passes/, listed in
 * pass_table.h) and what more than one of them, or the frame around them,
 * needs to know of another: which texture holds a pass's result, and the
 * alpha-mask rule's rounds that 'trace' and 'reflect' both record. */
#ifndef CORVID_RENDER_PASSES_H
#define CORVID_RENDER_PASSES_H

#include "frame.h"
#include "pass_table.h"

#define RENDER_PASS_DECLARE(name) extern const cv_render_pass_module render_pass_##name;
CV_RENDER_PASS_TABLE(RENDER_PASS_DECLARE)
#undef RENDER_PASS_DECLARE

/* The texture holding the final visibility after `iterations` filter steps
 * (passes/filter.c). */
int render_filtered_texture(uint32_t iterations);
/* The texture holding the reflection shown: the last denoise iteration's
 * (passes/reflect_denoise.c). */
int render_reflect_shown_texture(void);

/* The scene buffers the alpha-mask rule reads (the hits' materials). */
typedef struct render_alpha_uses {
    cv_graph_use vertices, instances, uvs, materials, image_table, image_pool;
} render_alpha_uses;

/* The alpha-mask rule for the `count` rays of a band just traced into `hits`
 * (any_hit: with CV_TRACE_ANY_HIT): render.alpha_continue (round 0 on `hits`),
 * then render_alpha_retraces() times a closest-hit re-trace into `scratch`
 * and the next round; the hits that stand end in `hits`, and the rays' tmin
 * is spent (render_alpha_continue.comp). Recorded only for a masked scene
 * (passes/alpha_rounds.c). */
void render_record_alpha_rounds(const cv_render_frame *f, const cv_graph_pass_context *pc, cv_command_list *l,
                                const render_alpha_uses *scene, cv_buffer rays, cv_buffer hits, cv_buffer scratch,
                                uint32_t count, bool any_hit);

#endif
