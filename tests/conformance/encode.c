/* Frame readers (media's frame_reader.h) on every backend: a texture read
 * already encoded where the device is (a proxy device's node encodes, so only
 * the encoded bytes cross the link). RAW, ZSTD and PNG give exactly what
 * cv_device_read_texture gives; JPEG and H.264 decode to the pattern within a
 * stated tolerance; H.264 marks its keyframes; RGBA32F travels through ZSTD
 * exactly; bad requests are refused with their code and change nothing. */
#include <pthread.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "conformance.h"
#include "corvid/frame_codec.h"
#include "corvid/frame_reader.h"
#include "corvid/proxy.h"

#define W 64u
#define H 48u

/* A smooth gradient with a block of strong color, moved `shift` texels right
 * (H.264 frames move it); alpha varies, which PNG, JPEG and H.264 drop. */
static void pattern(uint8_t *px, uint32_t shift) {
    for (uint32_t y = 0; y < H; y++)
        for (uint32_t x = 0; x < W; x++) {
            uint8_t *p = px + 4 * (y * W + x);
            bool block = x >= 8 + shift && x < 24 + shift && y >= 8 && y < 24;
            p[0] = block ? 240 : (uint8_t)(x * 255 / (W - 1));
            p[1] = block ? 40 : (uint8_t)(y * 255 / (H - 1));
            p[2] = block ? 48 : (uint8_t)(30 + 2 * (x + y));
            p[3] = (uint8_t)(255 - x);
        }
}

static cv_result make_texture(world *w, cv_format f, const char *label, cv_texture *out) {
    cv_texture_desc d = { .width = W, .height = H, .format = f };
    strncpy(d.label, label, sizeof(d.label) - 1);
    cv_result r = cv_texture_create(w->ctx, &d, out);
    return r == CV_OK ? cv_device_load(w->dev, cv_any(*out)) : r;
}

/* Reads t through a new reader of `codec`: one frame, which *out gets. */
static cv_result read_once(world *w, cv_codec codec, cv_texture t, const cv_encode_params *p, cv_encoded *out) {
    cv_frame_reader *r = NULL;
    cv_result rr = cv_frame_reader_create(w->dev, codec, W, H, &r);
    if (rr != CV_OK)
        return rr;
    CHECK(cv_frame_reader_is_remote(r) == (w->fx->node_backend != NULL));
    rr = cv_frame_reader_read(r, t, (cv_rect){ 0, 0, W, H }, p, out);
    cv_frame_reader_destroy(r);
    return rr;
}

/* The decoded picture of one frame (RGBA8, or the bytes for RAW/ZSTD); NULL if it failed. */
static uint8_t *decode(cv_codec codec, const cv_encoded *e, size_t *size) {
    cv_decoder *d = NULL;
    uint8_t *out = NULL;
    uint32_t width = 0, height = 0;
    *size = 0;
    if (cv_decoder_create(codec, &d) != CV_OK)
        return NULL;
    CHECK_OK(cv_decoder_decode(d, e->data, e->size, &out, size, &width, &height));
    if (codec != CV_CODEC_RAW && codec != CV_CODEC_ZSTD) {
        CHECK_EQ_INT(width, W);
        CHECK_EQ_INT(height, H);
    }
    cv_decoder_destroy(d);
    return out;
}

/* Mean absolute difference of the color channels (alpha is not encoded), and
 * the count of channels off by more than `far`. */
static double color_error(const uint8_t *a, const uint8_t *b, uint32_t far, uint32_t *far_count) {
    uint64_t sum = 0;
    *far_count = 0;
    for (uint32_t i = 0; i < W * H; i++)
        for (int c = 0; c < 3; c++) {
            uint32_t d = (uint32_t)abs((int)a[4 * i + c] - (int)b[4 * i + c]);
            sum += d;
            *far_count += d > far;
        }
    return (double)sum / (W * H * 3);
}

