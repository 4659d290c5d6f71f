/* The three transfer paths between two virtual GPUs (two VkDevices on one
 * adapter), each forced in turn: buffer ranges of odd sizes and offsets (one
 * byte up to three chunks), texture sub-rectangles of odd sizes in two
 * formats and a texture taller than one chunk, all checked byte for byte,
 * untouched bytes included. Then what must be refused, changing nothing:
 * out-of-range requests, wrong and unloaded handles, a forced path that a
 * pair cannot take (mock <-> vulkan), a bad path name; and what must still
 * work: mock <-> vulkan on the staged path, forcing one path after another. Validation (synchronization included)
 * must stay silent. */
#include <stdlib.h>
#include <string.h>

#include "corvid/transfer.h"
#include "vk_test.h"

static const cv_transfer_path paths[] = { CV_TRANSFER_STAGED, CV_TRANSFER_HOST_IMPORT, CV_TRANSFER_SHARED,
                                          CV_TRANSFER_DEVICE };

/* CORVID_VGPU_DEVICE=shared (ctest's vk_transfer_paths_shared): the two virtual GPUs share one
 * VkDevice, and the device path is theirs too; otherwise it is refused (below). */
static bool vgpu_shared(void) {
    const char *v = getenv("CORVID_VGPU_DEVICE");
    return v && strcmp(v, "shared") == 0;
}

static void fill(uint8_t *p, size_t n, uint32_t seed) {
    uint32_t x = seed * 2654435761u + 1;
    for (size_t i = 0; i < n; i++) {
        x = x * 1664525u + 1013904223u;
        p[i] = (uint8_t)(x >> 24);
    }
}

/* src gets pattern A, dst pattern B; after moving [so, so+n) to do, dst must
 * be B with A's bytes in [do, do+n). */
static void buffer_case(cv_context *ctx, cv_device *a, cv_device *b, cv_transfer_path path, uint64_t size,
                        uint64_t so, uint64_t dof, uint64_t n) {
    cv_buffer buf;
    CHECK_OK(cv_buffer_create(ctx, &(cv_buffer_desc){ .size = size, .label = "moved" }, &buf));
    CHECK_OK(cv_device_load(a, cv_any(buf)));
    CHECK_OK(cv_device_load(b, cv_any(buf)));
    uint8_t *src = malloc(size), *dst = malloc(size), *back = malloc(size);
    fill(src, size, (uint32_t)n);
    fill(dst, size, (uint32_t)n + 99);
    CHECK_OK(cv_device_write_buffer(a, buf, 0, size, src));
    CHECK_OK(cv_device_write_buffer(b, buf, 0, size, dst));
    cv_transfer_stats st = { 0 };
    CHECK_OK(cv_transfer_buffer(a, buf, so, b, buf, dof, n, &st));
    CHECK_EQ_INT(st.bytes, n);
    CHECK_EQ_INT(st.path, path);
    memcpy(dst + dof, src + so, n);
    CHECK_OK(cv_device_read_buffer(b, buf, 0, size, back));
    CHECK(memcmp(back, dst, size) == 0);
    /* The reverse direction too (b -> a), overlapping ranges of one handle. */
    CHECK_OK(cv_transfer_buffer(b, buf, 0, a, buf, size - n, n, &st));
    memcpy(src + size - n, dst, n);
    CHECK_OK(cv_device_read_buffer(a, buf, 0, size, back));
    CHECK(memcmp(back, src, size) == 0);
    free(src);
    free(dst);
    free(back);
    CHECK_OK(cv_buffer_destroy(ctx, buf));
}

static void texture_case(cv_context *ctx, cv_device *a, cv_device *b, cv_transfer_path path, cv_format format,
                         uint32_t w, uint32_t h, cv_rect rect, uint32_t dx, uint32_t dy) {
    cv_texture tex;
    CHECK_OK(cv_texture_create(ctx, &(cv_texture_desc){ .width = w, .height = h, .format = format, .label = "img" },
                               &tex));
    CHECK_OK(cv_device_load(a, cv_any(tex)));
    CHECK_OK(cv_device_load(b, cv_any(tex)));
    size_t texel = cv_format_bytes(format), row = w * texel, size = row * h;
    uint8_t *src = malloc(size), *dst = malloc(size), *back = malloc(size);
    fill(src, size, w * 7 + h);
    fill(dst, size, w * 7 + h + 1);
    if (format == CV_FORMAT_RGBA32F) /* finite floats, so every bit pattern survives */
        for (size_t i = 3; i < size; i += 4)
            src[i] &= 0x3f, dst[i] &= 0x3f;
    CHECK_OK(cv_device_write_texture(a, tex, (cv_rect){ 0, 0, w, h }, src));
    CHECK_OK(cv_device_write_texture(b, tex, (cv_rect){ 0, 0, w, h }, dst));
    cv_transfer_stats st = { 0 };
    CHECK_OK(cv_transfer_texture(a, tex, rect, b, tex, dx, dy, &st));
    CHECK_EQ_INT(st.bytes, (uint64_t)rect.width * rect.height * texel);
    CHECK_EQ_INT(st.path, path);
    for (uint32_t y = 0; y < rect.height; y++)
        memcpy(dst + (dy + y) * row + dx * texel, src + (rect.y + y) * row + rect.x * texel, rect.width * texel);
    CHECK_OK(cv_device_read_texture(b, tex, (cv_rect){ 0, 0, w, h }, back));
    CHECK(memcmp(back, dst, size) == 0);
    free(src);
    free(dst);
    free(back);
    CHECK_OK(cv_texture_destroy(ctx, tex));
}

