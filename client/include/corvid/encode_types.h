/* The words of encoded frames, as plain types: which codec, its parameters, and one
 * encoded frame. The media library's encoders (corvid/frame_codec.h), the frame reader
 * and the node's encoder streams all speak them, so they live at the bottom, in the client.
 *
 *     cv_encode_params p = { .quality = 90 };           // JPEG quality; 0s are defaults
 *     cv_encoded frame = { 0 };
 *     if (cv_encoder_encode(enc, pixels, width * 4, &p, &frame) == CV_OK)
 *         printf("%s: %zu bytes in %.2f ms\n", cv_codec_name(frame.codec), frame.size, frame.encode_ms);
 *     cv_encoded_free(&frame); */
#ifndef CORVID_ENCODE_TYPES_H
#define CORVID_ENCODE_TYPES_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

typedef enum cv_codec {
    CV_CODEC_RAW = 0,  /* texels as cv_device_read_texture gives them, uncompressed */
    CV_CODEC_JPEG = 1, /* RGBA8 texture -> baseline JPEG (libturbojpeg), 4:2:0 */
    CV_CODEC_H264 = 2, /* RGBA8 -> H.264 constrained baseline, Annex B NAL units (openh264) */
    CV_CODEC_PNG = 3,  /* RGBA8 -> lossless RGB PNG */
    CV_CODEC_ZSTD = 4, /* texels of any format, zstd-compressed (lossless planes: EXR) */
    CV_CODEC_COUNT
} cv_codec;

/* "raw", "jpeg", "h264", "png", "zstd"; "unknown" for a value out of the enum. */
const char *cv_codec_name(cv_codec c);

typedef struct cv_encode_params {
    uint32_t quality;      /* JPEG 1..100; 0 = 85 */
    uint32_t bitrate_kbps; /* H.264 target; 0 = width*height*fps/8000 (about 0.12 bit/pixel) */
    uint32_t fps;          /* H.264 rate control; 0 = 60 */
    bool keyframe;         /* H.264: this frame is an IDR */
    int zstd_level;        /* ZSTD: 0 = 3 */
} cv_encode_params;

typedef struct cv_encoded {
    cv_codec codec;
    uint32_t width, height;
    bool keyframe;
    uint8_t *data;
    size_t size;               /* malloc'd; cv_encoded_free */
    double read_ms, encode_ms; /* where the frame was read: device read, encode */
} cv_encoded;

/* Frees data and zeroes *e; a zeroed one (or NULL) is fine. */
void cv_encoded_free(cv_encoded *e);

#endif