static void lossless(world *w, cv_texture rgba8, const uint8_t *texels) {
    cv_encoded e = { 0 };
    size_t n = 0;
    CHECK_OK(read_once(w, CV_CODEC_RAW, rgba8, NULL, &e)); /* RAW: the texels themselves */
    CHECK(e.codec == CV_CODEC_RAW && e.width == W && e.height == H && e.size == W * H * 4);
    CHECK(e.size == W * H * 4 && memcmp(e.data, texels, e.size) == 0);
    cv_encoded_free(&e);

    CHECK_OK(read_once(w, CV_CODEC_ZSTD, rgba8, &(cv_encode_params){ .zstd_level = 5 }, &e));
    CHECK(e.codec == CV_CODEC_ZSTD && e.size > 0 && e.size < W * H * 4);
    uint8_t *out = decode(CV_CODEC_ZSTD, &e, &n);
    CHECK(out && n == W * H * 4 && memcmp(out, texels, n) == 0);
    free(out);
    cv_encoded_free(&e);

    CHECK_OK(read_once(w, CV_CODEC_PNG, rgba8, NULL, &e)); /* PNG: RGB exact, alpha 255 */
    CHECK(e.codec == CV_CODEC_PNG && e.size > 8 && memcmp(e.data, "\x89PNG", 4) == 0);
    out = decode(CV_CODEC_PNG, &e, &n);
    uint32_t wrong = 0;
    for (uint32_t i = 0; out && n == W * H * 4 && i < W * H; i++)
        wrong += memcmp(out + 4 * i, texels + 4 * i, 3) != 0 || out[4 * i + 3] != 255;
    CHECK(out && n == W * H * 4);
    CHECK_EQ_INT(wrong, 0);
    free(out);
    cv_encoded_free(&e);
}

/* RGBA32F through ZSTD: the float texels exactly, as cv_device_read_texture gives them. */
static void float_planes(world *w) {
    cv_texture f32;
    CHECK_OK(make_texture(w, CV_FORMAT_RGBA32F, "encode rgba32f", &f32));
    float *texels = malloc(W * H * 16), *back = malloc(W * H * 16);
    for (uint32_t i = 0; i < W * H * 4; i++)
        texels[i] = (float)(i % 97) * 0.37f - 5.0f + (i % 4 == 3 ? 1e6f : 0.0f);
    CHECK_OK(cv_device_write_texture(w->dev, f32, (cv_rect){ 0, 0, W, H }, texels));
    CHECK_OK(cv_device_read_texture(w->dev, f32, (cv_rect){ 0, 0, W, H }, back));
    cv_encoded e = { 0 };
    CHECK_OK(read_once(w, CV_CODEC_ZSTD, f32, NULL, &e));
    size_t n = 0;
    uint8_t *out = decode(CV_CODEC_ZSTD, &e, &n);
    CHECK(out && n == W * H * 16 && memcmp(out, back, n) == 0);
    free(out);
    cv_encoded_free(&e);
    /* JPEG takes RGBA8 only: refused, by the reader's check, before anything is read. */
    CHECK_RESULT(read_once(w, CV_CODEC_JPEG, f32, NULL, &e), CV_ERROR_FORMAT_MISMATCH);
    CHECK(e.data == NULL && e.size == 0);
    free(texels);
    free(back);
    CHECK_OK(cv_texture_destroy(w->ctx, f32));
}

/* JPEG at quality 90: mean error at most 3 levels, no more than 2% of the channels past 24
 * (the block's edges, 4:2:0 chroma). The link carries the JPEG, not the texels. */
static void jpeg(world *w, cv_texture rgba8, const uint8_t *texels) {
    cv_proxy_stats before = { 0 }, after = { 0 };
    bool proxy = w->fx->node_backend != NULL;
    if (proxy)
        CHECK_OK(cv_proxy_get_stats(w->dev, &before));
    cv_encoded e = { 0 };
    CHECK_OK(read_once(w, CV_CODEC_JPEG, rgba8, &(cv_encode_params){ .quality = 90 }, &e));
    if (proxy) {
        CHECK_OK(cv_proxy_get_stats(w->dev, &after));
        uint64_t link = after.bytes_received - before.bytes_received;
        CHECK(link >= e.size && link < e.size + 512); /* the frame and its envelopes, nothing more */
        CHECK(link * 4 < W * H * 4);
        CHECK_EQ_INT(after.encoded_frames - before.encoded_frames, 1);
    }
    CHECK(e.codec == CV_CODEC_JPEG && e.size > 2 && e.data[0] == 0xff && e.data[1] == 0xd8);
    CHECK(e.read_ms >= 0.0 && e.encode_ms > 0.0);
    size_t n = 0;
    uint8_t *out = decode(CV_CODEC_JPEG, &e, &n);
    CHECK(out && n == W * H * 4);
    if (out && n == W * H * 4) {
        uint32_t far = 0;
        double mean = color_error(out, texels, 24, &far);
        CHECK(mean <= 3.0);
        CHECK(far <= W * H * 3 / 50);
    }
    free(out);
    cv_encoded_free(&e);
}

/* H.264: frames 1..3 of a moving pattern, then a keyframe asked for. The first
 * and the fourth are IDRs; each decodes to its frame with mean error at most 4. */
