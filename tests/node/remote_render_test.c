/* The renderer, untouched, on remote devices: nodes started in this process on
 * loopback serve lavapipe devices; the client reaches them through the proxy
 * backend.
 *  - 1 node x 1 device, and 2 nodes x 2 virtual GPUs, render bit-identically to
 *    the local render on one lavapipe device; so do three progressive steps
 *    after it (cv_renderer_step), their display (the 8-bit image a live view
 *    encodes) read through the encoded path (a frame reader, RAW: on the node
 *    for a proxy primary) before any lossy codec;
 *  - a second render against the same node sends no scene bytes (they come
 *    from the node's content cache) and says how many it skipped;
 *  - a node that dies mid-session makes the client's calls fail with
 *    CV_ERROR_CONNECTION, promptly, and everything is still freed. */
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "corvid/clock.h"
#include "corvid/frame_reader.h"
#include "test_adapter.h"
#include "corvid/proxy.h"
#include "corvid/renderer.h"
#include "corvid/scene_procedural.h"
#include "corvid/vulkan.h"
#include "scratch_node.h"

#define W 128
#define H 72

static cv_render_settings settings(void) {
    return (cv_render_settings){
        .width = W, .height = H, .frames = 2, .ao_samples = 2, .sun_cone_degrees = 1.0f, .filter_iterations = 2
    };
}

/* The display of three steps after a render, read as a live view reads it
 * (the frame reader: on the node when the primary is remote). */
static cv_result step_display(cv_renderer *r, cv_device *primary, uint8_t *display) {
    cv_render_settings s = settings();
    cv_render_step step = { 0 };
    cv_result res = CV_OK;
    for (int k = 0; k < 3 && res == CV_OK; k++)
        res = cv_renderer_step(r, &s, &step);
    cv_frame_reader *reader = NULL;
    cv_encoded frame = { 0 };
    if (res == CV_OK)
        res = cv_frame_reader_create(primary, CV_CODEC_RAW, W, H, &reader);
    if (res == CV_OK)
        res = cv_frame_reader_read(reader, step.display, (cv_rect){ 0, 0, W, H }, &(cv_encode_params){ 0 }, &frame);
    if (res == CV_OK && frame.size != (size_t)W * H * 4)
        res = cv_error(CV_ERROR_MALFORMED, "display: %zu bytes", frame.size);
    if (res == CV_OK)
        memcpy(display, frame.data, frame.size);
    cv_encoded_free(&frame);
    cv_frame_reader_destroy(reader);
    return res;
}

static cv_result render(cv_device **devices, uint32_t count, const cv_scene *scene, const cv_bvh *bvh,
                        cv_render_output *out, uint8_t *display) {
    cv_renderer *r = NULL;
    cv_render_settings s = settings();
    cv_render_stats stats;
    cv_result res = cv_renderer_create(devices, count, scene, bvh, &r);
    if (res == CV_OK)
        res = cv_renderer_render(r, &s, out, &stats, NULL, NULL);
    if (res == CV_OK && display)
        res = step_display(r, devices[0], display);
    cv_renderer_destroy(r);
    return res;
}

static cv_result render_local(const cv_scene *scene, const cv_bvh *bvh, cv_render_output *out, uint8_t *display) {
    cv_context *ctx;
    cv_device *dev = NULL;
    cv_result res = cv_context_create(NULL, &ctx);
    if (res == CV_OK)
        res = cv_device_create(ctx, cv_vulkan_backend(),
                               &(cv_device_desc){ .adapter = cv_test_adapter(), .validation = true }, &dev);
    if (res == CV_OK)
        res = render(&dev, 1, scene, bvh, out, display);
    if (ctx)
        cv_context_destroy(ctx);
    return res;
}

