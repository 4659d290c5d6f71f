/* Asynchronous transfers (transfer.h: rings) between two virtual GPUs, on
 * the shared and host-import paths, through the bridge (vk_bridge.h: lavapipe
 * has no external semaphores, so every cross-device wait takes it):
 *   - buffer ranges and texture rectangles byte-exact, untouched bytes too,
 *     including transfers larger than the ring (its slots reused within one);
 *   - 40 frames through a 2-slot ring with no host wait: each frame the source
 *     runs y = 2x + y, then y moves to frame k's range of the destination, and
 *     the destination runs its own y = 2x + y on what arrived, while the
 *     reverse ring carries a texture back the other way; every frame's bytes
 *     must be exact (y0 + 2(k+1)x), which needs the source copy ordered after
 *     the source's work, the destination's after the copy, and each slot
 *     written only after its previous read;
 *   - refusals change nothing (out of range, wrong handle, a staged pair, a
 *     mock device, bad ring sizes), each naming what was wrong;
 *   - rings destroyed with copies in flight, then the devices: no leak, no
 *     validation message (synchronization validation included). */
#include <stdlib.h>
#include <string.h>

#include "corvid/transfer.h"
#include "vk_test.h"

enum { N = 1024, FRAMES = 40 };

static void fill(uint8_t *p, size_t n, uint32_t seed) {
    uint32_t x = seed * 2654435761u + 1;
    for (size_t i = 0; i < n; i++) {
        x = x * 1664525u + 1013904223u;
        p[i] = (uint8_t)(x >> 24);
    }
}

static cv_buffer both_buffer(cv_context *ctx, cv_device *a, cv_device *b, uint64_t size, const char *label) {
    cv_buffer buf = { 0 };
    cv_buffer_desc d = { .size = size };
    snprintf(d.label, sizeof(d.label), "%s", label);
    CHECK_OK(cv_buffer_create(ctx, &d, &buf));
    CHECK_OK(cv_device_load(a, cv_any(buf)));
    CHECK_OK(cv_device_load(b, cv_any(buf)));
    return buf;
}

