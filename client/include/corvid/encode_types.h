/* The words of encoded frames, as plain types: which codec, its parameters,
 * and one encoded frame. Encoders (media/'s frame_codec.h), frame readers
 * (frame_reader.h) and the proxy backend's remote encoder streams (a node
 * encodes a texture of its device, so only the encoded bytes cross the link)
 * all speak them, so they live below all of them, in the client.
 *
 *     cv_encode_params p = { .quality = 80 };
 *     cv_encoded frame = { 0 };
 *     if (cv_frame_reader_read(reader, display, rect, &p, &frame) == CV_OK)
 *         send(sock, frame.data, frame.size);   // a JPEG of display
 *     cv_encoded_free(&frame);
 *     printf("%s\n", cv_codec_name(frame.codec)); // "jpeg" */
#ifndef CORVID_ENCODE_TYPES_H
#define CORVID_ENCODE_TYPES_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "corvid/result.h"
#include "corvid/types.h"

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
    uint8_t *data; /* malloc'd; cv_encoded_free */
    size_t size;
    double read_ms, encode_ms; /* where the frame was read: device read, encode */
} cv_encoded;

/* Frees data and zeroes *e; a zeroed one (or NULL) is fine. */
void cv_encoded_free(cv_encoded *e);

/* ---- the rules every encoder stream keeps (local or on a node) -------------------------- */

#define CV_ENCODE_MAX_BITRATE_KBPS 1000000u /* bitrate_kbps: at most 1 Gbit/s */
#define CV_ENCODE_MAX_FPS 240u
#define CV_ENCODE_MIN_ZSTD_LEVEL (-7) /* zstd's fast levels */
#define CV_ENCODE_MAX_ZSTD_LEVEL 19   /* above: zstd's "ultra" levels, hundreds of MiB each */

/* A stream's codec and size: a codec of the enum (else CV_ERROR_INVALID_ARGUMENT), width and
 * height not 0 (INVALID_ARGUMENT), even for H.264 (INVALID_ARGUMENT). Messages start with
 * `what` ("frame reader", "open_encoder") and name the field. */
cv_result cv_encode_check_stream(cv_codec codec, uint32_t width, uint32_t height, const char *what);
/* One frame's parameters (NULL: all defaults): quality 0..100, bitrate_kbps and fps at most
 * the limits above, zstd_level 0 or MIN..MAX; CV_ERROR_OUT_OF_RANGE naming the field. */
cv_result cv_encode_check_params(const cv_encode_params *params, const char *what);
/* Textures a codec reads: RGBA8_UNORM for JPEG, H264 and PNG; any format for RAW and ZSTD
 * (else CV_ERROR_FORMAT_MISMATCH naming both). */
cv_result cv_encode_check_format(cv_codec codec, cv_format format, const char *what);

#endif
