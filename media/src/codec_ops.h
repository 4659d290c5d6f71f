/* What each codec of frame_codec.c provides: a const table of operations on its own
 * state (lavapipe's way with backends). frame_codec.c checks the arguments, resolves the
 * parameters' defaults, times the call and counts live objects; a codec only codes.
 *
 * Contract: a failing call returns the error (cv_error, with a message that names the
 * codec) and changes nothing it was given; encode fills out->data/size/keyframe only;
 * decode hands back a malloc'd buffer only on success. */
#ifndef CORVID_MEDIA_CODEC_OPS_H
#define CORVID_MEDIA_CODEC_OPS_H

#include <stddef.h>
#include <stdint.h>

#include "corvid/encode_types.h"
#include "corvid/result.h"

typedef struct codec_ops {
    /* width/height already checked against CV_CODEC_MAX_SIDE (and even for H.264). */
    cv_result (*encoder_create)(uint32_t width, uint32_t height, void **state);
    /* params: defaults resolved, ranges checked. */
    cv_result (*encode)(void *state, const uint8_t *pixels, size_t stride, const cv_encode_params *params,
                        cv_encoded *out);
    void (*encoder_destroy)(void *state);
    cv_result (*decoder_create)(void **state);
    cv_result (*decode)(void *state, const uint8_t *data, size_t size, uint8_t **out, size_t *out_size,
                        uint32_t *width, uint32_t *height);
    void (*decoder_destroy)(void *state);
} codec_ops;

extern const codec_ops cv_raw_codec_ops;
extern const codec_ops cv_jpeg_codec_ops;
extern const codec_ops cv_h264_codec_ops;
extern const codec_ops cv_png_codec_ops;
extern const codec_ops cv_zstd_codec_ops;

#endif
