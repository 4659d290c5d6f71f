/* The hybrid renderer on 1, 2, 3 and 4 virtual GPUs (lavapipe, validation on)
 * with every cross-device transfer forced onto each path in turn through
 * cv_transfer_set_path (staged, host-import, shared; with
 * CORVID_VGPU_DEVICE=shared also device), and with zero-copy gathers
 * (cv_render_settings.zero_copy on: visibility and reflection samples traced straight
 * into the primary's memory): radiance and visibility must be bit-identical
 * to the one-device frame, and validation silent.
 * FRAMES frames, more than CV_GRAPH_FRAMES_KEPT: on host-import and shared
 * the frames are pipelined with asynchronous transfers (every list set and
 * ring slot reused several times, the balancer fed from lagged frames, the
 * last frame collecting the pending ones).
 * Bytes moved, exactly, per frame (OBSERVED_FRAMES frames with an observer,
 * which reports every transfer step of every frame; also bit-identical to one
 * device): the visibility copy-back moves the secondaries' columns only, 4
 * bytes a pixel (render_visibility.glsl's R32_UINT texel); the reflection
 * samples' copy-back their columns, 8 bytes a pixel (RGBA16F); the G-buffer
 * multicast of frame 0 whole images (later frames trace it in windows that
 * move), position, normal and material, 16 bytes a pixel each, to every
 * secondary. A moving camera (2 devices, path auto, still bit-identical to
 * one device) renders the G-buffer every frame and sends each secondary only
 * that frame's window of it.
 * The zero-copy fallback (cv_graph_bake, zero-copy auto: a texture the
 * adapter cannot export is gathered by copies, the others still shared):
 * devices of a backend that refuses to alias the reflection samples copy
 * exactly those back, 8 bytes a pixel of the secondaries' columns, move no
 * visibility byte, and still give one device's bytes. */
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "test_adapter.h"
#include "test_render.h"
#include "corvid/backend.h"
#include "corvid/renderer.h"
#include "corvid/scene_procedural.h"
#include "corvid/transfer.h"
#include "corvid/vulkan.h"

#define W 160
#define H 90
#define FRAMES 12
#define OBSERVED_FRAMES 3

/* What the observer saw of one render's transfers. */
typedef struct transfer_check {
    uint32_t gpus;
    bool moving;            /* the camera moves: the G-buffer goes out every frame, windows only */
    bool zero_copy;         /* gathers through shared memory: visibility and reflection samples move no byte */
    bool reflection_copied; /* with zero_copy: the reflection samples could not be shared, and are copied */
    uint32_t frames;
    uint32_t visibility, reflection, gbuffer; /* transfer steps seen */
    uint32_t wrong;                           /* steps whose bytes were not the expected ones */
} transfer_check;

static void check_bytes(transfer_check *c, const cv_graph_timing *t, uint64_t want) {
    if (t->bytes == want)
        return;
    c->wrong++;
    fprintf(stderr, "%u devices: %s moved %llu bytes, not %llu\n", c->gpus, t->name, (unsigned long long)t->bytes,
            (unsigned long long)want);
}

static void observe_frame(const cv_render_frame_info *f, void *user) {
    transfer_check *c = user;
    c->frames++;
    uint64_t secondary_columns = W - f->columns[0].width; /* the primary's window is never copied */
    for (uint32_t i = 0; i < f->timing_count; i++) {
        const cv_graph_timing *t = &f->timings[i];
        if (strcmp(t->name, "transfer 'visibility'") == 0) {
            c->visibility++;
            check_bytes(c, t, c->zero_copy ? 0 : secondary_columns * H * 4);
        } else if (strcmp(t->name, "transfer 'reflection samples'") == 0) {
            c->reflection++;
            check_bytes(c, t, c->zero_copy && !c->reflection_copied ? 0 : secondary_columns * H * 8); /* RGBA16F */
        } else if (strcmp(t->name, "transfer 'gbuffer position'") == 0 ||
                   strcmp(t->name, "transfer 'gbuffer normal'") == 0 ||
                   strcmp(t->name, "transfer 'gbuffer material'") == 0) {
            c->gbuffer++;
            check_bytes(c, t, c->moving ? secondary_columns * H * 16 : (uint64_t)(c->gpus - 1) * W * H * 16);
        } else if (strncmp(t->name, "transfer", 8) == 0) {
            c->wrong++;
            fprintf(stderr, "%u devices: unexpected %s (%llu bytes)\n", c->gpus, t->name,
                    (unsigned long long)t->bytes);
        }
    }
}

