/* Data movement between two virtual GPUs (two VkDevices on the one adapter,
 * from the GPU table) and within one: GPU-produced data is moved with
 * cv_transfer_buffer / cv_transfer_texture (a column partition, as multi-GPU
 * tracing copies it back), then with device-local copy commands recorded on
 * the copy queue (buffer, texture, buffer<->texture), all checked byte for
 * byte against the CPU. */
#include <stdlib.h>
#include <string.h>

#include "corvid/transfer.h"
#include "vk_test.h"

enum { W = 64, H = 48, N = 3000 };

static float gradient_ref(int32_t coord) { return (float)((uint32_t)coord & 255u) / 256.0f; }

static void expected_texel(int x, int y, float out[4]) {
    out[0] = gradient_ref(x);
    out[1] = gradient_ref(y);
    out[2] = gradient_ref(x + y);
    out[3] = 1.0f;
}

/* Two backends in one process and one context: a buffer and a texture region
 * travel from a Vulkan device to a mock device and back, byte for byte. */
static void test_across_backends(void) {
    cv_context *ctx;
    CHECK_OK(cv_context_create(NULL, &ctx));
    cv_device *gpu = NULL, *mock = NULL;
    CHECK_OK(vkt_device(ctx, NULL, "gpu", &gpu));
    CHECK_OK(cv_device_create(ctx, cv_mock_backend(), &(cv_device_desc){ .label = "mock" }, &mock));
    if (!gpu || !mock) {
        cv_context_destroy(ctx);
        return;
    }
    cv_buffer b;
    cv_texture t;
    CHECK_OK(cv_buffer_create(ctx, &(cv_buffer_desc){ .size = 1 << 16, .label = "shared" }, &b));
    CHECK_OK(cv_texture_create(
        ctx, &(cv_texture_desc){ .width = 64, .height = 32, .format = CV_FORMAT_RGBA8_UNORM, .label = "shared" },
        &t));
    cv_device *both[2] = { gpu, mock };
    for (int i = 0; i < 2; i++) {
        CHECK_OK(cv_device_load(both[i], cv_any(b)));
        CHECK_OK(cv_device_load(both[i], cv_any(t)));
    }
    static uint8_t data[1 << 16], back[1 << 16];
    for (size_t i = 0; i < sizeof(data); i++)
        data[i] = (uint8_t)(i * 13 + 7);
    memset(back, 0, sizeof(back));
    CHECK_OK(cv_device_write_buffer(gpu, b, 0, sizeof(data), data));
    CHECK_OK(cv_device_write_buffer(mock, b, 0, sizeof(back), back));
    CHECK_OK(cv_transfer_buffer(gpu, b, 0, mock, b, 0, sizeof(data), NULL));
    CHECK_OK(cv_device_read_buffer(mock, b, 0, sizeof(back), back));
    CHECK(memcmp(back, data, sizeof(data)) == 0);
    CHECK_OK(cv_device_write_texture(mock, t, (cv_rect){ 0, 0, 64, 32 }, data));
    CHECK_OK(cv_device_write_texture(gpu, t, (cv_rect){ 0, 0, 64, 32 }, data + 8192));
    CHECK_OK(cv_transfer_texture(mock, t, (cv_rect){ 16, 0, 16, 32 }, gpu, t, 16, 0, NULL));
    CHECK_OK(cv_device_read_texture(gpu, t, (cv_rect){ 0, 0, 64, 32 }, back));
    for (int y = 0; y < 32; y++) {
        CHECK(memcmp(back + y * 256 + 64, data + y * 256 + 64, 64) == 0);           /* the moved columns */
        CHECK(memcmp(back + y * 256, data + 8192 + y * 256, 64) == 0);              /* untouched left */
        CHECK(memcmp(back + y * 256 + 128, data + 8192 + y * 256 + 128, 128) == 0); /* untouched right */
    }
    cv_context_destroy(ctx);
}

