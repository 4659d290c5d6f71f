/* Renders on N devices of the test adapter (cv_test_adapter(), validation
 * on), for tests that compare frames across device counts.
 *
 * cv_test_render: one render; creates a context, N virtual GPUs, a renderer,
 * renders `settings` into *out (and *stats if not NULL) and destroys them all
 * again, so nothing stays live. What several renderer tests each defined as
 * their own render_on().
 *
 *     cv_render_output two = { 0 };
 *     cv_render_stats stats;
 *     CHECK_OK(cv_test_render(2, scene, bvh, &(cv_render_settings){ .width = 160, .height = 90 },
 *                             &two, &stats));
 *     cv_render_output_free(&two);
 *
 * cv_test_gpus: many renders on one set of devices. Each context's devices
 * hold a VkInstance, and the instance goes when its last device does, so a
 * test that renders many times through cv_test_render creates an instance
 * (and one for the GPU table) per render; some drivers refuse after a few
 * (NVIDIA: VK_ERROR_INCOMPATIBLE_DRIVER at the sixth). Opened once, the set
 * keeps one instance for all its renders; a render on k of its devices uses
 * the first k, with a renderer of its own (created and destroyed per render).
 *
 *     cv_test_gpus g;
 *     CHECK_OK(cv_test_gpus_open(3, &g));
 *     CHECK_OK(cv_test_gpus_render(&g, 2, scene, bvh, &settings, &out, NULL));
 *     cv_test_gpus_close(&g);
 */
#ifndef CORVID_TEST_RENDER_H
#define CORVID_TEST_RENDER_H

#include "corvid/renderer.h"

/* gpus: 1..4. */
cv_result cv_test_render(uint32_t gpus, const cv_scene *scene, const cv_bvh *bvh, const cv_render_settings *settings,
                         cv_render_output *out, cv_render_stats *stats);

typedef struct cv_test_gpus {
    cv_context *ctx;
    cv_device *devices[4];
    uint32_t count;
} cv_test_gpus;

/* count: 1..4. On failure *out holds nothing (closing it is harmless). */
cv_result cv_test_gpus_open(uint32_t count, cv_test_gpus *out);
/* A render on the first `gpus` (1..g->count) devices of g. */
cv_result cv_test_gpus_render(const cv_test_gpus *g, uint32_t gpus, const cv_scene *scene, const cv_bvh *bvh,
                              const cv_render_settings *settings, cv_render_output *out, cv_render_stats *stats);
/* Destroys the devices and the context; g is zeroed. */
void cv_test_gpus_close(cv_test_gpus *g);

#endif