/* The zero-copy choice of the renders below (cv_render_settings.zero_copy). */
static cv_graph_zero_copy zero_copy_choice = CV_GRAPH_ZERO_COPY_AUTO;

static cv_result render_on(uint32_t gpus, const cv_scene *scene, const cv_bvh *bvh, cv_render_output *out,
                           cv_render_stats *stats, const cv_render_observer *observer, bool moving) {
    cv_render_settings s = { .width = W,
                             .height = H,
                             .frames = observer ? OBSERVED_FRAMES : FRAMES,
                             .ao_samples = 2,
                             .sun_cone_degrees = -1,
                             .filter_iterations = -1,
                             .orbit_degrees = moving ? 1.0f : 0.0f,
                             .observer = observer,
                             .zero_copy = zero_copy_choice };
    return cv_test_render(gpus, scene, bvh, &s, out, stats);
}

/* The Vulkan backend, but a texture labelled "reflection samples" cannot be
 * aliased (as if the adapter could not export it). */
static cv_result alias_but_reflection(cv_backend_device *bd, uint64_t id, const cv_resource_desc *desc,
                                      cv_backend_device *src_bd, void *src_obj, void **out_obj) {
    if (strcmp(desc->texture.label, "reflection samples") == 0)
        return cv_error(CV_ERROR_UNSUPPORTED, "test: texture '%s' cannot be exported", desc->texture.label);
    return cv_vulkan_backend()->resource_alias(bd, id, desc, src_bd, src_obj, out_obj);
}

static void check_zero_copy_fallback(const cv_scene *scene, const cv_bvh *bvh, const cv_render_output *alone) {
    cv_backend refusing = *cv_vulkan_backend();
    refusing.resource_alias = alias_but_reflection;
    cv_context *ctx = NULL;
    cv_device *devices[2] = { NULL, NULL };
    CHECK_OK(cv_context_create(NULL, &ctx));
    for (int d = 0; d < 2 && ctx; d++) {
        cv_device_desc desc = { .adapter = cv_test_adapter(), .validation = true };
        snprintf(desc.label, sizeof desc.label, "gpu%d", d);
        CHECK_OK(cv_device_create(ctx, &refusing, &desc, &devices[d]));
    }
    transfer_check c = { .gpus = 2, .zero_copy = true, .reflection_copied = true };
    cv_render_settings s = { .width = W,
                             .height = H,
                             .frames = OBSERVED_FRAMES,
                             .ao_samples = 2,
                             .sun_cone_degrees = -1,
                             .filter_iterations = -1,
                             .observer = &(cv_render_observer){ .frame = observe_frame, .user = &c } };
    cv_renderer *r = NULL;
    cv_render_output out = { 0 };
    if (devices[0] && devices[1]) {
        CHECK_OK(cv_renderer_create(devices, 2, scene, bvh, &r));
        if (r)
            CHECK_OK(cv_renderer_render(r, &s, &out, NULL, NULL, NULL));
    }
    cv_renderer_destroy(r);
    CHECK_EQ_INT(c.frames, OBSERVED_FRAMES);
    CHECK_EQ_INT(c.visibility, OBSERVED_FRAMES);
    CHECK_EQ_INT(c.reflection, OBSERVED_FRAMES);
    CHECK_EQ_INT(c.wrong, 0);
    size_t bytes = (size_t)W * H * 4 * sizeof(float);
    bool same = alone->radiance && out.radiance && memcmp(alone->radiance, out.radiance, bytes) == 0 &&
                memcmp(alone->visibility, out.visibility, bytes) == 0 &&
                memcmp(alone->reflection, out.reflection, bytes) == 0;
    CHECK(same);
    fprintf(stderr, "zero-copy with the reflection samples unshareable, 2 devices: %s\n",
            same ? "bit-identical, the reflection samples copied" : "DIFFERENT");
    cv_render_output_free(&out);
    cv_context_destroy(ctx);
}

