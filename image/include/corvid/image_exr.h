/* OpenEXR output and input: the renderer's HDR frames and their AOVs.
 *
 * A frame is written as one scanline EXR whose channels are grouped into
 * layers by name: the beauty as plain "R", "G", "B", "A", and each AOV
 * under its own prefix ("albedo.R", "normal.X", "depth.Z", "ao.Y"), the
 * naming that compositing tools read as layers. Each layer is stored as half
 * (smaller; 11 significant bits, enough for colour) or float (exact; for
 * depth, normals and anything compared bit for bit). Pixel data comes in as
 * float, either interleaved (channel_count floats per pixel) or as one plane
 * per channel, rows top to bottom. Files are written to a temporary name and
 * renamed into place when complete, so a failed write leaves no partial file
 * and an existing file untouched.
 *
 *     cv_exr_layer layers[] = {
 *         { .channel_count = 4, .channels = { "R", "G", "B", "A" },
 *           .type = CV_EXR_HALF, .interleaved = beauty_rgba },
 *         { .name = "depth", .channel_count = 1, .channels = { "Z" },
 *           .type = CV_EXR_FLOAT, .planes = { depth } },
 *     };
 *     cv_exr_write("frame.exr", &(cv_exr_desc){ .width = w, .height = h,
 *                  .compression = CV_EXR_PIZ, .layer_count = 2, .layers = layers });
 *
 * Reading gives every channel of a single-part scanline file as a float
 * plane, matched by full name (files list channels alphabetically, so never
 * rely on their order):
 *
 *     cv_exr_image img;
 *     cv_exr_read("frame.exr", &img);
 *     const float *z = cv_exr_image_find(&img, "depth.Z");
 *     cv_exr_image_free(&img);
 *
 * Errors: CV_ERROR_INVALID_ARGUMENT for a bad description (message names the
 * layer and field), CV_ERROR_IO when the file cannot be created, written or
 * read, CV_ERROR_MALFORMED for a file that is not a valid or complete EXR,
 * CV_ERROR_UNSUPPORTED for valid EXRs this reader does not take (tiled, deep,
 * multi-part, subsampled or UINT channels). Messages start with the path. */
#ifndef CORVID_IMAGE_EXR_H
#define CORVID_IMAGE_EXR_H

#include <stdint.h>

#include "corvid/result.h"

#define CV_EXR_MAX_LAYER_CHANNELS 4
#define CV_EXR_MAX_CHANNELS 64
/* Longest full channel name ("layer.channel") written; EXR's short-name limit. */
#define CV_EXR_MAX_NAME 31

/* How a channel is stored in the file (values as in the EXR format). */
typedef enum cv_exr_type {
    CV_EXR_HALF = 1,
    CV_EXR_FLOAT = 2,
} cv_exr_type;

typedef enum cv_exr_compression {
    CV_EXR_ZIP = 0, /* zlib over 16 scanlines: the default, good on smooth data */
    CV_EXR_PIZ = 1, /* wavelet, 32 scanlines: usually smaller on noisy renders */
    CV_EXR_NONE = 2,
    CV_EXR_OTHER_COMPRESSION = 3, /* read only: one this writer does not produce (RLE, DWAA, ...) */
} cv_exr_compression;

typedef struct cv_exr_layer {
    const char *name;       /* prefix of its channels; NULL or "" for unprefixed (the beauty) */
    uint32_t channel_count; /* 1..CV_EXR_MAX_LAYER_CHANNELS */
    const char *channels[CV_EXR_MAX_LAYER_CHANNELS]; /* e.g. "R", "G", "B" or "X", "Y", "Z" */
    cv_exr_type type;
    /* Either interleaved: width * height * channel_count floats ... */
    const float *interleaved;
    /* ... or, when interleaved is NULL, one plane of width * height floats per channel. */
    const float *planes[CV_EXR_MAX_LAYER_CHANNELS];
} cv_exr_layer;

typedef struct cv_exr_desc {
    uint32_t width, height; /* 1..CV_MAX_TEXTURE_DIM each */
    cv_exr_compression compression;
    uint32_t layer_count; /* >= 1; at most CV_EXR_MAX_CHANNELS channels in all */
    const cv_exr_layer *layers;
} cv_exr_desc;

/* Writes all layers to `path`. Full channel names must be unique. */
cv_result cv_exr_write(const char *path, const cv_exr_desc *desc);

typedef struct cv_exr_channel {
    char *name;       /* full name, e.g. "albedo.R" */
    cv_exr_type type; /* how the file stored it */
    float *pixels;    /* width * height floats, rows top to bottom */
} cv_exr_channel;

typedef struct cv_exr_image {
    uint32_t width, height;
    cv_exr_compression compression; /* as stored */
    uint32_t channel_count;
    cv_exr_channel *channels; /* in the file's (alphabetical) order */
} cv_exr_image;

/* Reads every channel of `path` into float planes. On failure *out is left
 * unchanged; on success free it with cv_exr_image_free. */
cv_result cv_exr_read(const char *path, cv_exr_image *out);

/* The plane of the channel with this full name, or NULL if there is none. */
const float *cv_exr_image_find(const cv_exr_image *image, const char *name);

/* Frees what cv_exr_read allocated and zeroes *image; NULL or zeroed is fine. */
void cv_exr_image_free(cv_exr_image *image);

#endif
