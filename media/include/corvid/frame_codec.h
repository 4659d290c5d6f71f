/* Frame encoders and decoders: one stream of RGBA8 images (or any bytes) to JPEG, H.264,
 * PNG, ZSTD or RAW, and back. The frame reader and the node's encoder streams encode a
 * presented frame where it was made, so a link carries kilobytes, not megabytes; the
 * decoders are for tests, tools and benchmarks.
 *
 *     cv_encoder *enc;
 *     if (cv_encoder_create(CV_CODEC_H264, 1280, 720, &enc) == CV_OK) {
 *         cv_encode_params p = { .bitrate_kbps = 8000 };   // 0s are defaults (encode_types.h)
 *         cv_encoded frame = { 0 };
 *         if (cv_encoder_encode(enc, rgba, 1280 * 4, &p, &frame) == CV_OK)
 *             send(frame.data, frame.size);                // the first frame is a keyframe
 *         cv_encoded_free(&frame);
 *         cv_encoder_destroy(enc);
 *     }
 *
 * Sizes: JPEG and PNG any size from 1x1 to CV_CODEC_MAX_SIDE; H.264 even widths and
 * heights (odd ones are refused with CV_ERROR_INVALID_ARGUMENT). Streams and parameters keep
 * the rules of encode_types.h (cv_encode_check_stream, cv_encode_check_params) that every
 * encoder stream keeps, local or on a node; H.264 serves a bitrate over 288 Mbit/s
 * (openh264's most) at 288 Mbit/s. Codec libraries: libturbojpeg, openh264 (the Debian
 * build, BSD-2-Clause; docs/media.md), libpng, libzstd. An encoder or a decoder is one
 * stream: one thread at a time; different ones run in parallel. */
#ifndef CORVID_FRAME_CODEC_H
#define CORVID_FRAME_CODEC_H

#include <stddef.h>
#include <stdint.h>

#include "corvid/encode_types.h"
#include "corvid/result.h"

/* The largest image either side takes (a side or a decoded size over it is refused). */
#define CV_CODEC_MAX_SIDE 16384u
/* The most bytes a decoder gives out for one frame (ZSTD and RAW frames claiming more are refused). */
#define CV_CODEC_MAX_DECODED_BYTES (1ull << 30)

typedef struct cv_encoder cv_encoder; /* one stream; H.264 keeps state between frames */

cv_result cv_encoder_create(cv_codec codec, uint32_t width, uint32_t height, cv_encoder **out);
/* pixels: RGBA8 rows (stride bytes apart) for JPEG/H264/PNG (alpha ignored); for ZSTD and
 * RAW any bytes: `stride * height` bytes. params may change from call to call (quality,
 * bitrate: applied from this frame on); NULL = defaults. Fills *out (codec, width, height,
 * size, keyframe, encode_ms; read_ms 0); on failure *out is zeroed. */
cv_result cv_encoder_encode(cv_encoder *e, const uint8_t *pixels, size_t stride, const cv_encode_params *params,
                            cv_encoded *out);
void cv_encoder_destroy(cv_encoder *e); /* NULL is ignored */

typedef struct cv_decoder cv_decoder; /* for tests, tools and benchmarks */

cv_result cv_decoder_create(cv_codec codec, cv_decoder **out);
/* JPEG/H264/PNG -> RGBA8 (alpha 255), ZSTD/RAW -> the bytes; *out malloc'd.
 * H.264: one access unit per call (what one encode gave); 0 bytes out = no picture yet.
 * width/height: the picture's (JPEG/H264/PNG); 0 for ZSTD/RAW (bytes carry no size).
 * Hostile bytes give an error (CV_ERROR_MALFORMED, or LIMIT_EXCEEDED over the limits above). */
cv_result cv_decoder_decode(cv_decoder *d, const uint8_t *data, size_t size, uint8_t **out, size_t *out_size,
                            uint32_t *width, uint32_t *height);
void cv_decoder_destroy(cv_decoder *d); /* NULL is ignored */

/* Encoders and decoders not yet destroyed, process-wide (tests' end-of-test check). */
uint32_t cv_live_encoders(void);
uint32_t cv_live_decoders(void);

#endif
