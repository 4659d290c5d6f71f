/* The codec names and the one owner of an encoded frame's bytes (encode_types.h). */
#include "corvid/encode_types.h"

#include <stdlib.h>
#include <string.h>

const char *cv_codec_name(cv_codec c) {
    static const char *names[CV_CODEC_COUNT] = {
        [CV_CODEC_RAW] = "raw", [CV_CODEC_JPEG] = "jpeg", [CV_CODEC_H264] = "h264",
        [CV_CODEC_PNG] = "png", [CV_CODEC_ZSTD] = "zstd",
    };
    return (unsigned)c < CV_CODEC_COUNT ? names[c] : "invalid";
}

void cv_encoded_free(cv_encoded *e) {
    if (!e)
        return;
    free(e->data);
    memset(e, 0, sizeof *e);
}
