/* ZSTD: any bytes (RGBA32F radiance planes for a lossless EXR, say) as one zstd frame with
 * its content size written, so the decoder knows what it takes before it allocates. The
 * contexts are kept for the stream: zstd's tables are not rebuilt per frame. */
#include <stdlib.h>
#include <zstd.h>

#include "codec_ops.h"
#include "corvid/frame_codec.h"

typedef struct zstd_encoder {
    ZSTD_CCtx *cctx;
    uint32_t height;
} zstd_encoder;

static cv_result zstd_encoder_create(uint32_t width, uint32_t height, void **state) {
    (void)width;
    zstd_encoder *e = malloc(sizeof *e);
    ZSTD_CCtx *cctx = e ? ZSTD_createCCtx() : NULL;
    if (!cctx) {
        free(e);
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "zstd encoder: no memory for a context");
    }
    *e = (zstd_encoder){ .cctx = cctx, .height = height };
    *state = e;
    return CV_OK;
}

static cv_result zstd_encode(void *state, const uint8_t *pixels, size_t stride, const cv_encode_params *params,
                             cv_encoded *out) {
    zstd_encoder *e = state;
    size_t size = stride * e->height;
    size_t bound = ZSTD_compressBound(size);
    uint8_t *data = malloc(bound);
    if (!data)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "zstd encoder: no memory for %zu bytes", bound);
    ZSTD_CCtx_reset(e->cctx, ZSTD_reset_session_and_parameters);
    size_t n = ZSTD_CCtx_setParameter(e->cctx, ZSTD_c_compressionLevel, params->zstd_level);
    if (!ZSTD_isError(n))
        n = ZSTD_compress2(e->cctx, data, bound, pixels, size);
    if (ZSTD_isError(n)) {
        free(data);
        return cv_error(CV_ERROR_BACKEND, "zstd encoder: %s", ZSTD_getErrorName(n));
    }
    uint8_t *fit = realloc(data, n ? n : 1); /* bound is larger than most frames need */
    out->data = fit ? fit : data;
    out->size = n;
    out->keyframe = true;
    return CV_OK;
}

static void zstd_encoder_destroy(void *state) {
    zstd_encoder *e = state;
    ZSTD_freeCCtx(e->cctx);
    free(e);
}

static cv_result zstd_decoder_create(void **state) {
    ZSTD_DCtx *dctx = ZSTD_createDCtx();
    if (!dctx)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "zstd decoder: no memory for a context");
    *state = dctx;
    return CV_OK;
}

static cv_result zstd_decode(void *state, const uint8_t *data, size_t size, uint8_t **out, size_t *out_size,
                             uint32_t *width, uint32_t *height) {
    (void)width;
    (void)height;
    unsigned long long claimed = ZSTD_getFrameContentSize(data, size);
    if (claimed == ZSTD_CONTENTSIZE_ERROR || claimed == ZSTD_CONTENTSIZE_UNKNOWN)
        return cv_error(CV_ERROR_MALFORMED, "zstd decoder: %zu bytes are not a zstd frame with its content size",
                        size);
    if (claimed > CV_CODEC_MAX_DECODED_BYTES)
        return cv_error(CV_ERROR_LIMIT_EXCEEDED, "zstd decoder: the frame claims %llu bytes, over the limit of %llu",
                        claimed, (unsigned long long)CV_CODEC_MAX_DECODED_BYTES);
    size_t frame = ZSTD_findFrameCompressedSize(data, size);
    if (ZSTD_isError(frame) || frame != size)
        return cv_error(CV_ERROR_MALFORMED, "zstd decoder: %zu bytes are not exactly one zstd frame (%s)", size,
                        ZSTD_isError(frame) ? ZSTD_getErrorName(frame) : "bytes after it");
    uint8_t *bytes = malloc(claimed ? (size_t)claimed : 1);
    if (!bytes)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "zstd decoder: no memory for %llu bytes", claimed);
    size_t n = ZSTD_decompressDCtx(state, bytes, (size_t)claimed, data, size);
    if (ZSTD_isError(n) || n != claimed) {
        free(bytes);
        return cv_error(CV_ERROR_MALFORMED, "zstd decoder: %s",
                        ZSTD_isError(n) ? ZSTD_getErrorName(n) : "fewer bytes than the frame claims");
    }
    *out = bytes;
    *out_size = n;
    return CV_OK;
}

static void zstd_decoder_destroy(void *state) { ZSTD_freeDCtx(state); }

const codec_ops cv_zstd_codec_ops = {
    .encoder_create = zstd_encoder_create,
    .encode = zstd_encode,
    .encoder_destroy = zstd_encoder_destroy,
    .decoder_create = zstd_decoder_create,
    .decode = zstd_decode,
    .decoder_destroy = zstd_decoder_destroy,
};
