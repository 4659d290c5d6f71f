/* The codec names, the one owner of an encoded frame's bytes, and the rules of encoder
 * streams and their parameters (encode_types.h). */
#include "corvid/encode_types.h"

#include <stdlib.h>
#include <string.h>

const char *cv_codec_name(cv_codec c) {
    static const char *names[CV_CODEC_COUNT] = {
        [CV_CODEC_RAW] = "raw", [CV_CODEC_JPEG] = "jpeg", [CV_CODEC_H264] = "h264",
        [CV_CODEC_PNG] = "png", [CV_CODEC_ZSTD] = "zstd",
    };
    return (unsigned)c < CV_CODEC_COUNT ? names[c] : "unknown";
}

void cv_encoded_free(cv_encoded *e) {
    if (!e)
        return;
    free(e->data);
    memset(e, 0, sizeof *e);
}

cv_result cv_encode_check_stream(cv_codec codec, uint32_t width, uint32_t height, const char *what) {
    if ((unsigned)codec >= CV_CODEC_COUNT)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "%s: codec %u is not a codec (0..%u: raw, jpeg, h264, png, zstd)",
                        what, (unsigned)codec, CV_CODEC_COUNT - 1);
    if (width == 0 || height == 0)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "%s: %s frames of %ux%u: width and height must not be 0", what,
                        cv_codec_name(codec), width, height);
    if (codec == CV_CODEC_H264 && (width % 2 || height % 2))
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "%s: h264 frames of %ux%u: width and height must be even", what,
                        width, height);
    return CV_OK;
}

cv_result cv_encode_check_params(const cv_encode_params *p, const char *what) {
    if (!p)
        return CV_OK;
    if (p->quality > 100)
        return cv_error(CV_ERROR_OUT_OF_RANGE, "%s: quality %u is out of range (1..100, 0 = 85)", what, p->quality);
    if (p->bitrate_kbps > CV_ENCODE_MAX_BITRATE_KBPS)
        return cv_error(CV_ERROR_OUT_OF_RANGE, "%s: bitrate_kbps %u is over the limit of %u", what, p->bitrate_kbps,
                        CV_ENCODE_MAX_BITRATE_KBPS);
    if (p->fps > CV_ENCODE_MAX_FPS)
        return cv_error(CV_ERROR_OUT_OF_RANGE, "%s: fps %u is over the limit of %u", what, p->fps, CV_ENCODE_MAX_FPS);
    if (p->zstd_level < CV_ENCODE_MIN_ZSTD_LEVEL || p->zstd_level > CV_ENCODE_MAX_ZSTD_LEVEL)
        return cv_error(CV_ERROR_OUT_OF_RANGE, "%s: zstd_level %d is out of range (%d..%d, 0 = 3)", what,
                        p->zstd_level, CV_ENCODE_MIN_ZSTD_LEVEL, CV_ENCODE_MAX_ZSTD_LEVEL);
    return CV_OK;
}

cv_result cv_encode_check_format(cv_codec codec, cv_format format, const char *what) {
    if (codec == CV_CODEC_RAW || codec == CV_CODEC_ZSTD || format == CV_FORMAT_RGBA8_UNORM)
        return CV_OK;
    return cv_error(CV_ERROR_FORMAT_MISMATCH, "%s: %s encodes RGBA8_UNORM textures, not %s", what,
                    cv_codec_name(codec), cv_format_name(format));
}
