/* Round trips through corvid_media's codecs, each against a stated tolerance: JPEG of a
 * rendered-looking frame (mean error <= 3 LSB, every channel's PSNR > 35 dB), a moving
 * H.264 sequence (PSNR > 30 dB a frame at the default bitrate; keyframes exactly on the
 * first and the requested frames, each IDR with its SPS and PPS), PNG, ZSTD and RAW
 * exact; quality and bitrate change the size; refused sizes and parameters. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "corvid/frame_codec.h"
#include "synthetic_frame.h"

#define W 320
#define H 180

static uint8_t *frame_at(uint32_t t, uint32_t noise) {
    uint8_t *rgba = malloc((size_t)W * H * 4);
    synthetic_frame(rgba, W, H, t, noise);
    return rgba;
}

/* Encodes one frame with a new encoder and decodes it; the decoded bytes or NULL. */
static uint8_t *round_trip(cv_codec codec, const uint8_t *pixels, size_t stride, uint32_t h,
                           const cv_encode_params *p, size_t *encoded_size, size_t *decoded_size) {
    cv_encoder *e = NULL;
    cv_decoder *d = NULL;
    cv_encoded frame = { 0 };
    uint8_t *out = NULL;
    uint32_t ow = 0, oh = 0;
    CHECK_OK(cv_encoder_create(codec, (uint32_t)(stride / 4), h, &e));
    CHECK_OK(cv_decoder_create(codec, &d));
    if (e && d && cv_encoder_encode(e, pixels, stride, p, &frame) == CV_OK) {
        CHECK_EQ_INT(frame.codec, codec);
        CHECK(frame.keyframe);
        CHECK(frame.encode_ms >= 0);
        *encoded_size = frame.size;
        CHECK_OK(cv_decoder_decode(d, frame.data, frame.size, &out, decoded_size, &ow, &oh));
    } else {
        CHECK(!"encode failed");
    }
    if (out && (codec == CV_CODEC_JPEG || codec == CV_CODEC_PNG)) {
        CHECK_EQ_INT(ow, stride / 4);
        CHECK_EQ_INT(oh, h);
    }
    cv_encoded_free(&frame);
    CHECK(frame.data == NULL && frame.size == 0);
    cv_encoder_destroy(e);
    cv_decoder_destroy(d);
    return out;
}

static void test_jpeg(void) {
    uint8_t *src = frame_at(0, 2);
    size_t sizes[2] = { 0, 0 }, n = 0;
    uint32_t qualities[2] = { 0 /* 85 */, 40 };
    for (int i = 0; i < 2; i++) {
        cv_encode_params p = { .quality = qualities[i] };
        uint8_t *out = round_trip(CV_CODEC_JPEG, src, W * 4, H, &p, &sizes[i], &n);
        CHECK_EQ_INT(n, W * H * 4);
        if (out && i == 0) {
            frame_diff d = frame_compare(src, out, W, H);
            printf("jpeg q85 %dx%d: %zu bytes, mean error %.2f LSB, min PSNR %.1f dB\n", W, H, sizes[0], d.mean_abs,
                   d.min_psnr_db);
            CHECK(d.mean_abs <= 3.0);
            CHECK(d.min_psnr_db > 35.0);
            bool opaque = true;
            for (size_t k = 3; k < n; k += 4)
                opaque &= out[k] == 255;
            CHECK(opaque);
        }
        free(out);
    }
    CHECK(sizes[1] < sizes[0] * 3 / 4); /* quality 40 is much smaller than 85 */
    /* Any size from 1x1; rows with padding. */
    uint8_t one[8] = { 200, 100, 50, 0, 1, 2, 3, 4 };
    size_t es = 0;
    uint8_t *out = round_trip(CV_CODEC_JPEG, one, 4, 1, NULL, &es, &n);
    CHECK(out && n == 4 && abs(out[0] - 200) <= 4 && abs(out[1] - 100) <= 4 && abs(out[2] - 50) <= 4);
    free(out);
    free(src);
}

static void test_lossless(cv_codec codec) {
    uint8_t *src = frame_at(3, 2);
    size_t es = 0, n = 0;
    cv_encode_params p = { .zstd_level = 1 };
    uint8_t *out = round_trip(codec, src, W * 4, H, &p, &es, &n);
    CHECK_EQ_INT(n, W * H * 4);
    CHECK(out && memcmp(out, src, n) == 0);
    printf("%s %dx%d: %zu bytes of %d\n", cv_codec_name(codec), W, H, es, W * H * 4);
    CHECK(codec == CV_CODEC_RAW ? es == n : es < n * 3 / 4);
    free(out);
    free(src);
}

