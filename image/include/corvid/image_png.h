/* PNG output and input: 8-bit previews of frames, and reference images that
 * tests compare renders against.
 *
 * Pixels are 8-bit sRGB-encoded RGB (3 channels) or RGBA (4), rows top to
 * bottom, tightly packed. Produce them from HDR data with cv_tonemap_to_srgb8
 * (corvid/tonemap.h). Files are written to a temporary name in the same
 * directory and renamed into place when complete, so a failed write leaves no
 * partial file and an existing file untouched.
 *
 *     cv_png_write("frame.png", w, h, 3, rgb8);
 *     cv_png_image ref;
 *     cv_png_read("reference.png", &ref);   // ref.channels is 3 or 4
 *     cv_png_image_free(&ref);
 *
 * Reading converts any PNG to 8-bit sRGB-encoded RGB or, when the file has
 * alpha (or a transparency chunk), RGBA: libpng expands grey and palette
 * images, reduces 16-bit ones (untagged 16-bit data is taken as sRGB-encoded)
 * and converts files tagged with another gamma. An 8-bit RGB(A) file as
 * written here reads back byte for byte.
 *
 * Errors: CV_ERROR_INVALID_ARGUMENT for bad arguments, CV_ERROR_IO when the
 * file cannot be created, written or read, CV_ERROR_MALFORMED for a file that
 * is not a valid or complete PNG. Messages start with the path. */
#ifndef CORVID_IMAGE_PNG_H
#define CORVID_IMAGE_PNG_H

#include <stdint.h>

#include "corvid/result.h"

typedef struct cv_png_image {
    uint32_t width, height;
    uint32_t channels; /* 3 (RGB) or 4 (RGBA) */
    uint8_t *pixels;   /* width * height * channels bytes */
} cv_png_image;

/* width and height 1..CV_MAX_TEXTURE_DIM, channels 3 or 4. */
cv_result cv_png_write(const char *path, uint32_t width, uint32_t height, uint32_t channels, const uint8_t *pixels);

/* On failure *out is left unchanged; on success free it with cv_png_image_free. */
cv_result cv_png_read(const char *path, cv_png_image *out);

/* Frees what cv_png_read allocated and zeroes *image; NULL or zeroed is fine. */
void cv_png_image_free(cv_png_image *image);

#endif