/* Requests that must fail with `code` and leave the destination as it was. */
static void refusals(cv_context *ctx, cv_device *a, cv_device *b, cv_transfer_path path) {
    enum { N = 4096 };
    cv_buffer buf, other;
    cv_texture tex;
    CHECK_OK(cv_buffer_create(ctx, &(cv_buffer_desc){ .size = N, .label = "guarded" }, &buf));
    CHECK_OK(cv_buffer_create(ctx, &(cv_buffer_desc){ .size = N, .label = "only on a" }, &other));
    CHECK_OK(cv_texture_create(
        ctx, &(cv_texture_desc){ .width = 16, .height = 16, .format = CV_FORMAT_RGBA8_UNORM, .label = "guarded" },
        &tex));
    for (int i = 0; i < 2; i++) {
        cv_device *d = i ? b : a;
        CHECK_OK(cv_device_load(d, cv_any(buf)));
        CHECK_OK(cv_device_load(d, cv_any(tex)));
    }
    CHECK_OK(cv_device_load(a, cv_any(other)));
    uint8_t data[N], before[N], after[N];
    fill(data, N, 5);
    fill(before, N, 6);
    CHECK_OK(cv_device_write_buffer(a, buf, 0, N, data));
    CHECK_OK(cv_device_write_buffer(b, buf, 0, N, before));
    CHECK_OK(cv_device_write_texture(b, tex, (cv_rect){ 0, 0, 16, 16 }, before));
    cv_transfer_stats st = { .bytes = 12345 };
    CHECK_RESULT(cv_transfer_buffer(a, buf, 1, b, buf, 0, N, &st), CV_ERROR_OUT_OF_RANGE);
    CHECK_RESULT(cv_transfer_buffer(a, buf, 0, b, buf, N - 3, 4, &st), CV_ERROR_OUT_OF_RANGE);
    CHECK_RESULT(cv_transfer_buffer(a, buf, UINT64_MAX, b, buf, 0, 2, &st), CV_ERROR_OUT_OF_RANGE);
    CHECK_RESULT(cv_transfer_buffer(a, buf, 0, b, buf, 0, 0, &st), CV_ERROR_OUT_OF_RANGE);
    CHECK_RESULT(cv_transfer_buffer(a, buf, 0, b, other, 0, 16, &st), CV_ERROR_NOT_LOADED);
    CHECK_RESULT(cv_transfer_buffer(a, (cv_buffer){ tex.id }, 0, b, buf, 0, 16, &st), CV_ERROR_WRONG_HANDLE_TYPE);
    CHECK_RESULT(cv_transfer_texture(a, tex, (cv_rect){ 8, 0, 9, 16 }, b, tex, 0, 0, &st), CV_ERROR_OUT_OF_RANGE);
    CHECK_RESULT(cv_transfer_texture(a, tex, (cv_rect){ 0, 0, 4, 4 }, b, tex, 13, 0, &st), CV_ERROR_OUT_OF_RANGE);
    CHECK_RESULT(cv_transfer_texture(a, tex, (cv_rect){ 0, 0, 0, 4 }, b, tex, 0, 0, &st), CV_ERROR_OUT_OF_RANGE);
    CHECK_RESULT(cv_transfer_texture(a, (cv_texture){ buf.id }, (cv_rect){ 0, 0, 4, 4 }, b, tex, 0, 0, &st),
                 CV_ERROR_WRONG_HANDLE_TYPE);
    CHECK_RESULT(cv_transfer_texture(a, (cv_texture){ 0 }, (cv_rect){ 0, 0, 4, 4 }, b, tex, 0, 0, &st),
                 CV_ERROR_NOT_LOADED);
    CHECK_RESULT(cv_transfer_buffer(NULL, buf, 0, b, buf, 0, 4, &st), CV_ERROR_INVALID_ARGUMENT);
    CHECK_EQ_INT(st.bytes, 12345); /* stats untouched by a refusal */
    CHECK_OK(cv_device_read_buffer(b, buf, 0, N, after));
    CHECK(memcmp(after, before, N) == 0);
    CHECK_OK(cv_device_read_texture(b, tex, (cv_rect){ 0, 0, 16, 16 }, after));
    CHECK(memcmp(after, before, 16 * 16 * 4) == 0);
    (void)path;
    CHECK_OK(cv_buffer_destroy(ctx, buf));
    CHECK_OK(cv_buffer_destroy(ctx, other));
    CHECK_OK(cv_texture_destroy(ctx, tex));
}

