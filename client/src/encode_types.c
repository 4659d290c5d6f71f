/* Names of the codecs and the release of an encoded frame (corvid/encode_types.h). */
#include "corvid/encode_types.h"

#include <stdlib.h>
#include <string.h>

const char *cv_codec_name(cv_codec c) {
    static const char *const names[CV_CODEC_COUNT] = { "raw", "jpeg", "h264", "png", "zstd" };
    return (unsigned)c < CV_CODEC_COUNT ? names[c] : "unknown";
}

void cv_encoded_free(cv_encoded *e) {
    if (!e)
        return;
    free(e->data);
    memset(e, 0, sizeof *e);
}