/* Odd ranges, one larger than the whole ring (3 slots of 4 KiB... 2 slots here). */
static void exact_cases(cv_context *ctx, cv_device *a, cv_device *b, cv_transfer_path path) {
    cv_transfer_ring *ring = NULL;
    CHECK_OK(cv_transfer_ring_create(a, b, 4096, 2, &ring));
    if (!ring)
        return;
    CHECK_EQ_INT(cv_transfer_ring_path(ring), path);
    enum { SIZE = 30011 };
    cv_buffer buf = both_buffer(ctx, a, b, SIZE, "moved");
    uint8_t *src = malloc(SIZE), *dst = malloc(SIZE), *back = malloc(SIZE);
    fill(src, SIZE, 1);
    fill(dst, SIZE, 2);
    CHECK_OK(cv_device_write_buffer(a, buf, 0, SIZE, src));
    CHECK_OK(cv_device_write_buffer(b, buf, 0, SIZE, dst));
    cv_transfer_async t = { 0 };
    CHECK_OK(cv_transfer_buffer_async(ring, buf, 3, buf, 1001, 1, &t));
    CHECK_EQ_INT(t.bytes, 1);
    CHECK_EQ_INT(t.path, path);
    memcpy(dst + 1001, src + 3, 1);
    /* 25000 bytes: seven pieces through two 4 KiB slots, each slot reused thrice. */
    CHECK_OK(cv_transfer_buffer_async(ring, buf, 7, buf, 5003, 25000, &t));
    memcpy(dst + 5003, src + 7, 25000);
    CHECK(t.dst_ticket > 0 && t.src_ticket > 0);
    CHECK_OK(cv_device_read_buffer(b, buf, 0, SIZE, back)); /* waits for the copies (the buffer's last use) */
    CHECK(memcmp(back, dst, SIZE) == 0);
    /* A texture rectangle of 61 x 47 RGBA8 (row 244 bytes: 16 rows a slot). */
    cv_texture tex;
    CHECK_OK(cv_texture_create(
        ctx, &(cv_texture_desc){ .width = 61, .height = 47, .format = CV_FORMAT_RGBA8_UNORM, .label = "img" }, &tex));
    CHECK_OK(cv_device_load(a, cv_any(tex)));
    CHECK_OK(cv_device_load(b, cv_any(tex)));
    size_t row = 61 * 4, tsize = row * 47;
    fill(src, tsize, 3);
    fill(dst, tsize, 4);
    CHECK_OK(cv_device_write_texture(a, tex, (cv_rect){ 0, 0, 61, 47 }, src));
    CHECK_OK(cv_device_write_texture(b, tex, (cv_rect){ 0, 0, 61, 47 }, dst));
    cv_rect rect = { 5, 2, 37, 44 };
    CHECK_OK(cv_transfer_texture_async(ring, tex, rect, tex, 11, 1, &t));
    CHECK_EQ_INT(t.bytes, 37 * 44 * 4);
    for (uint32_t y = 0; y < rect.height; y++)
        memcpy(dst + (1 + y) * row + 11 * 4, src + (rect.y + y) * row + rect.x * 4, rect.width * 4);
    CHECK_OK(cv_device_read_texture(b, tex, (cv_rect){ 0, 0, 61, 47 }, back));
    CHECK(memcmp(back, dst, tsize) == 0);
    /* Refusals: nothing moves, the message says what. */
    cv_transfer_async untouched = { .bytes = 777 };
    CHECK_RESULT(cv_transfer_buffer_async(ring, buf, 1, buf, 0, SIZE, &untouched), CV_ERROR_OUT_OF_RANGE);
    CHECK(strstr(cv_last_error(), "'moved'") != NULL);
    CHECK_RESULT(cv_transfer_texture_async(ring, tex, (cv_rect){ 30, 0, 32, 4 }, tex, 0, 0, &untouched),
                 CV_ERROR_OUT_OF_RANGE);
    CHECK_RESULT(cv_transfer_buffer_async(ring, (cv_buffer){ tex.id }, 0, buf, 0, 4, &untouched),
                 CV_ERROR_WRONG_HANDLE_TYPE);
    CHECK_RESULT(cv_transfer_buffer_async(NULL, buf, 0, buf, 0, 4, &untouched), CV_ERROR_INVALID_ARGUMENT);
    CHECK_EQ_INT(untouched.bytes, 777);
    CHECK_OK(cv_device_read_buffer(b, buf, 0, SIZE, back));
    fill(src, SIZE, 1);
    fill(dst, SIZE, 2);
    memcpy(dst + 1001, src + 3, 1);
    memcpy(dst + 5003, src + 7, 25000);
    CHECK(memcmp(back, dst, SIZE) == 0);
    free(src);
    free(dst);
    free(back);
    cv_transfer_ring_destroy(ring);
    CHECK_OK(cv_buffer_destroy(ctx, buf));
    CHECK_OK(cv_texture_destroy(ctx, tex));
}

static cv_cmdlist saxpy_list(cv_context *ctx, cv_pipeline saxpy, cv_buffer x, cv_buffer y) {
    cv_cmdlist list;
    cv_command_list *l;
    CHECK_OK(cv_cmdlist_create(ctx, &list));
    CHECK_OK(cv_cmdlist_begin(ctx, list, &l));
    struct {
        float a;
        uint32_t count;
    } push = { 2.0f, N };
    cv_binding b[2] = { { .resource = cv_any(x) }, { .resource = cv_any(y) } };
    cv_cmd_dispatch(l, CV_QUEUE_COMPUTE,
                    &(cv_dispatch_args){ .pipeline = saxpy,
                                         .bindings = b,
                                         .bindings_count = 2,
                                         .push = &push,
                                         .push_size = 8,
                                         .groups_x = N / 64,
                                         .groups_y = 1,
                                         .groups_z = 1 });
    CHECK_OK(cv_command_list_end(l));
    return list;
}