static void each_path(cv_context *ctx, cv_device *a, cv_device *b) {
    for (size_t p = 0; p < sizeof(paths) / sizeof(paths[0]); p++) {
        cv_transfer_path path = paths[p];
        fprintf(stderr, "path %s\n", cv_transfer_path_name(path));
        CHECK_OK(cv_transfer_set_path(path));
        cv_transfer_path chosen = CV_TRANSFER_AUTO;
        if (path == CV_TRANSFER_DEVICE && !vgpu_shared()) { /* separate VkDevices: refused, naming both */
            CHECK_RESULT(cv_transfer_choose_path(a, b, &chosen), CV_ERROR_UNSUPPORTED);
            CHECK(strstr(cv_last_error(), "'gpu0'") && strstr(cv_last_error(), "'gpu1'"));
            continue;
        }
        CHECK_OK(cv_transfer_choose_path(a, b, &chosen));
        CHECK_EQ_INT(chosen, path);
        buffer_case(ctx, a, b, path, 64, 0, 0, 1);
        buffer_case(ctx, a, b, path, 10007, 3, 1001, 4097);
        /* Three 8 MiB link chunks (five 4 MiB staged ones), odd everything. */
        buffer_case(ctx, a, b, path, (20u << 20) + 4096, 13, 4083, (20u << 20) + 5);
        texture_case(ctx, a, b, path, CV_FORMAT_RGBA8_UNORM, 61, 47, (cv_rect){ 5, 7, 37, 23 }, 11, 3);
        texture_case(ctx, a, b, path, CV_FORMAT_RGBA32F, 33, 17, (cv_rect){ 0, 0, 1, 1 }, 32, 16);
        /* 2000 x 1500 RGBA32F = 48 MB: rows in several chunks on every path. */
        texture_case(ctx, a, b, path, CV_FORMAT_RGBA32F, 2000, 1500, (cv_rect){ 3, 1, 1997, 1499 }, 0, 0);
        refusals(ctx, a, b, path);
    }
    cv_transfer_clear_path();
}

/* Mock <-> Vulkan: only the staged path fits; forcing another is refused, naming both. */
static void across_backends(cv_context *ctx, cv_device *gpu) {
    cv_device *mock = NULL;
    CHECK_OK(cv_device_create(ctx, cv_mock_backend(), &(cv_device_desc){ .label = "mock" }, &mock));
    if (!mock)
        return;
    enum { N = 5000 };
    cv_buffer buf;
    CHECK_OK(cv_buffer_create(ctx, &(cv_buffer_desc){ .size = N, .label = "cross" }, &buf));
    CHECK_OK(cv_device_load(gpu, cv_any(buf)));
    CHECK_OK(cv_device_load(mock, cv_any(buf)));
    uint8_t data[N], before[N], back[N];
    fill(data, N, 11);
    fill(before, N, 12);
    CHECK_OK(cv_device_write_buffer(gpu, buf, 0, N, data));
    CHECK_OK(cv_device_write_buffer(mock, buf, 0, N, before));
    for (size_t p = 1; p < sizeof(paths) / sizeof(paths[0]); p++) {
        CHECK_OK(cv_transfer_set_path(paths[p]));
        CHECK_RESULT(cv_transfer_buffer(gpu, buf, 0, mock, buf, 0, N, NULL), CV_ERROR_UNSUPPORTED);
        CHECK(strstr(cv_last_error(), "'gpu0'") && strstr(cv_last_error(), "'mock'"));
        CHECK_RESULT(cv_transfer_buffer(mock, buf, 0, gpu, buf, 0, N, NULL), CV_ERROR_UNSUPPORTED);
    }
    CHECK_OK(cv_device_read_buffer(mock, buf, 0, N, back));
    CHECK(memcmp(back, before, N) == 0);
    cv_transfer_stats st = { 0 };
    CHECK_OK(cv_transfer_set_path(CV_TRANSFER_AUTO));
    CHECK_OK(cv_transfer_buffer(gpu, buf, 7, mock, buf, 9, N - 9, &st));
    CHECK_EQ_INT(st.path, CV_TRANSFER_STAGED);
    memcpy(before + 9, data + 7, N - 9);
    CHECK_OK(cv_device_read_buffer(mock, buf, 0, N, back));
    CHECK(memcmp(back, before, N) == 0);
    CHECK_OK(cv_transfer_set_path(CV_TRANSFER_STAGED));
    CHECK_OK(cv_transfer_buffer(mock, buf, 0, gpu, buf, 0, N, &st));
    CHECK_EQ_INT(st.path, CV_TRANSFER_STAGED);
    CHECK_OK(cv_device_read_buffer(gpu, buf, 0, N, back));
    CHECK(memcmp(back, before, N) == 0);
    cv_transfer_clear_path();
    CHECK_OK(cv_buffer_destroy(ctx, buf));
    cv_device_destroy(mock);
}

