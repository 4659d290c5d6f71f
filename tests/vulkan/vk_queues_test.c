/* One list whose commands are meant for all three queue types, with data
 * flowing between them: a buffer filled on the copy queue, transformed on the
 * compute queue, copied on the copy queue again; a texture written by compute,
 * sampled by a graphics-queue dispatch, copied on the copy queue and drawn
 * over in a render pass; markers spanning queue changes. Where the device has
 * compute-only and transfer-only families this becomes several segments on
 * several queues chained by semaphores (on lavapipe, one); either way the
 * results must be exact and the validation layer silent. The list is
 * submitted twice to check the chain also orders submissions. */
#include <stdlib.h>
#include <string.h>

#include "vk_test.h"

enum { N = 4096, W = 48, H = 32 };

static float gradient_ref(uint32_t coord) { return (float)(coord & 255u) / 256.0f; }

int main(void) {
    cv_context *ctx;
    cv_device *dev = NULL;
    CHECK_OK(cv_context_create(NULL, &ctx));
    CHECK_OK(vkt_device(ctx, NULL, "queues", &dev));
    if (!dev) {
        cv_context_destroy(ctx); /* with any device it made */
        return check_report("vk_queues");
    }
    const cv_device_info *info = cv_device_get_info(dev);
    printf("device '%s': separate compute queue %d, separate copy queue %d\n", info->name,
           info->separate_compute_queue, info->separate_copy_queue);
    cv_pipeline saxpy = vkt_pipeline(ctx, dev, "test.saxpy");
    cv_pipeline gradient = vkt_pipeline(ctx, dev, "test.gradient");
    cv_pipeline sample_copy = vkt_pipeline(ctx, dev, "test.sample_copy");
    cv_buffer x = vkt_buffer(ctx, dev, 4 * N, 0, "x"), y = vkt_buffer(ctx, dev, 4 * N, 0, "y");
    cv_buffer out = vkt_buffer(ctx, dev, 4 * N, 0, "out");
    cv_texture grad = vkt_texture(ctx, dev, W, H, CV_FORMAT_RGBA32F,
                                  CV_TEXTURE_USAGE_STORAGE | CV_TEXTURE_USAGE_SAMPLED, "grad");
    cv_texture copy = vkt_texture(ctx, dev, W, H, CV_FORMAT_RGBA32F, CV_TEXTURE_USAGE_STORAGE, "copy");
    cv_texture final = vkt_texture(ctx, dev, W, H, CV_FORMAT_RGBA32F,
                                   CV_TEXTURE_USAGE_STORAGE | CV_TEXTURE_USAGE_COLOR_TARGET, "final");
    cv_sampler nearest = vkt_sampler(ctx, dev, CV_FILTER_NEAREST, CV_ADDRESS_CLAMP);
    float hx[N];
    for (int i = 0; i < N; i++)
        hx[i] = (float)(i % 512);
    CHECK_OK(cv_device_write_buffer(dev, x, 0, sizeof(hx), hx));

    cv_cmdlist list;
    cv_command_list *l;
    CHECK_OK(cv_cmdlist_create(ctx, &list));
    CHECK_OK(cv_cmdlist_begin(ctx, list, &l));
    cv_cmd_begin_marker(l, CV_QUEUE_COPY, &(cv_begin_marker_args){ .label = "all" });
    /* copy: y = 3.0f everywhere */
    float three = 3.0f;
    uint32_t three_bits;
    memcpy(&three_bits, &three, 4);
    cv_cmd_clear_buffer(l, CV_QUEUE_COPY, &(cv_clear_buffer_args){ .buffer = y, .size = 4 * N, .value = three_bits });
    /* compute: y = 2x + y; grad = gradient */
    struct {
        float a;
        uint32_t count;
    } push = { 2.0f, N };
    cv_binding xy[2] = { { .resource = cv_any(x) }, { .resource = cv_any(y) } };
    cv_cmd_dispatch(l, CV_QUEUE_COMPUTE,
                    &(cv_dispatch_args){ .pipeline = saxpy,
                                         .bindings = xy,
                                         .bindings_count = 2,
                                         .push = &push,
                                         .push_size = 8,
                                         .groups_x = N / 64,
                                         .groups_y = 1,
                                         .groups_z = 1 });
    int32_t origin[2] = { 3, 5 };
    cv_binding bg = { .resource = cv_any(grad) };
    cv_cmd_dispatch(l, CV_QUEUE_COMPUTE,
                    &(cv_dispatch_args){ .pipeline = gradient,
                                         .bindings = &bg,
                                         .bindings_count = 1,
                                         .push = origin,
                                         .push_size = 8,
                                         .groups_x = W / 8,
                                         .groups_y = H / 8,
                                         .groups_z = 1 });
    cv_cmd_begin_marker(l, CV_QUEUE_COMPUTE, &(cv_begin_marker_args){ .label = "copies" });
    /* copy: out = y; copy = grad */
    cv_cmd_copy_buffer(l, CV_QUEUE_COPY, &(cv_copy_buffer_args){ .src = y, .dst = out, .size = 4 * N });
    cv_cmd_copy_texture(l, CV_QUEUE_COPY,
                        &(cv_copy_texture_args){ .src = grad, .dst = copy, .width = W, .height = H });
    cv_cmd_end_marker(l, CV_QUEUE_COPY, &(cv_end_marker_args){ 0 });
    /* graphics: final = sample(grad) shifted by one texel, then a render pass loads it and draws nothing */
    int32_t offset[2] = { 1, 0 };
    cv_binding bs[2] = { { .resource = cv_any(grad), .sampler = nearest }, { .resource = cv_any(final) } };
    cv_cmd_dispatch(l, CV_QUEUE_GRAPHICS,
                    &(cv_dispatch_args){ .pipeline = sample_copy,
                                         .bindings = bs,
                                         .bindings_count = 2,
                                         .push = offset,
                                         .push_size = 8,
                                         .groups_x = W / 8,
                                         .groups_y = H / 8,
                                         .groups_z = 1 });
    cv_cmd_begin_render_pass(l, CV_QUEUE_GRAPHICS, &(cv_begin_render_pass_args){ .color0 = final });
    cv_cmd_end_render_pass(l, CV_QUEUE_GRAPHICS, &(cv_end_render_pass_args){ 0 });
    /* compute again, after graphics: y = 2x + y once more */
    cv_cmd_dispatch(l, CV_QUEUE_COMPUTE,
                    &(cv_dispatch_args){ .pipeline = saxpy,
                                         .bindings = xy,
                                         .bindings_count = 2,
                                         .push = &push,
                                         .push_size = 8,
                                         .groups_x = N / 64,
                                         .groups_y = 1,
                                         .groups_z = 1 });
    cv_cmd_end_marker(l, CV_QUEUE_COMPUTE, &(cv_end_marker_args){ 0 });
    CHECK_OK(cv_command_list_end(l));

    float hy[N], hout[N];
    float(*tex)[W][4] = malloc(W * H * 16);
    for (int round = 0; round < 2; round++) {
        uint64_t t;
        CHECK_OK(vkt_run(dev, list, &t));
        CHECK_OK(cv_device_read_buffer(dev, out, 0, sizeof(hout), hout));
        CHECK_OK(cv_device_read_buffer(dev, y, 0, sizeof(hy), hy));
        int wrong = 0;
        for (int i = 0; i < N; i++)
            wrong += hout[i] != 3.0f + 2.0f * hx[i] || hy[i] != 3.0f + 4.0f * hx[i];
        CHECK_EQ_INT(wrong, 0);
        CHECK_OK(cv_device_read_texture(dev, copy, (cv_rect){ 0, 0, W, H }, tex));
        wrong = 0;
        for (uint32_t py = 0; py < H; py++)
            for (uint32_t px = 0; px < W; px++) {
                uint32_t gx = px + 3, gy = py + 5;
                wrong += tex[py][px][0] != gradient_ref(gx) || tex[py][px][1] != gradient_ref(gy) ||
                         tex[py][px][2] != gradient_ref(gx + gy) || tex[py][px][3] != 1.0f;
            }
        CHECK_EQ_INT(wrong, 0);
        CHECK_OK(cv_device_read_texture(dev, final, (cv_rect){ 0, 0, W, H }, tex));
        wrong = 0;
        for (uint32_t py = 0; py < H; py++)
            for (uint32_t px = 0; px < W; px++) {
                uint32_t sx = px + 1 < W ? px + 1 : W - 1; /* clamped */
                wrong += tex[py][px][0] != gradient_ref(sx + 3) || tex[py][px][1] != gradient_ref(py + 5);
            }
        CHECK_EQ_INT(wrong, 0);
        cv_pass_timing timings[4];
        uint32_t n = 0;
        CHECK_OK(cv_device_timings(dev, t, timings, 4, &n));
        CHECK_EQ_INT(n, 2);
        if (n == 2)
            CHECK(strcmp(timings[0].label, "all") == 0 && strcmp(timings[1].label, "copies") == 0 &&
                  timings[1].start_ms >= timings[0].start_ms);
        CHECK_OK(cv_device_write_buffer(dev, x, 0, sizeof(hx), hx));
    }
    free(tex);
    cv_context_destroy(ctx);
    return vkt_report("vk_queues");
}