/* FRAMES frames, no host wait until the end (see the file comment). */
static void frames(cv_context *ctx, cv_device *a, cv_device *b) {
    cv_transfer_ring *ab = NULL, *ba = NULL;
    CHECK_OK(cv_transfer_ring_create(a, b, 4 * N, 2, &ab));
    CHECK_OK(cv_transfer_ring_create(b, a, 16 * 16 * 16, 2, &ba));
    if (!ab || !ba) {
        cv_transfer_ring_destroy(ab);
        cv_transfer_ring_destroy(ba);
        return;
    }
    cv_pipeline saxpy;
    CHECK_OK(cv_pipeline_create(ctx, "test.saxpy", &saxpy));
    CHECK_OK(cv_device_load(a, cv_any(saxpy)));
    CHECK_OK(cv_device_load(b, cv_any(saxpy)));
    cv_buffer x = both_buffer(ctx, a, b, 4 * N, "x"), y = both_buffer(ctx, a, b, 4 * N, "y");
    cv_buffer got = both_buffer(ctx, a, b, 4 * N * FRAMES, "frames");
    cv_texture tex;
    CHECK_OK(cv_texture_create(
        ctx, &(cv_texture_desc){ .width = 16 * FRAMES, .height = 16, .format = CV_FORMAT_RGBA32F, .label = "tiles" },
        &tex));
    CHECK_OK(cv_device_load(a, cv_any(tex)));
    CHECK_OK(cv_device_load(b, cv_any(tex)));
    float hx[N], hy[N];
    for (int i = 0; i < N; i++) {
        hx[i] = (float)(i % 100);
        hy[i] = (float)i;
    }
    CHECK_OK(cv_device_write_buffer(a, x, 0, sizeof(hx), hx));
    CHECK_OK(cv_device_write_buffer(a, y, 0, sizeof(hy), hy));
    CHECK_OK(cv_device_write_buffer(b, x, 0, sizeof(hx), hx));
    size_t tex_bytes = (size_t)16 * FRAMES * 16 * 16;
    uint8_t *tiles = malloc(tex_bytes), *back = malloc(tex_bytes);
    fill(tiles, tex_bytes, 9);
    for (size_t i = 3; i < tex_bytes; i += 4)
        tiles[i] &= 0x3f; /* finite floats */
    CHECK_OK(cv_device_write_texture(b, tex, (cv_rect){ 0, 0, 16 * FRAMES, 16 }, tiles));
    cv_cmdlist on_a = saxpy_list(ctx, saxpy, x, y), on_b = saxpy_list(ctx, saxpy, x, y);
    for (uint32_t k = 0; k < FRAMES; k++) {
        CHECK_OK(cv_device_submit(a, on_a, NULL));
        cv_transfer_async t;
        CHECK_OK(cv_transfer_buffer_async(ab, y, 0, y, 0, 4 * N, &t));
        CHECK_EQ_INT(t.path, cv_transfer_ring_path(ab));
        CHECK_OK(cv_device_submit(b, on_b, NULL)); /* y on b: 2x + (what arrived) */
        /* Keep b's result of frame k: a copy on b into frame k's range of 'frames'. */
        cv_cmdlist keep;
        cv_command_list *l;
        CHECK_OK(cv_cmdlist_create(ctx, &keep));
        CHECK_OK(cv_cmdlist_begin(ctx, keep, &l));
        cv_cmd_copy_buffer(l, CV_QUEUE_COMPUTE,
                           &(cv_copy_buffer_args){
                               .src = y, .dst = got, .dst_offset = (uint64_t)4 * N * k, .size = 4 * N });
        CHECK_OK(cv_command_list_end(l));
        CHECK_OK(cv_device_submit(b, keep, NULL));
        CHECK_OK(cv_cmdlist_destroy(ctx, keep));
        /* The other way: tile k of b's texture to a. */
        CHECK_OK(cv_transfer_texture_async(ba, tex, (cv_rect){ 16 * k, 0, 16, 16 }, tex, 16 * k, 0, &t));
    }
    float *all = malloc(sizeof(float) * N * FRAMES);
    CHECK_OK(cv_device_read_buffer(b, got, 0, sizeof(float) * N * FRAMES, all));
    uint32_t wrong = 0;
    for (uint32_t k = 0; k < FRAMES; k++)
        for (int i = 0; i < N; i++) /* a: y0 + 2(k+1)x, then b adds 2x */
            wrong += all[k * N + i] != hy[i] + 2.0f * (float)(k + 2) * hx[i];
    CHECK_EQ_INT(wrong, 0);
    CHECK_OK(cv_device_read_texture(a, tex, (cv_rect){ 0, 0, 16 * FRAMES, 16 }, back));
    CHECK(memcmp(back, tiles, tex_bytes) == 0);
    /* More in flight, then the rings go (waiting for them) and the caller destroys the devices. */
    for (uint32_t k = 0; k < 8; k++) {
        CHECK_OK(cv_device_submit(a, on_a, NULL));
        CHECK_OK(cv_transfer_buffer_async(ab, y, 0, y, 0, 4 * N, NULL));
        CHECK_OK(cv_transfer_texture_async(ba, tex, (cv_rect){ 16 * k, 0, 16, 16 }, tex, 16 * k, 0, NULL));
    }
    cv_transfer_ring_destroy(ab);
    cv_transfer_ring_destroy(ba);
    free(all);
    free(tiles);
    free(back);
    CHECK_OK(cv_cmdlist_destroy(ctx, on_a));
    CHECK_OK(cv_cmdlist_destroy(ctx, on_b));
    CHECK_OK(cv_buffer_destroy(ctx, x));
    CHECK_OK(cv_buffer_destroy(ctx, y));
    CHECK_OK(cv_buffer_destroy(ctx, got));
    CHECK_OK(cv_texture_destroy(ctx, tex));
    CHECK_OK(cv_pipeline_destroy(ctx, saxpy));
}

