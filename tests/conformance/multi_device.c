/* Several devices of one backend in one context: cross-device transfers, and
 * parallel recording and submission from several threads. */
#include <pthread.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "conformance.h"
#include "corvid/transfer.h"

void conformance_transfers(const fixture *fx) {
    cv_context *ctx;
    CHECK_OK(cv_context_create(NULL, &ctx));
    cv_device *a = NULL, *b = NULL;
    CHECK_OK(fixture_device(fx, ctx, 0, &a));
    CHECK_OK(fixture_device(fx, ctx, 1, &b));
    if (!a || !b) {
        cv_context_destroy(ctx);
        return;
    }
    cv_buffer buf;
    cv_texture tex, tex_f;
    CHECK_OK(cv_buffer_create(ctx, &(cv_buffer_desc){ .size = 4096, .label = "shared" }, &buf));
    CHECK_OK(cv_texture_create(
        ctx, &(cv_texture_desc){ .width = 32, .height = 16, .format = CV_FORMAT_RGBA16F, .label = "partition" },
        &tex));
    CHECK_OK(
        cv_texture_create(ctx, &(cv_texture_desc){ .width = 32, .height = 16, .format = CV_FORMAT_RGBA32F }, &tex_f));
    /* One handle, a representation on each device. */
    CHECK_OK(cv_device_load(a, cv_any(buf)));
    CHECK_OK(cv_device_load(b, cv_any(buf)));
    CHECK_OK(cv_device_load(a, cv_any(tex)));
    CHECK_OK(cv_device_load(b, cv_any(tex)));
    CHECK_OK(cv_device_load(b, cv_any(tex_f)));

    uint8_t data[4096], zero[4096] = { 0 }, out[4096];
    for (int i = 0; i < 4096; i++)
        data[i] = (uint8_t)(i * 31 + 1);
    CHECK_OK(cv_device_write_buffer(a, buf, 0, 4096, data));
    CHECK_OK(cv_device_write_buffer(b, buf, 0, 4096, zero));
    cv_transfer_stats st = { 0 };
    CHECK_OK(cv_transfer_buffer(a, buf, 1000, b, buf, 3000, 1000, &st));
    CHECK_EQ_INT(st.bytes, 1000);
    CHECK(st.total_ms >= 0);
    CHECK_OK(cv_device_read_buffer(b, buf, 0, 4096, out));
    CHECK(memcmp(out + 3000, data + 1000, 1000) == 0);
    CHECK(memcmp(out, zero, 3000) == 0);
    CHECK(memcmp(out + 4000, zero, 96) == 0);

    /* A column partition of a texture, as multi-GPU tracing copies it back. */
    uint16_t texels[32 * 16 * 4], back[32 * 16 * 4];
    for (int i = 0; i < 32 * 16 * 4; i++)
        texels[i] = (uint16_t)(0x3C00 + i); /* finite halves */
    memset(back, 0, sizeof(back));
    CHECK_OK(cv_device_write_texture(a, tex, (cv_rect){ 0, 0, 32, 16 }, texels));
    CHECK_OK(cv_device_write_texture(b, tex, (cv_rect){ 0, 0, 32, 16 }, back));
    CHECK_OK(cv_transfer_texture(a, tex, (cv_rect){ 8, 0, 8, 16 }, b, tex, 8, 0, &st));
    CHECK_EQ_INT(st.bytes, 8 * 16 * 8);
    CHECK_OK(cv_device_read_texture(b, tex, (cv_rect){ 0, 0, 32, 16 }, back));
    for (int y = 0; y < 16; y++) {
        CHECK(memcmp(back + (y * 32 + 8) * 4, texels + (y * 32 + 8) * 4, 8 * 8) == 0);
        CHECK(back[(y * 32 + 7) * 4] == 0 && back[(y * 32 + 16) * 4] == 0);
    }
    CHECK_RESULT(cv_transfer_texture(a, tex_f, (cv_rect){ 0, 0, 8, 8 }, b, tex_f, 0, 0, NULL), CV_ERROR_NOT_LOADED);
    CHECK_RESULT(cv_transfer_texture(a, tex, (cv_rect){ 0, 0, 8, 8 }, b, tex_f, 0, 0, NULL),
                 CV_ERROR_FORMAT_MISMATCH);
    CHECK_RESULT(cv_transfer_texture(a, tex, (cv_rect){ 28, 0, 8, 8 }, b, tex, 0, 0, NULL), CV_ERROR_OUT_OF_RANGE);
    CHECK_RESULT(cv_transfer_buffer(a, buf, 4000, b, buf, 0, 200, NULL), CV_ERROR_OUT_OF_RANGE);
    /* Transfers larger than one staging chunk (4 MiB) are pipelined in pieces. */
    const uint64_t big = 9u << 20;
    cv_buffer large;
    cv_texture tall;
    CHECK_OK(cv_buffer_create(ctx, &(cv_buffer_desc){ .size = big, .label = "large" }, &large));
    CHECK_OK(cv_texture_create(
        ctx, &(cv_texture_desc){ .width = 1024, .height = 1100, .format = CV_FORMAT_RGBA32F, .label = "tall" },
        &tall));
    CHECK_OK(cv_device_load(a, cv_any(large)));
    CHECK_OK(cv_device_load(b, cv_any(large)));
    CHECK_OK(cv_device_load(a, cv_any(tall)));
    CHECK_OK(cv_device_load(b, cv_any(tall)));
    uint32_t *words = malloc(big), *back_words = calloc(1, big);
    for (uint64_t i = 0; words && i < big / 4; i++)
        words[i] = (uint32_t)(i * 2654435761u);
    if (words && back_words) {
        CHECK_OK(cv_device_write_buffer(a, large, 0, big, words));
        CHECK_OK(cv_device_write_buffer(b, large, 0, big, back_words));
        CHECK_OK(cv_transfer_buffer(a, large, 4, b, large, 0, big - 8, &st));
        CHECK_EQ_INT(st.bytes, big - 8);
        CHECK_OK(cv_device_read_buffer(b, large, 0, big, back_words));
        CHECK(memcmp(back_words, words + 1, big - 8) == 0);
        CHECK(back_words[big / 4 - 1] == 0 && back_words[big / 4 - 2] == 0);
        /* 1024 x 1100 float4 texels = 18 MB: 5 row bands; copy rows 3..1099 to rows 0..1096. */
        CHECK_OK(cv_device_write_texture(a, tall, (cv_rect){ 0, 0, 1024, 256 }, words));
        CHECK_OK(cv_device_write_texture(a, tall, (cv_rect){ 0, 256, 1024, 144 }, words));
        CHECK_OK(cv_transfer_texture(a, tall, (cv_rect){ 0, 3, 1024, 1097 }, b, tall, 0, 0, &st));
        CHECK_EQ_INT(st.bytes, 1024ull * 1097 * 16);
        CHECK(st.read_ms >= 0 && st.write_ms >= 0 && st.total_ms >= 0);
        CHECK_OK(cv_device_read_texture(b, tall, (cv_rect){ 0, 0, 1024, 2 }, back_words));
        CHECK(memcmp(back_words, words + 3 * 1024 * 4, 2 * 1024 * 16) == 0);
        CHECK_OK(cv_device_read_texture(b, tall, (cv_rect){ 0, 253, 1024, 1 }, back_words));
        CHECK(memcmp(back_words, words, 1024 * 16) == 0); /* source row 256 = words row 0 */
    }
    free(words);
    free(back_words);
    /* Unloading on one device leaves the other's representation alone. */
    CHECK_OK(cv_device_unload(a, cv_any(buf)));
    CHECK(cv_device_has(b, cv_any(buf)));
    CHECK_RESULT(cv_transfer_buffer(a, buf, 0, b, buf, 0, 16, NULL), CV_ERROR_NOT_LOADED);
    /* Devices can go away while the application runs. */
    cv_device_destroy(a);
    CHECK_OK(cv_device_read_buffer(b, buf, 3000, 16, out));
    CHECK(memcmp(out, data + 1000, 16) == 0);
    cv_context_destroy(ctx);
}

