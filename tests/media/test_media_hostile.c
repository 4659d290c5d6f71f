/* Hostile bytes to every decoder of corvid_media: empty input, garbage, every truncation
 * of a valid frame, bit flips, and headers that claim huge pictures or contents. Each call
 * must come back (an error, or for a flip that still parses a well-formed picture) and
 * never crash or overrun: CI runs this under ASan and UBSan. A failed decode hands out
 * nothing. */
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "corvid/frame_codec.h"
#include "synthetic_frame.h"

#define W 64
#define H 48

static uint32_t rng_state = 12345u;
static uint32_t next_random(void) {
    rng_state = rng_state * 1664525u + 1013904223u;
    return rng_state >> 8;
}

/* One decode of hostile bytes: an error hands out nothing; a success hands out a consistent picture. */
static cv_result decode_once(cv_decoder *d, cv_codec codec, const uint8_t *data, size_t size) {
    uint8_t *out = (uint8_t *)&rng_state; /* must be overwritten */
    size_t n = 99;
    uint32_t w = 7, h = 7;
    cv_result r = cv_decoder_decode(d, data, size, &out, &n, &w, &h);
    if (r != CV_OK) {
        CHECK(out == NULL && n == 0 && w == 0 && h == 0);
        CHECK(cv_last_error()[0] != '\0');
    } else if (codec == CV_CODEC_JPEG || codec == CV_CODEC_PNG || (codec == CV_CODEC_H264 && n > 0)) {
        CHECK(out != NULL && n == (size_t)w * h * 4);
    }
    if (r == CV_OK)
        free(out);
    return r;
}

static cv_encoded encode(cv_codec codec, bool second_frame) {
    uint8_t *src = malloc(W * H * 4);
    synthetic_frame(src, W, H, 0, 1);
    cv_encoder *e = NULL;
    cv_encoded f = { 0 };
    CHECK_OK(cv_encoder_create(codec, W, H, &e));
    CHECK_OK(cv_encoder_encode(e, src, W * 4, NULL, &f));
    if (second_frame) { /* a P frame, for H.264 */
        cv_encoded_free(&f);
        synthetic_frame(src, W, H, 1, 1);
        CHECK_OK(cv_encoder_encode(e, src, W * 4, NULL, &f));
    }
    cv_encoder_destroy(e);
    free(src);
    return f;
}

/* Garbage, every truncation and bit flips of a valid frame, each through a fresh decoder and one shared one. */
static void fuzz_codec(cv_codec codec) {
    cv_decoder *shared = NULL;
    CHECK_OK(cv_decoder_create(codec, &shared));
    if (!shared)
        return;
    int errors = 0, calls = 0;
    uint8_t garbage[4096];
    for (int i = 0; i < 64; i++) {
        size_t n = next_random() % sizeof garbage;
        for (size_t k = 0; k < n; k++)
            garbage[k] = (uint8_t)next_random();
        if (i % 4 == 0 && n > 4) /* start codes and markers make parsers go further */
            memcpy(garbage, (const uint8_t[]){ 0, 0, 0, 1 }, 4);
        errors += decode_once(shared, codec, garbage, n) != CV_OK;
        calls++;
    }
    cv_encoded valid = encode(codec, false);
    for (size_t cut = 0; cut < valid.size; cut += 1 + valid.size / 97) {
        cv_decoder *fresh = NULL;
        CHECK_OK(cv_decoder_create(codec, &fresh));
        errors += decode_once(fresh, codec, valid.data, cut) != CV_OK;
        calls++;
        cv_decoder_destroy(fresh);
    }
    uint8_t *copy = malloc(valid.size);
    for (int i = 0; i < 200 && copy; i++) {
        memcpy(copy, valid.data, valid.size);
        for (int flips = 1 + (int)(next_random() % 4); flips > 0; flips--)
            copy[next_random() % valid.size] ^= (uint8_t)(1u << (next_random() % 8));
        cv_decoder *fresh = NULL;
        CHECK_OK(cv_decoder_create(codec, &fresh));
        decode_once(fresh, codec, copy, valid.size);
        decode_once(shared, codec, copy, valid.size);
        calls += 2;
        cv_decoder_destroy(fresh);
    }
    free(copy);
    /* The decoder still decodes a good frame after all that (a fresh stream for H.264: an IDR). */
    uint8_t *out = NULL;
    size_t n = 0;
    uint32_t w = 0, h = 0;
    CHECK_OK(cv_decoder_decode(shared, valid.data, valid.size, &out, &n, &w, &h));
    CHECK(codec == CV_CODEC_ZSTD || codec == CV_CODEC_RAW || (w == W && h == H && n == W * H * 4));
    free(out);
    printf("%s: %d hostile calls, %d refused\n", cv_codec_name(codec), calls, errors);
    CHECK(codec == CV_CODEC_RAW || errors > 0);
    cv_encoded_free(&valid);
    cv_decoder_destroy(shared);
}