/* The forced path: taken by the next transfer; set again, the last one wins; a bad name or path is refused. */
static void environment(cv_context *ctx, cv_device *a, cv_device *b) {
    cv_buffer buf;
    CHECK_OK(cv_buffer_create(ctx, &(cv_buffer_desc){ .size = 256, .label = "env" }, &buf));
    CHECK_OK(cv_device_load(a, cv_any(buf)));
    CHECK_OK(cv_device_load(b, cv_any(buf)));
    cv_transfer_stats st = { 0 };
    cv_transfer_path chosen;
    CHECK_OK(cv_transfer_choose_path(a, b, &chosen));
    if (vgpu_shared()) /* one VkDevice: auto copies directly */
        CHECK_EQ_INT(chosen, CV_TRANSFER_DEVICE);
    else if (vkt_is_lavapipe()) /* external memory fd: auto shares */
        CHECK_EQ_INT(chosen, CV_TRANSFER_SHARED);
    CHECK_OK(cv_transfer_set_path(CV_TRANSFER_HOST_IMPORT));
    CHECK_OK(cv_transfer_buffer(a, buf, 0, b, buf, 0, 256, &st));
    CHECK_EQ_INT(st.path, CV_TRANSFER_HOST_IMPORT);
    CHECK_OK(cv_transfer_set_path(CV_TRANSFER_STAGED));
    CHECK_OK(cv_transfer_buffer(a, buf, 0, b, buf, 0, 256, &st));
    CHECK_EQ_INT(st.path, CV_TRANSFER_STAGED);
    CHECK_OK(cv_transfer_set_path(CV_TRANSFER_SHARED));
    CHECK_OK(cv_transfer_buffer(a, buf, 0, b, buf, 0, 256, &st));
    CHECK_EQ_INT(st.path, CV_TRANSFER_SHARED);
    cv_transfer_clear_path();
    CHECK_RESULT(cv_transfer_path_parse("fastest", &chosen), CV_ERROR_INVALID_ARGUMENT);
    CHECK(strstr(cv_last_error(), "fastest") != NULL);
    CHECK_RESULT(cv_transfer_set_path(CV_TRANSFER_PATH_COUNT), CV_ERROR_INVALID_ARGUMENT);
    cv_transfer_path parsed;
    CHECK_OK(cv_transfer_path_parse("host-import", &parsed));
    CHECK_EQ_INT(parsed, CV_TRANSFER_HOST_IMPORT);
    CHECK(strcmp(cv_transfer_path_name(CV_TRANSFER_SHARED), "shared") == 0);
    CHECK_OK(cv_transfer_path_parse("device", &parsed));
    CHECK_EQ_INT(parsed, CV_TRANSFER_DEVICE);
    CHECK(strcmp(cv_transfer_path_name(CV_TRANSFER_DEVICE), "device") == 0);
    CHECK_OK(cv_buffer_destroy(ctx, buf));
}

int main(void) {
    unsetenv("CORVID_TRANSFER_PATH");
    /* Separate VkDevices unless ctest's vk_transfer_paths_shared asks for one
     * (auto, the default, shares on GPUs with several queues). */
    setenv("CORVID_VGPU_DEVICE", "separate", 0);
    cv_context *ctx;
    CHECK_OK(cv_context_create(NULL, &ctx));
    cv_device *gpu[2] = { NULL, NULL };
    CHECK_OK(vkt_two_virtual_gpus(ctx, gpu));
    if (gpu[0] && gpu[1]) {
        each_path(ctx, gpu[0], gpu[1]);
        across_backends(ctx, gpu[0]);
        environment(ctx, gpu[0], gpu[1]);
        cv_device_destroy(gpu[0]);
        cv_device_destroy(gpu[1]);
    }
    cv_context_destroy(ctx);
    CHECK_NOTHING_LIVE();
    return vkt_report("vk_transfer_paths");
}