typedef struct worker {
    cv_context *ctx;
    cv_device *dev;
    cv_buffer buf;
    uint32_t seed;
    int failures;
} worker;

/* Each thread records its own list (thousands of commands) and submits it. */
static void *work(void *arg) {
    worker *w = arg;
    cv_cmdlist list;
    cv_command_list *l;
    if (cv_cmdlist_create(w->ctx, &list) != CV_OK || cv_cmdlist_begin(w->ctx, list, &l) != CV_OK) {
        w->failures++;
        return NULL;
    }
    for (uint32_t i = 0; i < 2000; i++) {
        uint32_t v = w->seed * 100000 + i;
        cv_cmd_update_buffer(l, CV_QUEUE_COPY,
                             &(cv_update_buffer_args){
                                 .buffer = w->buf, .offset = (i % 64) * 4, .data = &v, .data_size = 4 });
    }
    uint64_t t;
    if (cv_command_list_end(l) != CV_OK || cv_device_submit(w->dev, list, &t) != CV_OK ||
        cv_device_wait(w->dev, t, UINT64_MAX) != CV_OK)
        w->failures++;
    uint32_t out[64];
    if (cv_device_read_buffer(w->dev, w->buf, 0, sizeof(out), out) != CV_OK)
        w->failures++;
    for (uint32_t k = 0; k < 64; k++)
        if (out[k] != w->seed * 100000 + k + 64 * ((1999 - k) / 64)) /* the last write to each word */
            w->failures++;
    cv_cmdlist_destroy(w->ctx, list);
    return NULL;
}

void conformance_parallel(const fixture *fx) {
    enum { N = 3 };
    cv_context *ctx;
    CHECK_OK(cv_context_create(NULL, &ctx));
    worker workers[N] = { 0 };
    pthread_t threads[N];
    for (uint32_t i = 0; i < N; i++) {
        workers[i] = (worker){ .ctx = ctx, .seed = i + 1 };
        CHECK_OK(fixture_device(fx, ctx, i, &workers[i].dev));
        CHECK_OK(cv_buffer_create(ctx, &(cv_buffer_desc){ .size = 256 }, &workers[i].buf));
        CHECK_OK(cv_device_load(workers[i].dev, cv_any(workers[i].buf)));
    }
    for (uint32_t i = 0; i < N; i++)
        pthread_create(&threads[i], NULL, work, &workers[i]);
    for (uint32_t i = 0; i < N; i++) {
        pthread_join(threads[i], NULL);
        CHECK_EQ_INT(workers[i].failures, 0);
    }
    CHECK_EQ_INT(cv_context_live_count(ctx, CV_HANDLE_CMDLIST), 0);
    cv_context_destroy(ctx);
}