/* A zstd frame header that claims 2 GiB of content (single segment, 8-byte content size), then a last raw block. */
static void test_zstd_bomb(void) {
    const uint8_t frame[] = { 0x28, 0xb5, 0x2f, 0xfd, 0xe0, 0, 0, 0, 0x80, 0, 0, 0, 0, 0x09, 0, 0, 'x' };
    cv_decoder *d = NULL;
    CHECK_OK(cv_decoder_create(CV_CODEC_ZSTD, &d));
    CHECK_RESULT(decode_once(d, CV_CODEC_ZSTD, frame, sizeof frame), CV_ERROR_LIMIT_EXCEEDED);
    CHECK(strstr(cv_last_error(), "2147483648"));
    /* Two frames back to back, and a frame without its content size: refused. */
    cv_encoded one = encode(CV_CODEC_ZSTD, false);
    uint8_t *two = malloc(one.size * 2);
    memcpy(two, one.data, one.size);
    memcpy(two + one.size, one.data, one.size);
    CHECK_RESULT(decode_once(d, CV_CODEC_ZSTD, two, one.size * 2), CV_ERROR_MALFORMED);
    two[4] &= 0x3f; /* no content size, no single segment: the window byte is missing then, so also malformed */
    CHECK_RESULT(decode_once(d, CV_CODEC_ZSTD, two, one.size), CV_ERROR_MALFORMED);
    free(two);
    cv_encoded_free(&one);
    cv_decoder_destroy(d);
}

/* JPEG and PNG headers patched to claim pictures over CV_CODEC_MAX_SIDE. */
static void test_huge_headers(void) {
    cv_encoded jpeg = encode(CV_CODEC_JPEG, false);
    cv_decoder *d = NULL;
    CHECK_OK(cv_decoder_create(CV_CODEC_JPEG, &d));
    for (size_t i = 0; i + 8 < jpeg.size; i++) {
        if (jpeg.data[i] == 0xff && jpeg.data[i + 1] == 0xc0) { /* SOF0: length, precision, height, width */
            jpeg.data[i + 5] = 0x80;                            /* 32768 x 32768: libjpeg takes up to 65500 */
            jpeg.data[i + 6] = 0x00;
            jpeg.data[i + 7] = 0x80;
            jpeg.data[i + 8] = 0x00;
            break;
        }
    }
    CHECK_RESULT(decode_once(d, CV_CODEC_JPEG, jpeg.data, jpeg.size), CV_ERROR_LIMIT_EXCEEDED);
    cv_decoder_destroy(d);
    cv_encoded_free(&jpeg);

    cv_encoded png = encode(CV_CODEC_PNG, false);
    CHECK_OK(cv_decoder_create(CV_CODEC_PNG, &d));
    png.data[16] = 0x00; /* IHDR width 0x0000f040... (the CRC no longer matches either) */
    png.data[17] = 0x00;
    png.data[18] = 0xf0;
    CHECK_RESULT(decode_once(d, CV_CODEC_PNG, png.data, png.size), CV_ERROR_MALFORMED);
    cv_decoder_destroy(d);
    cv_encoded_free(&png);
}

/* A P frame with no IDR before it: no reference, an error rather than a concealed guess. */
static void test_h264_without_idr(void) {
    cv_encoded p = encode(CV_CODEC_H264, true);
    CHECK(!p.keyframe);
    cv_decoder *d = NULL;
    CHECK_OK(cv_decoder_create(CV_CODEC_H264, &d));
    CHECK(decode_once(d, CV_CODEC_H264, p.data, p.size) != CV_OK);
    CHECK_RESULT(decode_once(d, CV_CODEC_H264, NULL, 0), CV_ERROR_MALFORMED);
    cv_decoder_destroy(d);
    cv_encoded_free(&p);
}

int main(void) {
    check_live_counter("encoders", cv_live_encoders);
    check_live_counter("decoders", cv_live_decoders);
    for (cv_codec c = 0; c < CV_CODEC_COUNT; c++)
        fuzz_codec(c);
    test_zstd_bomb();
    test_huge_headers();
    test_h264_without_idr();
    CHECK_NOTHING_LIVE();
    return check_report("test_media_hostile");
}
