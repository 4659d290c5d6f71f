/* The hybrid renderer on 1, 2, 3 and 4 virtual GPUs (lavapipe, validation on)
 * with every cross-device transfer forced onto each path in turn through
 * CORVID_TRANSFER_PATH (staged, host-import, shared; with
 * CORVID_VGPU_DEVICE=shared also device and auto): radiance and visibility
 * must be bit-identical to the one-device frame, and validation silent.
 * FRAMES frames, more than CV_GRAPH_FRAMES_KEPT: on host-import and shared
 * the frames are pipelined with asynchronous transfers (every list set and
 * ring slot reused several times, the balancer fed from lagged frames, the
 * last frame collecting the pending ones). */
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "test_render.h"
#include "corvid/renderer.h"
#include "corvid/scene_procedural.h"
#include "corvid/transfer.h"
#include "corvid/vulkan.h"

#define W 160
#define H 90
#define FRAMES 12

static cv_result render_on(uint32_t gpus, const cv_scene *scene, const cv_bvh *bvh, cv_render_output *out,
                           cv_render_stats *stats) {
    cv_render_settings s = {
        .width = W, .height = H, .frames = FRAMES, .ao_samples = 2, .sun_cone_degrees = -1, .filter_iterations = -1
    };
    return cv_test_render(gpus, scene, bvh, &s, out, stats);
}

int main(void) {
    cv_scene *scene = NULL;
    cv_bvh *bvh = NULL;
    CHECK_OK(cv_scene_make_room(1, &scene));
    CHECK_OK(cv_bvh_build_flat(scene, NULL, &bvh));
    if (!scene || !bvh)
        return check_report("renderer_transfer_paths");
    size_t bytes = (size_t)W * H * 4 * sizeof(float);
    cv_render_output one = { 0 };
    cv_render_stats stats;
    unsetenv("CORVID_TRANSFER_PATH");
    CHECK_OK(render_on(1, scene, bvh, &one, &stats));
    CHECK(stats.setup_ms == 0); /* one device: no rings, no set-up bake */
    /* With the virtual GPUs on one VkDevice (CORVID_VGPU_DEVICE=shared, ctest's
     * renderer_transfer_paths_shared) the direct path too, and auto (which takes it). */
    const char *vgpu = getenv("CORVID_VGPU_DEVICE");
    bool shared = vgpu && strcmp(vgpu, "shared") == 0;
    const char *paths[] = { "staged", "host-import", "shared", "device", "auto" };
    for (int p = 0; p < (shared ? 5 : 3); p++) {
        setenv("CORVID_TRANSFER_PATH", paths[p], 1);
        for (uint32_t gpus = 2; gpus <= 4; gpus++) {
            cv_render_output many = { 0 };
            CHECK_OK(render_on(gpus, scene, bvh, &many, &stats));
            CHECK_EQ_INT(stats.device_count, gpus);
            CHECK(stats.transfer_bytes > 0);
            CHECK_EQ_INT(stats.frames, FRAMES);
            CHECK(stats.setup_ms > 0); /* a new multi-device graph: baked once before the frames (its rings) */
            /* Every frame's visibility columns of the secondaries reached the primary (collected frames too). */
            CHECK(stats.transfer_bytes >= (uint64_t)FRAMES * 8 * H * 8);
            bool same = one.radiance && many.radiance && memcmp(one.radiance, many.radiance, bytes) == 0 &&
                        memcmp(one.visibility, many.visibility, bytes) == 0;
            CHECK(same);
            fprintf(stderr, "%s, %u devices: %s, %.1f MB moved in %.1f ms\n", paths[p], gpus,
                    same ? "bit-identical" : "DIFFERENT", stats.transfer_bytes / 1e6, stats.transfer_ms);
            cv_render_output_free(&many);
        }
    }
    unsetenv("CORVID_TRANSFER_PATH");
    cv_render_output_free(&one);
    cv_bvh_destroy(bvh);
    cv_scene_destroy(scene);
    CHECK_EQ_INT(cv_vulkan_validation_message_count(), 0);
    CHECK_NOTHING_LIVE();
    return check_report("renderer_transfer_paths");
}