/* Renders on `per_node` devices of each node; stats of device 0's session. */
static cv_result render_remote(scratch_node *nodes, uint32_t node_count, uint32_t per_node, const cv_scene *scene,
                               const cv_bvh *bvh, cv_render_output *out, uint8_t *display, cv_proxy_stats *stats) {
    cv_context *ctx;
    cv_device *devices[8] = { 0 };
    uint32_t count = 0;
    cv_result res = cv_context_create(NULL, &ctx);
    for (uint32_t n = 0; res == CV_OK && n < node_count; n++)
        for (uint32_t d = 0; res == CV_OK && d < per_node; d++) {
            char adapter[16];
            snprintf(adapter, sizeof(adapter), "%u", d);
            cv_device_desc desc = { .endpoint = nodes[n].endpoint, .adapter = adapter };
            snprintf(desc.label, sizeof(desc.label), "node%u.gpu%u", n, d);
            res = cv_device_create(ctx, cv_proxy_backend(), &desc, &devices[count]);
            if (res == CV_OK)
                count++;
        }
    if (res == CV_OK)
        res = render(devices, count, scene, bvh, out, display);
    if (res == CV_OK && stats)
        res = cv_proxy_get_stats(devices[0], stats);
    if (ctx)
        cv_context_destroy(ctx);
    return res;
}

static bool same_image(const cv_render_output *a, const cv_render_output *b) {
    size_t bytes = (size_t)W * H * 4 * sizeof(float);
    return a->radiance && b->radiance && memcmp(a->radiance, b->radiance, bytes) == 0 &&
           memcmp(a->visibility, b->visibility, bytes) == 0 && memcmp(a->normal, b->normal, bytes) == 0;
}

/* A node dies between frames of a render on three devices (the local primary
 * and one device on each of two nodes): the frame it fails in is traced again
 * by the survivors, later frames go on without it, and the image is the one
 * rendered on the primary alone. */
typedef struct loss_plan {
    scratch_node *victim;
    uint32_t after_frame;
} loss_plan;

static void kill_node_after(uint32_t frame, uint32_t frames, void *user) {
    (void)frames;
    loss_plan *plan = user;
    if (frame == plan->after_frame && plan->victim->node)
        scratch_node_stop(plan->victim); /* cancels its sessions: the client sees them end */
}

static void node_loss(const cv_scene *scene, const cv_bvh *bvh) {
    cv_render_settings s = settings();
    s.frames = 4;
    cv_render_stats stats;
    cv_render_output alone = { 0 }, survived = { 0 };
    scratch_node nodes[2];
    CHECK_OK(scratch_node_start(&nodes[0], cv_vulkan_backend(), 1, true));
    CHECK_OK(scratch_node_start(&nodes[1], cv_vulkan_backend(), 1, true));
    cv_context *ctx;
    cv_device *devices[3] = { 0 };
    CHECK_OK(cv_context_create(NULL, &ctx));
    CHECK_OK(cv_device_create(ctx, cv_vulkan_backend(),
                              &(cv_device_desc){ .adapter = cv_test_adapter(), .validation = true }, &devices[0]));
    for (int n = 0; n < 2; n++)
        CHECK_OK(cv_device_create(ctx, cv_proxy_backend(), &(cv_device_desc){ .endpoint = nodes[n].endpoint },
                                  &devices[1 + n]));
    cv_renderer *r = NULL;
    if (devices[0] && devices[1] && devices[2]) {
        /* The primary alone first: the image the loss must not change. */
        CHECK_OK(cv_renderer_create(devices, 1, scene, bvh, &r));
        CHECK_OK(cv_renderer_render(r, &s, &alone, &stats, NULL, NULL));
        cv_renderer_destroy(r);
        r = NULL;
        loss_plan plan = { .victim = &nodes[1], .after_frame = 2 };
        CHECK_OK(cv_renderer_create(devices, 3, scene, bvh, &r));
        CHECK_OK(cv_renderer_render(r, &s, &survived, &stats, kill_node_after, &plan));
        CHECK_EQ_INT(stats.devices_lost, 1);
        CHECK_EQ_INT(stats.device_count, 2);
        CHECK(cv_device_is_lost(devices[2]));
        CHECK(!cv_device_is_lost(devices[1]));
        CHECK(same_image(&alone, &survived));
        cv_renderer_destroy(r);
    }
    cv_context_destroy(ctx);
    CHECK_EQ_INT(scratch_node_wait_sessions(&nodes[0], 5000), 0);
    scratch_node_stop(&nodes[0]);
    scratch_node_stop(&nodes[1]);
    cv_render_output_free(&alone);
    cv_render_output_free(&survived);
}