/* Radiance planes, 16 bytes a texel: ZSTD takes any bytes. */
static void test_zstd_float(void) {
    float *src = malloc((size_t)W * H * 16);
    synthetic_radiance(src, W, H, 1);
    cv_encoder *e = NULL;
    cv_decoder *d = NULL;
    cv_encoded f = { 0 };
    CHECK_OK(cv_encoder_create(CV_CODEC_ZSTD, W, H, &e));
    CHECK_OK(cv_decoder_create(CV_CODEC_ZSTD, &d));
    CHECK_OK(cv_encoder_encode(e, (const uint8_t *)src, W * 16, NULL, &f));
    uint8_t *out = NULL;
    size_t n = 0;
    uint32_t ow = 1, oh = 1;
    CHECK_OK(cv_decoder_decode(d, f.data, f.size, &out, &n, &ow, &oh));
    CHECK(n == (size_t)W * H * 16 && out && memcmp(out, src, n) == 0);
    CHECK(ow == 0 && oh == 0);
    /* A second frame of the same stream reuses the contexts. */
    cv_encoded_free(&f);
    free(out);
    out = NULL;
    CHECK_OK(cv_encoder_encode(e, (const uint8_t *)src, W * 16, &(cv_encode_params){ .zstd_level = 9 }, &f));
    CHECK_OK(cv_decoder_decode(d, f.data, f.size, &out, &n, &ow, &oh));
    CHECK(n == (size_t)W * H * 16 && out && memcmp(out, src, n) == 0);
    cv_encoded_free(&f);
    free(out);
    cv_encoder_destroy(e);
    cv_decoder_destroy(d);
    free(src);
}

/* NAL unit types in an Annex B stream, as a bit set (1 << type). */
static uint32_t nal_types(const uint8_t *data, size_t size) {
    uint32_t types = 0;
    for (size_t i = 0; i + 3 < size; i++)
        if (data[i] == 0 && data[i + 1] == 0 && data[i + 2] == 1)
            types |= 1u << (data[i + 3] & 31);
    return types;
}

static void test_h264(void) {
    cv_encoder *e = NULL;
    cv_decoder *d = NULL;
    CHECK_OK(cv_encoder_create(CV_CODEC_H264, W, H, &e));
    CHECK_OK(cv_decoder_create(CV_CODEC_H264, &d));
    if (!e || !d)
        return;
    for (uint32_t t = 0; t < 5; t++) {
        uint8_t *src = frame_at(t, 1);
        cv_encode_params p = { .keyframe = t == 3 };
        cv_encoded f = { 0 };
        CHECK_OK(cv_encoder_encode(e, src, W * 4, &p, &f));
        CHECK_EQ_INT(f.keyframe, t == 0 || t == 3);
        uint32_t types = nal_types(f.data, f.size);
        CHECK(f.size > 4 && f.data[0] == 0 && f.data[1] == 0 && f.data[2] == 0 && f.data[3] == 1);
        if (f.keyframe)
            CHECK(types == ((1u << 7) | (1u << 8) | (1u << 5))); /* SPS, PPS, IDR slice */
        else
            CHECK(types == (1u << 1)); /* one non-IDR slice */
        uint8_t *out = NULL;
        size_t n = 0;
        uint32_t ow = 0, oh = 0;
        CHECK_OK(cv_decoder_decode(d, f.data, f.size, &out, &n, &ow, &oh));
        CHECK(n == (size_t)W * H * 4 && ow == W && oh == H);
        if (out) {
            frame_diff diff = frame_compare(src, out, W, H);
            printf("h264 frame %u%s: %zu bytes, mean error %.2f LSB, min PSNR %.1f dB\n", t,
                   f.keyframe ? " (IDR)" : "", f.size, diff.mean_abs, diff.min_psnr_db);
            CHECK(diff.min_psnr_db > 30.0);
        }
        free(out);
        free(src);
        cv_encoded_free(&f);
    }
    cv_encoder_destroy(e);
    cv_decoder_destroy(d);
}

/* 1280x720 and up: the picture in slices on threads (h264_encoder.c); the same guarantees. */
static void test_h264_sliced(void) {
    const uint32_t w = 1280, h = 720;
    cv_encoder *e = NULL;
    cv_decoder *d = NULL;
    CHECK_OK(cv_encoder_create(CV_CODEC_H264, w, h, &e));
    CHECK_OK(cv_decoder_create(CV_CODEC_H264, &d));
    uint8_t *src = malloc((size_t)w * h * 4);
    for (uint32_t t = 0; e && d && src && t < 3; t++) {
        synthetic_frame(src, w, h, t, 1);
        cv_encoded f = { 0 };
        CHECK_OK(cv_encoder_encode(e, src, w * 4, &(cv_encode_params){ .keyframe = t == 2, .fps = 30 }, &f));
        CHECK_EQ_INT(f.keyframe, t != 1);
        CHECK(f.width == w && f.height == h);
        uint32_t types = nal_types(f.data, f.size);
        CHECK(types == (f.keyframe ? (1u << 7) | (1u << 8) | (1u << 5) : 1u << 1));
        uint8_t *out = NULL;
        size_t n = 0;
        uint32_t ow = 0, oh = 0;
        CHECK_OK(cv_decoder_decode(d, f.data, f.size, &out, &n, &ow, &oh));
        CHECK(out && ow == w && oh == h && frame_compare(src, out, w, h).min_psnr_db > 30.0);
        free(out);
        cv_encoded_free(&f);
    }
    free(src);
    cv_encoder_destroy(e);
    cv_decoder_destroy(d);
}

