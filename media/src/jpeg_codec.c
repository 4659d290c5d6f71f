/* JPEG through libturbojpeg: RGBA8 -> baseline 4:2:0 at the frame's quality, and back to
 * RGBA8. The encoder compresses into a work buffer of the largest size a frame can take
 * (allocated once) and copies the frame out, so no frame pays for a large allocation. */
#include <stdlib.h>
#include <string.h>
#include <turbojpeg.h>

#include "codec_ops.h"
#include "corvid/frame_codec.h"

typedef struct jpeg_encoder {
    tjhandle tj;
    uint32_t width, height;
    unsigned char *work;
    unsigned long work_size;
} jpeg_encoder;

static void jpeg_encoder_destroy(void *state) {
    jpeg_encoder *e = state;
    if (e->tj)
        tjDestroy(e->tj);
    tjFree(e->work);
    free(e);
}

static cv_result jpeg_encoder_create(uint32_t width, uint32_t height, void **state) {
    jpeg_encoder *e = calloc(1, sizeof *e);
    if (!e)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "jpeg encoder: no memory");
    e->width = width;
    e->height = height;
    e->tj = tjInitCompress();
    e->work_size = tjBufSize((int)width, (int)height, TJSAMP_420);
    e->work = e->tj && e->work_size != (unsigned long)-1 ? tjAlloc((int)e->work_size) : NULL;
    if (!e->work) {
        jpeg_encoder_destroy(e);
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "jpeg encoder %ux%u: no compressor or work buffer", width, height);
    }
    *state = e;
    return CV_OK;
}

static cv_result jpeg_encode(void *state, const uint8_t *pixels, size_t stride, const cv_encode_params *params,
                             cv_encoded *out) {
    jpeg_encoder *e = state;
    unsigned char *jpeg = e->work;
    unsigned long size = e->work_size;
    if (tjCompress2(e->tj, pixels, (int)e->width, (int)stride, (int)e->height, TJPF_RGBA, &jpeg, &size, TJSAMP_420,
                    (int)params->quality, TJFLAG_NOREALLOC) != 0)
        return cv_error(CV_ERROR_BACKEND, "jpeg encoder %ux%u: %s", e->width, e->height, tjGetErrorStr2(e->tj));
    uint8_t *data = malloc(size);
    if (!data)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "jpeg encoder: no memory for %lu bytes", size);
    memcpy(data, jpeg, size);
    out->data = data;
    out->size = size;
    out->keyframe = true;
    return CV_OK;
}

/* A decompressor that failed mid-header keeps that header's parsing state (libjpeg-turbo 2.1
 * aborts it only on success), and would misread the next image: each failure replaces it. */
typedef struct jpeg_decoder {
    tjhandle tj;
} jpeg_decoder;

static cv_result jpeg_decoder_create(void **state) {
    jpeg_decoder *d = malloc(sizeof *d);
    tjhandle tj = d ? tjInitDecompress() : NULL;
    if (!tj) {
        free(d);
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "jpeg decoder: no decompressor");
    }
    d->tj = tj;
    *state = d;
    return CV_OK;
}

/* The error of a failed call, with a fresh decompressor for the next (the old one kept if none is made). */
static cv_result jpeg_failure(jpeg_decoder *d, cv_result code, const char *what, int w, int h) {
    cv_result r = cv_error(code, "jpeg decoder: %s (%dx%d): %s", what, w, h, tjGetErrorStr2(d->tj));
    tjhandle fresh = tjInitDecompress();
    if (fresh) {
        tjDestroy(d->tj);
        d->tj = fresh;
    }
    return r;
}

static cv_result jpeg_decode(void *state, const uint8_t *data, size_t size, uint8_t **out, size_t *out_size,
                             uint32_t *width, uint32_t *height) {
    jpeg_decoder *d = state;
    if (size == 0 || size > (unsigned long)-1)
        return cv_error(CV_ERROR_MALFORMED, "jpeg decoder: %zu bytes are not a JPEG", size);
    int w = 0, h = 0, subsamp = 0, colorspace = 0;
    if (tjDecompressHeader3(d->tj, data, (unsigned long)size, &w, &h, &subsamp, &colorspace) != 0)
        return jpeg_failure(d, CV_ERROR_MALFORMED, "not a JPEG header", w, h);
    if (w <= 0 || h <= 0 || (uint32_t)w > CV_CODEC_MAX_SIDE || (uint32_t)h > CV_CODEC_MAX_SIDE)
        return cv_error(CV_ERROR_LIMIT_EXCEEDED, "jpeg decoder: a %dx%d image, over the limit of %u a side", w, h,
                        CV_CODEC_MAX_SIDE);
    size_t n = (size_t)w * (size_t)h * 4u;
    uint8_t *rgba = malloc(n);
    if (!rgba)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "jpeg decoder: no memory for %dx%d pixels", w, h);
    /* A warning (data ending early, say) fails the frame too: a viewer shows no half-decoded picture. */
    if (tjDecompress2(d->tj, data, (unsigned long)size, rgba, w, w * 4, h, TJPF_RGBA, TJFLAG_STOPONWARNING) != 0) {
        free(rgba);
        return jpeg_failure(d, CV_ERROR_MALFORMED, "the image does not decode", w, h);
    }
    *out = rgba;
    *out_size = n;
    *width = (uint32_t)w;
    *height = (uint32_t)h;
    return CV_OK;
}

static void jpeg_decoder_destroy(void *state) {
    jpeg_decoder *d = state;
    tjDestroy(d->tj);
    free(d);
}

const codec_ops cv_jpeg_codec_ops = {
    .encoder_create = jpeg_encoder_create,
    .encode = jpeg_encode,
    .encoder_destroy = jpeg_encoder_destroy,
    .decoder_create = jpeg_decoder_create,
    .decode = jpeg_decode,
    .decoder_destroy = jpeg_decoder_destroy,
};