/* The node goes away under a live session. */
static void node_death(void) {
    scratch_node n;
    CHECK_OK(scratch_node_start(&n, cv_mock_backend(), 1, false));
    cv_context *ctx;
    cv_device *dev;
    CHECK_OK(cv_context_create(NULL, &ctx));
    CHECK_OK(cv_device_create(ctx, cv_proxy_backend(), &(cv_device_desc){ .endpoint = n.endpoint }, &dev));
    cv_buffer b;
    CHECK_OK(cv_buffer_create(ctx, &(cv_buffer_desc){ .size = 64 }, &b));
    CHECK_OK(cv_device_load(dev, cv_any(b)));
    scratch_node_stop_keep(&n, false); /* cancels the session: the client sees the stream end */
    uint8_t out[64];
    double t0 = cv_now_ms() / 1e3;
    CHECK_RESULT(cv_device_read_buffer(dev, b, 0, 64, out), CV_ERROR_CONNECTION);
    CHECK(cv_now_ms() / 1e3 - t0 < 10.0);
    CHECK(strstr(cv_last_error(), n.endpoint) != NULL);
    cv_context_destroy(ctx);
    /* Nothing listens there now: a new device fails with CONNECTION, naming the node. */
    CHECK_OK(cv_context_create(NULL, &ctx));
    t0 = cv_now_ms() / 1e3;
    CHECK_RESULT(cv_device_create(ctx, cv_proxy_backend(), &(cv_device_desc){ .endpoint = n.endpoint }, &dev),
                 CV_ERROR_CONNECTION);
    CHECK(cv_now_ms() / 1e3 - t0 < 15.0);
    cv_context_destroy(ctx);
}

int main(void) {
    cv_scene *scene = NULL;
    cv_bvh *bvh = NULL;
    CHECK_OK(cv_scene_make_room(1, &scene));
    CHECK_OK(cv_bvh_build_flat(scene, NULL, &bvh));
    if (!scene || !bvh)
        return check_report("node_remote_render");

    cv_render_output local = { 0 }, one = { 0 }, again = { 0 }, four = { 0 };
    static uint8_t local_display[W * H * 4], one_display[W * H * 4], four_display[W * H * 4];
    CHECK_OK(render_local(scene, bvh, &local, local_display));

    scratch_node nodes[2];
    CHECK_OK(scratch_node_start(&nodes[0], cv_vulkan_backend(), 2, true));
    CHECK_OK(scratch_node_start(&nodes[1], cv_vulkan_backend(), 2, true));

    cv_proxy_stats first, second;
    CHECK_OK(render_remote(nodes, 1, 1, scene, bvh, &one, one_display, &first));
    CHECK(same_image(&local, &one));
    CHECK(memcmp(local_display, one_display, sizeof(one_display)) == 0);
    CHECK(first.upload_bytes_sent > 0);

    /* The same scene again, in a new session: every byte comes from the cache. */
    CHECK_OK(render_remote(nodes, 1, 1, scene, bvh, &again, NULL, &second));
    CHECK(same_image(&local, &again));
    CHECK_EQ_INT(second.upload_bytes_sent, 0);
    CHECK(second.upload_bytes_skipped >= first.upload_bytes_sent);

    CHECK_OK(render_remote(nodes, 2, 2, scene, bvh, &four, four_display, NULL));
    CHECK(same_image(&local, &four));
    CHECK(memcmp(local_display, four_display, sizeof(four_display)) == 0);
    /* Not a display of nothing: the room's lit and shadowed texels give many levels. */
    bool seen[256] = { false };
    uint32_t levels = 0;
    for (size_t i = 0; i < sizeof(local_display); i++)
        levels += !seen[local_display[i]] ? (seen[local_display[i]] = true) : 0;
    CHECK(levels > 64);

    for (int i = 0; i < 2; i++) {
        CHECK_EQ_INT(scratch_node_wait_sessions(&nodes[i], 5000), 0);
        scratch_node_stop(&nodes[i]);
    }
    node_loss(scene, bvh);
    node_death();
    CHECK_EQ_INT(cv_vulkan_validation_message_count(), 0);
    cv_render_output_free(&local);
    cv_render_output_free(&one);
    cv_render_output_free(&again);
    cv_render_output_free(&four);
    cv_bvh_destroy(bvh);
    cv_scene_destroy(scene);
    return check_report("node_remote_render");
}
