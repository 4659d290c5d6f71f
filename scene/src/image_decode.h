/* Decoding texture images for import: PNG (libpng) and JPEG (libjpeg-turbo)
 * bytes in memory to RGBA8, rows top to bottom, the bytes as stored (no
 * gamma or colour-profile conversion: glTF says texels are used as they
 * are). Every PNG colour type and depth becomes RGBA8 (gray, gray + alpha,
 * palette with or without tRNS, RGB, 16-bit channels scaled to 8 bits with
 * rounding; no alpha -> 255); JPEG gray and YCbCr/RGB likewise (CMYK is
 * refused). The header is read first: a side of 0 or over CV_IMAGE_MAX_SIDE,
 * or an image whose bytes with their mip chain (cv_image_stored_bytes) pass
 * `budget` (what is left of the scene's CV_SCENE_MAX_IMAGE_BYTES), is refused
 * before any texel memory is allocated; a progressive JPEG's decoder memory
 * is bounded by twice that plus 64 MiB. Corrupt or truncated data
 * is refused (libjpeg's warnings, such as a premature end of data, count as
 * errors), with nothing leaked.
 *
 *     uint8_t *rgba; uint32_t w, h;
 *     cv_result r = image_decode(bytes, size, budget, "scene.gltf: material 0 ('box'): image 'logo.png'", &rgba, &w, &h);
 *     ... free(rgba);
 *
 * Errors (CV_ERROR_MALFORMED, CV_ERROR_LIMIT_EXCEEDED for sides,
 * CV_ERROR_OUT_OF_MEMORY) start with `what`. */
#ifndef CORVID_SCENE_IMAGE_DECODE_H
#define CORVID_SCENE_IMAGE_DECODE_H

#include <stddef.h>
#include <stdint.h>

#include "corvid/result.h"

cv_result image_decode(const uint8_t *data, size_t size, uint64_t budget, const char *what, uint8_t **rgba,
                       uint32_t *width, uint32_t *height);

#endif
