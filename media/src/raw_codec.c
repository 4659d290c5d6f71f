/* RAW: the bytes as given, copied (`stride * height` of them); decoding copies them back.
 * The baseline the other codecs are measured against. */
#include <stdlib.h>
#include <string.h>

#include "codec_ops.h"
#include "corvid/frame_codec.h"

typedef struct raw_encoder {
    uint32_t height;
} raw_encoder;

static cv_result raw_encoder_create(uint32_t width, uint32_t height, void **state) {
    (void)width;
    raw_encoder *e = malloc(sizeof *e);
    if (!e)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "raw encoder: no memory");
    e->height = height;
    *state = e;
    return CV_OK;
}

static cv_result raw_encode(void *state, const uint8_t *pixels, size_t stride, const cv_encode_params *params,
                            cv_encoded *out) {
    (void)params;
    const raw_encoder *e = state;
    size_t size = stride * e->height;
    uint8_t *data = malloc(size);
    if (!data)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "raw encoder: no memory for %zu bytes", size);
    memcpy(data, pixels, size);
    out->data = data;
    out->size = size;
    out->keyframe = true;
    return CV_OK;
}

static void raw_encoder_destroy(void *state) { free(state); }

static cv_result raw_decoder_create(void **state) {
    *state = NULL; /* nothing to keep */
    return CV_OK;
}

static cv_result raw_decode(void *state, const uint8_t *data, size_t size, uint8_t **out, size_t *out_size,
                            uint32_t *width, uint32_t *height) {
    (void)state;
    (void)width;
    (void)height;
    if (size > CV_CODEC_MAX_DECODED_BYTES)
        return cv_error(CV_ERROR_LIMIT_EXCEEDED, "raw decoder: %zu bytes, over the limit of %llu", size,
                        (unsigned long long)CV_CODEC_MAX_DECODED_BYTES);
    uint8_t *bytes = malloc(size ? size : 1);
    if (!bytes)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "raw decoder: no memory for %zu bytes", size);
    if (size)
        memcpy(bytes, data, size);
    *out = bytes;
    *out_size = size;
    return CV_OK;
}

static void raw_decoder_destroy(void *state) { (void)state; }

const codec_ops cv_raw_codec_ops = {
    .encoder_create = raw_encoder_create,
    .encode = raw_encode,
    .encoder_destroy = raw_encoder_destroy,
    .decoder_create = raw_decoder_create,
    .decode = raw_decode,
    .decoder_destroy = raw_decoder_destroy,
};
