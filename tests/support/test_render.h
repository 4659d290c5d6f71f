/* One render on N devices of the test adapter (cv_test_adapter(), validation
 * on), for tests that compare frames across device counts: creates a
 * context, N virtual GPUs, a renderer, renders `settings` into *out (and
 * *stats if not NULL) and destroys them all again, so nothing stays live.
 * What several renderer tests each defined as their own render_on().
 *
 *     cv_render_output two = { 0 };
 *     cv_render_stats stats;
 *     CHECK_OK(cv_test_render(2, scene, bvh, &(cv_render_settings){ .width = 160, .height = 90 },
 *                             &two, &stats));
 *     cv_render_output_free(&two);
 */
#ifndef CORVID_TEST_RENDER_H
#define CORVID_TEST_RENDER_H

#include "corvid/renderer.h"

/* gpus: 1..4. */
cv_result cv_test_render(uint32_t gpus, const cv_scene *scene, const cv_bvh *bvh, const cv_render_settings *settings,
                         cv_render_output *out, cv_render_stats *stats);

#endif