/* Frames 2..9 of a stream at a low and at a high bitrate (and frame rate), changed mid-stream: more bits per
 * second, more bytes. */
static void test_h264_bitrate(void) {
    cv_encoder *e = NULL;
    CHECK_OK(cv_encoder_create(CV_CODEC_H264, W, H, &e));
    if (!e)
        return;
    size_t bytes[2] = { 0, 0 };
    uint32_t kbps[2] = { 200, 3000 };
    for (int phase = 0; phase < 2; phase++) {
        for (uint32_t t = 0; t < 10; t++) {
            uint8_t *src = frame_at((uint32_t)phase * 10 + t, 1);
            cv_encoded f = { 0 };
            cv_encode_params p = { .bitrate_kbps = kbps[phase], .fps = phase ? 30 : 60 }; /* both change */
            CHECK_OK(cv_encoder_encode(e, src, W * 4, &p, &f));
            if (t >= 2)
                bytes[phase] += f.size;
            cv_encoded_free(&f);
            free(src);
        }
    }
    printf("h264 8 frames at 200 kbit/s: %zu bytes; at 3000 kbit/s: %zu bytes\n", bytes[0], bytes[1]);
    CHECK(bytes[1] > bytes[0] * 3);
    /* The shared limit (1 Gbit/s) is more than openh264 takes: served at openh264's most, not refused. */
    uint8_t *src = frame_at(20, 1);
    cv_encoded f = { 0 };
    CHECK_OK(cv_encoder_encode(e, src, W * 4, &(cv_encode_params){ .bitrate_kbps = CV_ENCODE_MAX_BITRATE_KBPS }, &f));
    CHECK(f.size > 0);
    cv_encoded_free(&f);
    free(src);
    cv_encoder_destroy(e);
}

static void test_refusals(void) {
    cv_encoder *e = (cv_encoder *)1;
    CHECK_RESULT(cv_encoder_create(CV_CODEC_H264, 321, 180, &e), CV_ERROR_INVALID_ARGUMENT);
    CHECK(e == NULL && strstr(cv_last_error(), "even"));
    CHECK_RESULT(cv_encoder_create(CV_CODEC_H264, 320, 181, &e), CV_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(cv_encoder_create(CV_CODEC_JPEG, 0, 10, &e), CV_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(cv_encoder_create(CV_CODEC_PNG, CV_CODEC_MAX_SIDE + 1, 10, &e), CV_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(cv_encoder_create(CV_CODEC_COUNT, 16, 16, &e), CV_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(cv_decoder_create((cv_codec)99, &(cv_decoder *){ NULL }), CV_ERROR_INVALID_ARGUMENT);
    CHECK_EQ_INT(strcmp(cv_codec_name((cv_codec)99), "unknown"), 0);
    CHECK_EQ_INT(strcmp(cv_codec_name(CV_CODEC_H264), "h264"), 0);
    CHECK_OK(cv_encoder_create(CV_CODEC_JPEG, 16, 16, &e));
    uint8_t px[16 * 16 * 4] = { 0 };
    cv_encoded f = { .size = 7 };
    CHECK_RESULT(cv_encoder_encode(e, px, 15 * 4, NULL, &f), CV_ERROR_INVALID_ARGUMENT);
    CHECK(f.size == 0 && f.data == NULL && strstr(cv_last_error(), "stride"));
    CHECK_RESULT(cv_encoder_encode(e, px, 64, &(cv_encode_params){ .quality = 101 }, &f), CV_ERROR_OUT_OF_RANGE);
    CHECK(strstr(cv_last_error(), "quality 101"));
    CHECK_RESULT(cv_encoder_encode(e, px, 64, &(cv_encode_params){ .zstd_level = 1000 }, &f), CV_ERROR_OUT_OF_RANGE);
    CHECK_RESULT(cv_encoder_encode(e, px, 64, &(cv_encode_params){ .bitrate_kbps = CV_ENCODE_MAX_BITRATE_KBPS + 1 },
                                   &f),
                 CV_ERROR_OUT_OF_RANGE);
    CHECK_RESULT(cv_encoder_encode(e, NULL, 64, NULL, &f), CV_ERROR_INVALID_ARGUMENT);
    CHECK_OK(cv_encoder_encode(e, px, 64, NULL, &f)); /* the refusals changed nothing */
    cv_encoded_free(&f);
    cv_encoded_free(NULL);
    cv_encoder_destroy(e);
    cv_encoder_destroy(NULL);
    cv_decoder_destroy(NULL);
}

int main(void) {
    check_live_counter("encoders", cv_live_encoders);
    check_live_counter("decoders", cv_live_decoders);
    test_jpeg();
    test_lossless(CV_CODEC_PNG);
    test_lossless(CV_CODEC_ZSTD);
    test_lossless(CV_CODEC_RAW);
    test_zstd_float();
    test_h264();
    test_h264_sliced();
    test_h264_bitrate();
    test_refusals();
    CHECK_NOTHING_LIVE();
    return check_report("test_media_codec");
}
