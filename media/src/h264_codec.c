/* The H.264 codec's table of operations, and openh264's messages routed into the log. */
#include "h264_codec.h"

#include <stdio.h>
#include <string.h>
#include <wels/codec_api.h>

#include "codec_ops.h"
#include "corvid/log.h"

void h264_trace_message(void *context, int level, const char *message) {
    h264_trace *t = context;
    if (level <= WELS_LOG_WARNING) {
        snprintf(t->last, sizeof t->last, "%s", message);
        size_t n = strlen(t->last);
        while (n > 0 && (t->last[n - 1] == '\n' || t->last[n - 1] == '\r'))
            t->last[--n] = '\0';
    }
    cv_log(CV_LOG_DEBUG, t->origin, "openh264: %s", message);
}

const codec_ops cv_h264_codec_ops = {
    .encoder_create = h264_encoder_create,
    .encode = h264_encode,
    .encoder_destroy = h264_encoder_destroy,
    .decoder_create = h264_decoder_create,
    .decode = h264_decode,
    .decoder_destroy = h264_decoder_destroy,
};
