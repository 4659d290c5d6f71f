/* The encoders and decoders of frame_codec.h: argument checks, parameter defaults, timing
 * and live counts around each codec's operations (codec_ops.h). */
#include "corvid/frame_codec.h"

#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "codec_ops.h"
#include "corvid/clock.h"

struct cv_encoder {
    cv_codec codec;
    const codec_ops *ops;
    uint32_t width, height;
    void *state;
};

struct cv_decoder {
    cv_codec codec;
    const codec_ops *ops;
    void *state;
};

/* process-wide: encoders and decoders of the whole process, for tests' end-of-test leak check. */
static atomic_uint live_encoders, live_decoders;

uint32_t cv_live_encoders(void) { return atomic_load(&live_encoders); }
uint32_t cv_live_decoders(void) { return atomic_load(&live_decoders); }

static const codec_ops *ops_of(cv_codec codec) {
    switch (codec) {
    case CV_CODEC_RAW: return &cv_raw_codec_ops;
    case CV_CODEC_JPEG: return &cv_jpeg_codec_ops;
    case CV_CODEC_H264: return &cv_h264_codec_ops;
    case CV_CODEC_PNG: return &cv_png_codec_ops;
    case CV_CODEC_ZSTD: return &cv_zstd_codec_ops;
    case CV_CODEC_COUNT: break;
    }
    return NULL;
}

cv_result cv_encoder_create(cv_codec codec, uint32_t width, uint32_t height, cv_encoder **out) {
    if (!out)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "encoder: out is NULL");
    *out = NULL;
    cv_result r = cv_encode_check_stream(codec, width, height, "encoder"); /* the rules of every encoder stream */
    if (r != CV_OK)
        return r;
    const codec_ops *ops = ops_of(codec);
    const char *name = cv_codec_name(codec);
    if (width > CV_CODEC_MAX_SIDE || height > CV_CODEC_MAX_SIDE)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "%s encoder: size %ux%u out of range (1..%u a side)", name, width,
                        height, CV_CODEC_MAX_SIDE);
    cv_encoder *e = calloc(1, sizeof *e);
    if (!e)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "%s encoder: no memory", name);
    *e = (cv_encoder){ .codec = codec, .ops = ops, .width = width, .height = height };
    r = ops->encoder_create(width, height, &e->state);
    if (r != CV_OK) {
        free(e);
        return r;
    }
    atomic_fetch_add(&live_encoders, 1);
    *out = e;
    return CV_OK;
}

/* The params with their defaults (encode_types.h), or an error naming the field out of range. */
static cv_result resolve_params(const cv_encoder *e, const cv_encode_params *in, cv_encode_params *p) {
    char what[32];
    snprintf(what, sizeof what, "%s encoder", cv_codec_name(e->codec));
    cv_result r = cv_encode_check_params(in, what);
    if (r != CV_OK)
        return r;
    *p = in ? *in : (cv_encode_params){ 0 };
    if (p->quality == 0)
        p->quality = 85;
    if (p->fps == 0)
        p->fps = 60;
    if (p->bitrate_kbps == 0) {
        uint64_t kbps = (uint64_t)e->width * e->height * p->fps / 8000u;
        p->bitrate_kbps = kbps < 1                            ? 1
                          : kbps > CV_ENCODE_MAX_BITRATE_KBPS ? CV_ENCODE_MAX_BITRATE_KBPS
                                                              : (uint32_t)kbps;
    }
    if (p->zstd_level == 0)
        p->zstd_level = 3;
    return CV_OK;
}

cv_result cv_encoder_encode(cv_encoder *e, const uint8_t *pixels, size_t stride, const cv_encode_params *params,
                            cv_encoded *out) {
    if (!out)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "encoder: out is NULL");
    memset(out, 0, sizeof *out);
    if (!e || !pixels)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "encoder: %s is NULL", e ? "pixels" : "the encoder");
    const char *name = cv_codec_name(e->codec);
    bool rgba = e->codec == CV_CODEC_JPEG || e->codec == CV_CODEC_H264 || e->codec == CV_CODEC_PNG;
    if (rgba && stride < (size_t)e->width * 4u)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "%s encoder: stride %zu is less than a row of %u RGBA8 pixels",
                        name, stride, e->width);
    if (stride == 0 || stride > CV_CODEC_MAX_DECODED_BYTES / e->height)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "%s encoder: stride %zu out of range (1..%llu bytes in all)", name,
                        stride, (unsigned long long)CV_CODEC_MAX_DECODED_BYTES);
    cv_encode_params p;
    cv_result r = resolve_params(e, params, &p);
    if (r != CV_OK)
        return r;
    double start = cv_now_ms();
    cv_encoded frame = { .codec = e->codec, .width = e->width, .height = e->height };
    r = e->ops->encode(e->state, pixels, stride, &p, &frame);
    if (r != CV_OK)
        return r;
    frame.encode_ms = cv_now_ms() - start;
    *out = frame;
    return CV_OK;
}

void cv_encoder_destroy(cv_encoder *e) {
    if (!e)
        return;
    e->ops->encoder_destroy(e->state);
    free(e);
    atomic_fetch_sub(&live_encoders, 1);
}

cv_result cv_decoder_create(cv_codec codec, cv_decoder **out) {
    if (!out)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "decoder: out is NULL");
    *out = NULL;
    const codec_ops *ops = ops_of(codec);
    if (!ops)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "decoder: unknown codec %d", (int)codec);
    cv_decoder *d = calloc(1, sizeof *d);
    if (!d)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "%s decoder: no memory", cv_codec_name(codec));
    *d = (cv_decoder){ .codec = codec, .ops = ops };
    cv_result r = ops->decoder_create(&d->state);
    if (r != CV_OK) {
        free(d);
        return r;
    }
    atomic_fetch_add(&live_decoders, 1);
    *out = d;
    return CV_OK;
}

cv_result cv_decoder_decode(cv_decoder *d, const uint8_t *data, size_t size, uint8_t **out, size_t *out_size,
                            uint32_t *width, uint32_t *height) {
    if (!d || !out || !out_size || !width || !height || (!data && size))
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "decoder: a NULL argument");
    *out = NULL;
    *out_size = 0;
    *width = *height = 0;
    uint8_t *bytes = NULL;
    size_t n = 0;
    uint32_t w = 0, h = 0;
    cv_result r = d->ops->decode(d->state, data, size, &bytes, &n, &w, &h);
    if (r != CV_OK)
        return r;
    *out = bytes;
    *out_size = n;
    *width = w;
    *height = h;
    return CV_OK;
}

void cv_decoder_destroy(cv_decoder *d) {
    if (!d)
        return;
    d->ops->decoder_destroy(d->state);
    free(d);
    atomic_fetch_sub(&live_decoders, 1);
}