static void h264(world *w, cv_texture rgba8) {
    cv_frame_reader *r = NULL;
    CHECK_OK(cv_frame_reader_create(w->dev, CV_CODEC_H264, W, H, &r));
    cv_decoder *d = NULL;
    CHECK_OK(cv_decoder_create(CV_CODEC_H264, &d));
    uint8_t *px = malloc(W * H * 4);
    const bool expect_key[4] = { true, false, false, true };
    uint32_t pictures = 0;
    for (uint32_t f = 0; f < 4; f++) {
        pattern(px, 2 * f);
        CHECK_OK(cv_device_write_texture(w->dev, rgba8, (cv_rect){ 0, 0, W, H }, px));
        cv_encode_params p = { .bitrate_kbps = 4000, .fps = 30, .keyframe = f == 3 };
        cv_encoded e = { 0 };
        CHECK_OK(cv_frame_reader_read(r, rgba8, (cv_rect){ 0, 0, W, H }, &p, &e));
        CHECK(e.codec == CV_CODEC_H264 && e.size > 4);
        CHECK(e.keyframe == expect_key[f]);
        uint8_t *out = NULL;
        size_t n = 0;
        uint32_t width = 0, height = 0;
        CHECK_OK(cv_decoder_decode(d, e.data, e.size, &out, &n, &width, &height));
        if (n == W * H * 4 && width == W && height == H) { /* a picture (baseline: no reordering delay) */
            uint32_t far = 0;
            CHECK(color_error(out, px, 32, &far) <= 4.0);
            pictures++;
        }
        free(out);
        cv_encoded_free(&e);
    }
    CHECK_EQ_INT(pictures, 4);
    free(px);
    cv_decoder_destroy(d);
    cv_frame_reader_destroy(r);
}

/* Bad requests: refused with their code, *out zeroed, and the device, the
 * reader and the texture go on as before. */
