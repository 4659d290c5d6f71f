/* The H.264 codec's two halves (h264_encoder.c, h264_decoder.c) and what they share: the
 * route of openh264's own messages into the log, keeping the last warning or error for the
 * message of a failing call. h264_codec.c joins them into cv_h264_codec_ops. */
#ifndef CORVID_MEDIA_H264_CODEC_H
#define CORVID_MEDIA_H264_CODEC_H

#include <stddef.h>
#include <stdint.h>

#include "corvid/encode_types.h"
#include "corvid/result.h"

typedef struct h264_trace {
    const char *origin; /* "h264 encoder", "h264 decoder" */
    char last[160];     /* openh264's last warning or error ("" if none) */
} h264_trace;

/* A WelsTraceCallback; its context is an h264_trace. */
void h264_trace_message(void *context, int level, const char *message);

cv_result h264_encoder_create(uint32_t width, uint32_t height, void **state);
cv_result h264_encode(void *state, const uint8_t *pixels, size_t stride, const cv_encode_params *params,
                      cv_encoded *out);
void h264_encoder_destroy(void *state);

cv_result h264_decoder_create(void **state);
cv_result h264_decode(void *state, const uint8_t *data, size_t size, uint8_t **out, size_t *out_size, uint32_t *width,
                      uint32_t *height);
void h264_decoder_destroy(void *state);

#endif