/* Rings that cannot be made, each saying why. */
static void refused_rings(cv_context *ctx, cv_device *a, cv_device *b) {
    cv_transfer_ring *ring = (cv_transfer_ring *)&ring;
    CHECK_OK(cv_transfer_set_path(CV_TRANSFER_STAGED));
    CHECK_RESULT(cv_transfer_ring_create(a, b, 4096, 2, &ring), CV_ERROR_UNSUPPORTED);
    CHECK(ring == NULL && strstr(cv_last_error(), "staged") != NULL);
    cv_transfer_clear_path();
    CHECK_RESULT(cv_transfer_ring_create(a, b, 4096, 1, &ring), CV_ERROR_OUT_OF_RANGE);
    CHECK_RESULT(cv_transfer_ring_create(a, b, 1000, 2, &ring), CV_ERROR_OUT_OF_RANGE);
    CHECK_RESULT(cv_transfer_ring_create(a, a, 4096, 2, &ring), CV_ERROR_INVALID_ARGUMENT);
    cv_device *mock = NULL;
    CHECK_OK(cv_device_create(ctx, cv_mock_backend(), &(cv_device_desc){ .label = "mock" }, &mock));
    CHECK_RESULT(cv_transfer_ring_create(a, mock, 4096, 2, &ring), CV_ERROR_UNSUPPORTED);
    CHECK(strstr(cv_last_error(), "'mock'") != NULL);
    cv_device_destroy(mock);
}

int main(void) {
    unsetenv("CORVID_TRANSFER_PATH");
    cv_context *ctx;
    CHECK_OK(cv_context_create(NULL, &ctx));
    cv_device *gpu[2] = { NULL, NULL };
    CHECK_OK(vkt_two_virtual_gpus(ctx, gpu));
    if (gpu[0] && gpu[1]) {
        const cv_transfer_path paths[] = { CV_TRANSFER_SHARED, CV_TRANSFER_HOST_IMPORT };
        for (int p = 0; p < 2; p++) {
            fprintf(stderr, "path %s\n", cv_transfer_path_name(paths[p]));
            CHECK_OK(cv_transfer_set_path(paths[p]));
            exact_cases(ctx, gpu[0], gpu[1], paths[p]);
            frames(ctx, gpu[0], gpu[1]);
        }
        cv_transfer_clear_path();
        refused_rings(ctx, gpu[0], gpu[1]);
        cv_device_destroy(gpu[0]);
        cv_device_destroy(gpu[1]);
    }
    cv_context_destroy(ctx);
    CHECK_NOTHING_LIVE();
    return vkt_report("vk_transfer_async");
}