int main(void) {
    cv_scene *scene = NULL;
    cv_bvh *bvh = NULL;
    CHECK_OK(cv_scene_make_room(1, &scene));
    CHECK_OK(cv_bvh_build_flat(scene, NULL, &bvh));
    if (!scene || !bvh)
        return check_report("renderer_transfer_paths");
    size_t bytes = (size_t)W * H * 4 * sizeof(float);
    cv_render_output one = { 0 }, one_observed = { 0 };
    cv_render_stats stats;
    cv_transfer_clear_path();
    CHECK_OK(render_on(1, scene, bvh, &one, &stats, NULL, false));
    CHECK(stats.setup_ms == 0); /* one device: no rings, no set-up bake */
    transfer_check alone = { .gpus = 1 };
    CHECK_OK(render_on(1, scene, bvh, &one_observed, &stats,
                       &(cv_render_observer){ .frame = observe_frame, .user = &alone }, false));
    CHECK_EQ_INT(alone.frames, OBSERVED_FRAMES);
    CHECK_EQ_INT(alone.visibility + alone.reflection + alone.gbuffer + alone.wrong, 0); /* nothing moves */
    /* With the virtual GPUs on one VkDevice (CORVID_VGPU_DEVICE=shared, ctest's
     * renderer_transfer_paths_shared) the direct path too. "zero-copy": the
     * path left to auto with zero_copy on (graph.h): the gathers are
     * GPU-side waits on shared memory; a forced path turns it off. */
    const char *vgpu = getenv("CORVID_VGPU_DEVICE");
    bool shared = vgpu && strcmp(vgpu, "shared") == 0;
    const char *paths[] = { "staged", "host-import", "shared", "device", "zero-copy" };
    /* Separate VkDevices: the three memory paths and zero-copy; one VkDevice:
     * the paths that differ there (staged and host-import are the same code
     * either way). */
    for (int p = shared ? 2 : 0; p < 5; p++) {
        bool zero_copy = strcmp(paths[p], "zero-copy") == 0;
        if (p == 3 && !shared)
            continue; /* the device path needs one VkDevice */
        cv_transfer_path forced;
        CHECK_OK(cv_transfer_path_parse(zero_copy ? "auto" : paths[p], &forced));
        CHECK_OK(cv_transfer_set_path(forced));
        zero_copy_choice = zero_copy ? CV_GRAPH_ZERO_COPY_ON : CV_GRAPH_ZERO_COPY_AUTO;
        /* Sanitizer builds: 2 and 3 (an even and an uneven split), not 4 as well. */
        for (uint32_t gpus = 2; gpus <= CV_TEST_REPEATS(4u, 3u); gpus++) {
            cv_render_output many = { 0 };
            CHECK_OK(render_on(gpus, scene, bvh, &many, &stats, NULL, false));
            CHECK_EQ_INT(stats.device_count, gpus);
            CHECK(stats.transfer_bytes > 0);
            CHECK_EQ_INT(stats.frames, FRAMES);
            CHECK(stats.setup_ms > 0); /* a new multi-device graph: baked once before the frames (its rings) */
            /* Every frame's visibility columns of the secondaries reached the primary (collected frames too);
             * with zero-copy only frame 0's G-buffer moves, 3 images of 16 bytes a pixel to each secondary. */
            if (zero_copy)
                CHECK_EQ_INT(stats.transfer_bytes, (uint64_t)(gpus - 1) * 3 * W * H * 16);
            else
                CHECK(stats.transfer_bytes >= (uint64_t)FRAMES * 8 * H * 8);
            bool same = one.radiance && many.radiance && memcmp(one.radiance, many.radiance, bytes) == 0 &&
                        memcmp(one.visibility, many.visibility, bytes) == 0;
            CHECK(same);
            fprintf(stderr, "%s, %u devices: %s, %.1f MB moved in %.1f ms\n", paths[p], gpus,
                    same ? "bit-identical" : "DIFFERENT", stats.transfer_bytes / 1e6, stats.transfer_ms);
            cv_render_output_free(&many);
            /* Exact bytes of every transfer step of every frame (sanitizer
             * builds: on 2 devices; the byte rule is the same on 3). */
            if (gpus > CV_TEST_REPEATS(4u, 2u))
                continue;
            transfer_check c = { .gpus = gpus, .zero_copy = zero_copy };
            cv_render_output observed = { 0 };
            CHECK_OK(render_on(gpus, scene, bvh, &observed, &stats,
                               &(cv_render_observer){ .frame = observe_frame, .user = &c }, false));
            CHECK_EQ_INT(c.frames, OBSERVED_FRAMES);
            CHECK_EQ_INT(c.visibility, OBSERVED_FRAMES);
            CHECK_EQ_INT(c.reflection, OBSERVED_FRAMES);
            CHECK_EQ_INT(c.gbuffer, 3); /* frame 0: position, normal and material (the reflect pass reads them) */
            CHECK_EQ_INT(c.wrong, 0);
            CHECK(one_observed.radiance && observed.radiance &&
                  memcmp(one_observed.radiance, observed.radiance, bytes) == 0 &&
                  memcmp(one_observed.visibility, observed.visibility, bytes) == 0);
            cv_render_output_free(&observed);
        }
    }
    cv_transfer_clear_path();
    zero_copy_choice = CV_GRAPH_ZERO_COPY_AUTO;
    /* A moving camera: the G-buffer every frame, each secondary gets its window
     * of it; the gathers zero-copy (auto, on lavapipe's separate VkDevices and
     * on one VkDevice alike). */
    cv_render_output moving_one = { 0 }, moving_two = { 0 };
    transfer_check moving = { .gpus = 2, .moving = true, .zero_copy = true },
                   moving_alone = { .gpus = 1, .moving = true };
    CHECK_OK(render_on(1, scene, bvh, &moving_one, &stats,
                       &(cv_render_observer){ .frame = observe_frame, .user = &moving_alone }, true));
    CHECK_EQ_INT(moving_alone.gbuffer + moving_alone.visibility + moving_alone.reflection + moving_alone.wrong, 0);
    CHECK_OK(render_on(2, scene, bvh, &moving_two, &stats,
                       &(cv_render_observer){ .frame = observe_frame, .user = &moving }, true));
    CHECK_EQ_INT(moving.frames, OBSERVED_FRAMES);
    CHECK_EQ_INT(moving.gbuffer, 3 * OBSERVED_FRAMES); /* position, normal, material: every frame */
    CHECK_EQ_INT(moving.visibility, OBSERVED_FRAMES);
    CHECK_EQ_INT(moving.reflection, OBSERVED_FRAMES);
    CHECK_EQ_INT(moving.wrong, 0);
    CHECK(moving_one.radiance && moving_two.radiance &&
          memcmp(moving_one.radiance, moving_two.radiance, bytes) == 0 &&
          memcmp(moving_one.reflection, moving_two.reflection, bytes) == 0 &&
          memcmp(moving_one.visibility, moving_two.visibility, bytes) == 0);
    fprintf(stderr, "moving camera, 2 devices: %s, %.1f MB moved\n",
            moving_one.radiance && moving_two.radiance && memcmp(moving_one.radiance, moving_two.radiance, bytes) == 0
                ? "bit-identical"
                : "DIFFERENT",
            stats.transfer_bytes / 1e6);
    cv_render_output_free(&moving_one);
    cv_render_output_free(&moving_two);
    check_zero_copy_fallback(scene, bvh, &one_observed);
    cv_render_output_free(&one);
    cv_render_output_free(&one_observed);
    cv_bvh_destroy(bvh);
    cv_scene_destroy(scene);
    CHECK_EQ_INT(cv_vulkan_validation_message_count(), 0);
    CHECK_NOTHING_LIVE();
    return check_report("renderer_transfer_paths");
}