static void refusals(world *w, cv_texture rgba8, const uint8_t *texels) {
    cv_frame_reader *r = NULL;
    CHECK_RESULT(cv_frame_reader_create(w->dev, CV_CODEC_H264, 63, 48, &r), CV_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(cv_frame_reader_create(w->dev, (cv_codec)9, W, H, &r), CV_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(cv_frame_reader_create(w->dev, CV_CODEC_JPEG, 0, H, &r), CV_ERROR_INVALID_ARGUMENT);
    CHECK(r == NULL);
    CHECK_OK(cv_frame_reader_create(w->dev, CV_CODEC_JPEG, W, H, &r));
    cv_encoded e = { 0 };
    const cv_rect all = { 0, 0, W, H };
    CHECK_RESULT(cv_frame_reader_read(r, rgba8, (cv_rect){ 0, 0, W / 2, H }, NULL, &e), CV_ERROR_FORMAT_MISMATCH);
    CHECK_RESULT(cv_frame_reader_read(r, rgba8, (cv_rect){ 1, 0, W, H }, NULL, &e), CV_ERROR_OUT_OF_RANGE);
    CHECK_RESULT(cv_frame_reader_read(r, rgba8, all, &(cv_encode_params){ .quality = 101 }, &e),
                 CV_ERROR_OUT_OF_RANGE);
    CHECK(strstr(cv_last_error(), "quality 101") != NULL);
    CHECK_RESULT(cv_frame_reader_read(r, rgba8, all, &(cv_encode_params){ .zstd_level = 50 }, &e),
                 CV_ERROR_OUT_OF_RANGE);
    CHECK_RESULT(cv_frame_reader_read(r, rgba8, all, &(cv_encode_params){ .bitrate_kbps = 2000000 }, &e),
                 CV_ERROR_OUT_OF_RANGE);
    cv_texture unloaded;
    CHECK_OK(cv_texture_create(w->ctx, &(cv_texture_desc){ .width = W, .height = H, .format = CV_FORMAT_RGBA8_UNORM },
                               &unloaded));
    CHECK_RESULT(cv_frame_reader_read(r, unloaded, all, NULL, &e), CV_ERROR_NOT_LOADED);
    CHECK_OK(cv_texture_destroy(w->ctx, unloaded));
    CHECK(cv_frame_reader_read(r, unloaded, all, NULL, &e) != CV_OK);
    CHECK(e.data == NULL && e.size == 0);
    CHECK_OK(cv_frame_reader_read(r, rgba8, all, NULL, &e)); /* the reader goes on */
    CHECK(e.size > 0);
    cv_encoded_free(&e);
    cv_frame_reader_destroy(r);
    uint8_t *back = malloc(W * H * 4); /* so does the device */
    CHECK_OK(cv_device_read_texture(w->dev, rgba8, all, back));
    CHECK(memcmp(back, texels, W * H * 4) == 0);
    free(back);
}

/* Other calls on the device while readers read: plain reads on one thread, a
 * second reader (its own stream) on another. The device locks each call; a
 * remote reader waits for its frame without the lock. */
typedef struct side_reads {
    world *w;
    cv_texture t;
    bool encoded; /* through a ZSTD frame reader, else cv_device_read_texture */
    uint32_t wrong;
} side_reads;

static void *read_beside(void *arg) {
    side_reads *s = arg;
    uint8_t *px = malloc(W * H * 4), *want = malloc(W * H * 4);
    pattern(want, 0);
    cv_frame_reader *r = NULL;
    if (s->encoded && cv_frame_reader_create(s->w->dev, CV_CODEC_ZSTD, W, H, &r) != CV_OK)
        s->wrong++;
    for (int i = 0; i < 8; i++) {
        if (!s->encoded) {
            s->wrong += cv_device_read_texture(s->w->dev, s->t, (cv_rect){ 0, 0, W, H }, px) != CV_OK ||
                        memcmp(px, want, W * H * 4) != 0;
            continue;
        }
        cv_encoded e = { 0 };
        size_t n = 0;
        uint8_t *out = NULL;
        uint32_t width, height;
        cv_decoder *d = NULL; /* no CHECK on this thread: check.h's counters are the main thread's */
        if (r && cv_frame_reader_read(r, s->t, (cv_rect){ 0, 0, W, H }, NULL, &e) == CV_OK &&
            cv_decoder_create(CV_CODEC_ZSTD, &d) == CV_OK)
            cv_decoder_decode(d, e.data, e.size, &out, &n, &width, &height);
        s->wrong += !out || n != W * H * 4 || memcmp(out, want, n) != 0;
        cv_decoder_destroy(d);
        free(out);
        cv_encoded_free(&e);
    }
    cv_frame_reader_destroy(r);
    free(px);
    free(want);
    return NULL;
}

static void beside_other_calls(world *w, cv_texture rgba8, cv_texture other) {
    side_reads side[2] = { { w, other, false, 0 }, { w, other, true, 0 } };
    pthread_t threads[2];
    for (int i = 0; i < 2; i++)
        CHECK(pthread_create(&threads[i], NULL, read_beside, &side[i]) == 0);
    cv_frame_reader *r = NULL;
    CHECK_OK(cv_frame_reader_create(w->dev, CV_CODEC_RAW, W, H, &r));
    uint8_t *want = malloc(W * H * 4);
    CHECK_OK(cv_device_read_texture(w->dev, rgba8, (cv_rect){ 0, 0, W, H }, want));
    uint32_t wrong = 0;
    for (int i = 0; i < 8; i++) {
        cv_encoded e = { 0 };
        wrong += cv_frame_reader_read(r, rgba8, (cv_rect){ 0, 0, W, H }, NULL, &e) != CV_OK || e.size != W * H * 4 ||
                 memcmp(e.data, want, e.size) != 0;
        cv_encoded_free(&e);
    }
    for (int i = 0; i < 2; i++)
        pthread_join(threads[i], NULL);
    CHECK_EQ_INT(wrong, 0);
    CHECK_EQ_INT(side[0].wrong, 0);
    CHECK_EQ_INT(side[1].wrong, 0);
    free(want);
    cv_frame_reader_destroy(r);
}

void conformance_encode(world *w) {
    cv_texture rgba8, other;
    CHECK_OK(make_texture(w, CV_FORMAT_RGBA8_UNORM, "encode rgba8", &rgba8));
    CHECK_OK(make_texture(w, CV_FORMAT_RGBA8_UNORM, "encode other", &other));
    uint8_t *texels = malloc(W * H * 4);
    pattern(texels, 0);
    CHECK_OK(cv_device_write_texture(w->dev, rgba8, (cv_rect){ 0, 0, W, H }, texels));
    CHECK_OK(cv_device_write_texture(w->dev, other, (cv_rect){ 0, 0, W, H }, texels));
    lossless(w, rgba8, texels);
    jpeg(w, rgba8, texels);
    refusals(w, rgba8, texels);
    beside_other_calls(w, rgba8, other);
    float_planes(w);
    h264(w, rgba8);
    free(texels);
    CHECK_OK(cv_texture_destroy(w->ctx, rgba8));
    CHECK_OK(cv_texture_destroy(w->ctx, other));
    CHECK_EQ_INT(cv_live_decoders(), 0);
    if (!w->fx->node_backend) /* a node frees its streams when their close arrives: checked at the end */
        CHECK_EQ_INT(cv_live_encoders(), 0);
}