int main(void) {
    test_across_backends();
    cv_context *ctx;
    CHECK_OK(cv_context_create(NULL, &ctx));
    cv_vulkan_gpu_table table;
    CHECK_OK(cv_vulkan_gpu_table_build(&(cv_vulkan_gpu_config){ .virtual_per_adapter = 2, .adapters = vkt_adapter() },
                                       &table));
    CHECK_EQ_INT(table.count, 2);
    cv_device *gpu[2] = { NULL, NULL };
    CHECK_OK(cv_vulkan_create_devices(ctx, &table, true, gpu));
    if (!gpu[0] || !gpu[1]) {
        cv_context_destroy(ctx); /* with any device it made */
        return check_report("vk_transfer");
    }
    CHECK(strcmp(cv_device_label(gpu[1]), "gpu1") == 0);

    /* One handle per resource, a representation on each device. */
    cv_buffer buf = { 0 }, buf2 = { 0 };
    cv_texture tex = { 0 }, tex2 = { 0 };
    CHECK_OK(cv_buffer_create(ctx, &(cv_buffer_desc){ .size = 4 * N, .label = "buf" }, &buf));
    CHECK_OK(cv_buffer_create(ctx, &(cv_buffer_desc){ .size = W * H * 16, .label = "buf2" }, &buf2));
    CHECK_OK(cv_texture_create(
        ctx, &(cv_texture_desc){ .width = W, .height = H, .format = CV_FORMAT_RGBA32F, .label = "frame" }, &tex));
    CHECK_OK(cv_texture_create(
        ctx, &(cv_texture_desc){ .width = W, .height = H, .format = CV_FORMAT_RGBA32F, .label = "frame2" }, &tex2));
    cv_pipeline fill, gradient;
    CHECK_OK(cv_pipeline_create(ctx, "test.fill_u32", &fill));
    CHECK_OK(cv_pipeline_create(ctx, "test.gradient", &gradient));
    for (int g = 0; g < 2; g++) {
        CHECK_OK(cv_device_load(gpu[g], cv_any(buf)));
        CHECK_OK(cv_device_load(gpu[g], cv_any(tex)));
    }
    CHECK_OK(cv_device_load(gpu[0], cv_any(fill)));
    CHECK_OK(cv_device_load(gpu[0], cv_any(gradient)));
    CHECK_OK(cv_device_load(gpu[1], cv_any(buf2)));
    CHECK_OK(cv_device_load(gpu[1], cv_any(tex2)));

    /* gpu0 produces: buf[i] = 1000 + i, tex = gradient. gpu1 starts zeroed. */
    cv_cmdlist list;
    cv_command_list *l;
    CHECK_OK(cv_cmdlist_create(ctx, &list));
    CHECK_OK(cv_cmdlist_begin(ctx, list, &l));
    uint32_t fill_push[2] = { 1000, N };
    int32_t origin[2] = { 0, 0 };
    cv_binding bb = { .resource = cv_any(buf) }, bt = { .resource = cv_any(tex) };
    cv_cmd_dispatch(l, CV_QUEUE_COMPUTE,
                    &(cv_dispatch_args){ .pipeline = fill,
                                         .bindings = &bb,
                                         .bindings_count = 1,
                                         .push = fill_push,
                                         .push_size = 8,
                                         .groups_x = (N + 63) / 64,
                                         .groups_y = 1,
                                         .groups_z = 1 });
    cv_cmd_dispatch(l, CV_QUEUE_COMPUTE,
                    &(cv_dispatch_args){ .pipeline = gradient,
                                         .bindings = &bt,
                                         .bindings_count = 1,
                                         .push = origin,
                                         .push_size = 8,
                                         .groups_x = W / 8,
                                         .groups_y = H / 8,
                                         .groups_z = 1 });
    CHECK_OK(cv_command_list_end(l));
    CHECK_OK(vkt_run(gpu[0], list, NULL));
    uint8_t *zero = calloc(1, W * H * 16);
    CHECK_OK(cv_device_write_buffer(gpu[1], buf, 0, 4 * N, zero));
    CHECK_OK(cv_device_write_texture(gpu[1], tex, (cv_rect){ 0, 0, W, H }, zero));

    /* Cross-device: a buffer range, and the column partition x in [16, 40). */
    cv_transfer_stats stats;
    CHECK_OK(cv_transfer_buffer(gpu[0], buf, 400, gpu[1], buf, 8000, 2000, &stats));
    CHECK_EQ_INT(stats.bytes, 2000);
    CHECK_OK(cv_transfer_texture(gpu[0], tex, (cv_rect){ 16, 0, 24, H }, gpu[1], tex, 16, 0, &stats));
    CHECK_EQ_INT(stats.bytes, 24 * H * 16);
    uint32_t *words = malloc(4 * N);
    CHECK_OK(cv_device_read_buffer(gpu[1], buf, 0, 4 * N, words));
    int wrong = 0;
    for (uint32_t i = 0; i < N; i++) {
        bool moved = i >= 2000 && i < 2500; /* bytes 8000..9999 <- source bytes 400..2399 */
        wrong += words[i] != (moved ? 1000 + (i - 2000) + 100 : 0);
    }
    CHECK_EQ_INT(wrong, 0);
    float(*frame)[W][4] = malloc(W * H * 16);
    CHECK_OK(cv_device_read_texture(gpu[1], tex, (cv_rect){ 0, 0, W, H }, frame));
    wrong = 0;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            float want[4] = { 0, 0, 0, 0 };
            if (x >= 16 && x < 40)
                expected_texel(x, y, want);
            wrong += memcmp(frame[y][x], want, 16) != 0;
        }
    CHECK_EQ_INT(wrong, 0);

    /* Device-local copies on gpu1, recorded for the copy queue. */
    CHECK_OK(cv_device_write_texture(gpu[1], tex2, (cv_rect){ 0, 0, W, H }, zero));
    CHECK_OK(cv_device_write_buffer(gpu[1], buf2, 0, W * H * 16, zero));
    CHECK_OK(cv_cmdlist_begin(ctx, list, &l));
    /* buf[0..100) <- buf[2000..2100) (words 2000.. hold the moved values) */
    cv_cmd_copy_buffer(l, CV_QUEUE_COPY,
                       &(cv_copy_buffer_args){
                           .src = buf, .src_offset = 8000, .dst = buf, .dst_offset = 0, .size = 400 });
    /* tex2 (4,2) <- tex (16,0) 24 x 20 */
    cv_cmd_copy_texture(
        l, CV_QUEUE_COPY,
        &(cv_copy_texture_args){
            .src = tex, .src_x = 16, .src_y = 0, .dst = tex2, .dst_x = 4, .dst_y = 2, .width = 24, .height = 20 });
    /* buf2 <- tex2 rows (all of it), then tex (0, 30) <- buf2 first 10x5 texels (zeros) */
    cv_cmd_copy_texture_to_buffer(
        l, CV_QUEUE_COPY,
        &(cv_copy_texture_to_buffer_args){
            .src = tex2, .src_x = 0, .src_y = 0, .width = W, .height = H, .dst = buf2, .dst_offset = 0 });
    cv_cmd_copy_buffer_to_texture(
        l, CV_QUEUE_COPY,
        &(cv_copy_buffer_to_texture_args){
            .src = buf2, .src_offset = 0, .dst = tex, .dst_x = 20, .dst_y = 30, .width = 10, .height = 5 });
    CHECK_OK(cv_command_list_end(l));
    CHECK_OK(vkt_run(gpu[1], list, NULL));

    CHECK_OK(cv_device_read_buffer(gpu[1], buf, 0, 400, words));
    wrong = 0;
    for (uint32_t i = 0; i < 100; i++)
        wrong += words[i] != 1100 + i;
    CHECK_EQ_INT(wrong, 0);
    float(*frame2)[W][4] = malloc(W * H * 16);
    CHECK_OK(cv_device_read_texture(gpu[1], tex2, (cv_rect){ 0, 0, W, H }, frame2));
    float(*staged)[W][4] = malloc(W * H * 16);
    CHECK_OK(cv_device_read_buffer(gpu[1], buf2, 0, W * H * 16, staged));
    CHECK(memcmp(staged, frame2, W * H * 16) == 0);
    CHECK_OK(cv_device_read_texture(gpu[1], tex, (cv_rect){ 0, 0, W, H }, frame));
    wrong = 0;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            float want2[4] = { 0, 0, 0, 0 }, want[4] = { 0, 0, 0, 0 };
            if (x >= 4 && x < 28 && y >= 2 && y < 22)
                expected_texel(x - 4 + 16, y - 2, want2);
            wrong += memcmp(frame2[y][x], want2, 16) != 0;
            if (x >= 16 && x < 40)
                expected_texel(x, y, want);
            if (x >= 20 && x < 30 && y >= 30 && y < 35) {
                /* row r of the 10x5 region came from buf2 texels [10r, 10r+10) = tex2 row 0 */
                int i = (y - 30) * 10 + (x - 20);
                memcpy(want, frame2[i / W][i % W], 16);
            }
            wrong += memcmp(frame[y][x], want, 16) != 0;
        }
    CHECK_EQ_INT(wrong, 0);

    free(zero);
    free(words);
    free(frame);
    free(frame2);
    free(staged);
    cv_device_destroy(gpu[0]);
    cv_device_destroy(gpu[1]);
    cv_context_destroy(ctx);
    return vkt_report("vk_transfer");
}
