/* Pass timings from GPU timestamp queries: a list with nested markers around
 * dispatches, a render pass with a timestamp inside it, and copies. Checks
 * that every pass is reported, in the order the passes began, with starts
 * that never decrease, children inside their parents and timestamps of zero
 * duration; a resubmission reports again; a list without markers has none.
 * Each pass's start on the host's CLOCK_MONOTONIC (host_ms; lavapipe and the
 * NVIDIA driver both offer calibrated timestamps) lies between the host's
 * clock before the submission and after the wait, and host_ms and start_ms
 * agree on the spacing of the passes. Nothing depends on the measured values
 * themselves. */
#include <string.h>
#include <time.h>

#include "vk_test.h"

enum { N = 65536, W = 64, H = 64 };

static double host_now_ms(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec * 1e3 + ts.tv_nsec / 1e6;
}

int main(void) {
    cv_context *ctx;
    cv_device *dev = NULL;
    CHECK_OK(cv_context_create(NULL, &ctx));
    CHECK_OK(vkt_device(ctx, NULL, "timings", &dev));
    if (!dev) {
        cv_context_destroy(ctx); /* with any device it made */
        return check_report("vk_timings");
    }
    CHECK(cv_device_get_info(dev)->gpu_timestamps);
    cv_pipeline fill = vkt_pipeline(ctx, dev, "test.fill_u32");
    cv_pipeline triangle = vkt_pipeline(ctx, dev, "test.triangle");
    cv_buffer buf = vkt_buffer(ctx, dev, 4 * N, 0, "buf"), copy = vkt_buffer(ctx, dev, 4 * N, 0, "copy");
    cv_texture color = vkt_texture(ctx, dev, W, H, CV_FORMAT_RGBA8_UNORM, CV_TEXTURE_USAGE_COLOR_TARGET, "color");
    cv_texture depth = vkt_texture(ctx, dev, W, H, CV_FORMAT_D32F, 0, "depth");
    const float tri[3][4] = { { -1, -1, 0.5f, 1 }, { 1, -1, 0.5f, 1 }, { 0, 1, 0.5f, 1 } };
    cv_buffer vertices = vkt_buffer(ctx, dev, sizeof(tri), 0, "vertices");
    CHECK_OK(cv_device_write_buffer(dev, vertices, 0, sizeof(tri), tri));

    cv_cmdlist list;
    cv_command_list *l;
    CHECK_OK(cv_cmdlist_create(ctx, &list));
    CHECK_OK(cv_cmdlist_begin(ctx, list, &l));
    uint32_t push[2] = { 5, N };
    cv_binding bb = { .resource = cv_any(buf) }, bv = { .resource = cv_any(vertices) };
    const float white[4] = { 1, 1, 1, 1 };
    cv_cmd_begin_marker(l, CV_QUEUE_COMPUTE, &(cv_begin_marker_args){ .label = "frame" });
    cv_cmd_begin_marker(l, CV_QUEUE_COMPUTE, &(cv_begin_marker_args){ .label = "compute" });
    for (int i = 0; i < 4; i++)
        cv_cmd_dispatch(l, CV_QUEUE_COMPUTE,
                        &(cv_dispatch_args){ .pipeline = fill,
                                             .bindings = &bb,
                                             .bindings_count = 1,
                                             .push = push,
                                             .push_size = 8,
                                             .groups_x = N / 64,
                                             .groups_y = 1,
                                             .groups_z = 1 });
    cv_cmd_end_marker(l, CV_QUEUE_COMPUTE, &(cv_end_marker_args){ 0 });
    cv_cmd_begin_marker(l, CV_QUEUE_GRAPHICS, &(cv_begin_marker_args){ .label = "raster" });
    cv_cmd_begin_render_pass(l, CV_QUEUE_GRAPHICS,
                             &(cv_begin_render_pass_args){
                                 .color0 = color, .depth = depth, .clear = 1, .clear_depth = 1.0f });
    cv_cmd_draw(l, CV_QUEUE_GRAPHICS,
                &(cv_draw_args){ .pipeline = triangle,
                                 .bindings = &bv,
                                 .bindings_count = 1,
                                 .push = white,
                                 .push_size = 16,
                                 .vertex_count = 3,
                                 .instance_count = 1 });
    cv_cmd_timestamp(l, CV_QUEUE_GRAPHICS, &(cv_timestamp_args){ .label = "drawn" });
    cv_cmd_end_render_pass(l, CV_QUEUE_GRAPHICS, &(cv_end_render_pass_args){ 0 });
    cv_cmd_end_marker(l, CV_QUEUE_GRAPHICS, &(cv_end_marker_args){ 0 });
    cv_cmd_begin_marker(l, CV_QUEUE_COPY, &(cv_begin_marker_args){ .label = "copy" });
    cv_cmd_copy_buffer(l, CV_QUEUE_COPY, &(cv_copy_buffer_args){ .src = buf, .dst = copy, .size = 4 * N });
    cv_cmd_end_marker(l, CV_QUEUE_COPY, &(cv_end_marker_args){ 0 });
    cv_cmd_end_marker(l, CV_QUEUE_COMPUTE, &(cv_end_marker_args){ 0 });
    CHECK_OK(cv_command_list_end(l));

    static const char *labels[] = { "frame", "compute", "raster", "drawn", "copy" };
    for (int round = 0; round < 2; round++) {
        uint64_t t;
        double before = host_now_ms();
        CHECK_OK(vkt_run(dev, list, &t));
        double after = host_now_ms();
        cv_pass_timing timings[8];
        uint32_t n = 0;
        CHECK_OK(cv_device_timings(dev, t, timings, 8, &n));
        CHECK_EQ_INT(n, 5);
        if (n != 5)
            break;
        for (uint32_t i = 0; i < n; i++) {
            CHECK(strcmp(timings[i].label, labels[i]) == 0);
            CHECK(timings[i].start_ms >= 0 && timings[i].duration_ms >= 0);
            if (i > 0)
                CHECK(timings[i].start_ms >= timings[i - 1].start_ms);
            /* On the host's clock: inside the submission (the calibration's
             * deviation is microseconds; 0.5 ms of slack), spaced as on the GPU. */
            CHECK(timings[i].host_ms >= before - 0.5 && timings[i].host_ms <= after + 0.5);
            double spacing = (timings[i].host_ms - timings[0].host_ms) - (timings[i].start_ms - timings[0].start_ms);
            CHECK(spacing > -1e-3 && spacing < 1e-3);
        }
        if (round == 0)
            fprintf(stderr, "host clock: submitted at %.3f ms, passes from %.3f ms, waited until %.3f ms\n", 0.0,
                    timings[0].host_ms - before, after - before);
        const double slack = 1e-6;
        double frame_end = timings[0].start_ms + timings[0].duration_ms;
        for (uint32_t i = 1; i < n; i++)
            CHECK(timings[i].start_ms + timings[i].duration_ms <= frame_end + slack);
        CHECK(timings[3].duration_ms == 0.0);
        CHECK(timings[3].start_ms >= timings[2].start_ms &&
              timings[3].start_ms <= timings[2].start_ms + timings[2].duration_ms + slack);
        CHECK(timings[2].start_ms >= timings[1].start_ms + timings[1].duration_ms - slack);
        CHECK(timings[4].start_ms >= timings[2].start_ms + timings[2].duration_ms - slack);
        /* Capacity smaller than the passes: the first ones. */
        CHECK_OK(cv_device_timings(dev, t, timings, 2, &n));
        CHECK_EQ_INT(n, 2);
        CHECK(strcmp(timings[1].label, "compute") == 0);
    }

    /* No markers, no timings. */
    CHECK_OK(cv_cmdlist_begin(ctx, list, &l));
    cv_cmd_copy_buffer(l, CV_QUEUE_COPY, &(cv_copy_buffer_args){ .src = buf, .dst = copy, .size = 4 * N });
    CHECK_OK(cv_command_list_end(l));
    uint64_t t;
    CHECK_OK(vkt_run(dev, list, &t));
    cv_pass_timing none[2];
    uint32_t n = 99;
    CHECK_OK(cv_device_timings(dev, t, none, 2, &n));
    CHECK_EQ_INT(n, 0);

    cv_context_destroy(ctx);
    return vkt_report("vk_timings");
}
