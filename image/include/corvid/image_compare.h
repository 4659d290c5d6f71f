/* Image comparison for tests: how far a render is from its reference.
 *
 * Both images have the same size and channel count, tightly packed. The
 * result gives the largest difference of any channel value, the root mean
 * square difference over all channel values, the PSNR that follows from it,
 * and how many pixels have some channel differing by more than a tolerance:
 * a test typically asserts max_abs for exact paths and pixels_over (a few
 * stray pixels allowed) or psnr for approximate ones.
 *
 *     cv_image_diff d;
 *     cv_image_compare_u8(render, reference, w, h, 3, 2, &d);
 *     CHECK(d.pixels_over == 0 && d.psnr > 40.0); */
#ifndef CORVID_IMAGE_COMPARE_H
#define CORVID_IMAGE_COMPARE_H

#include <stdint.h>

#include "corvid/result.h"

typedef struct cv_image_diff {
    double max_abs;       /* largest |a - b| over all channel values */
    double rmse;          /* sqrt(mean of (a - b)^2) over all channel values */
    double psnr;          /* dB: 10 log10(peak^2 / rmse^2); +INFINITY when identical */
    uint64_t pixels_over; /* pixels with some channel |a - b| > tolerance */
    uint64_t pixel_count; /* width * height */
} cv_image_diff;

/* 8-bit images; the PSNR peak is 255. */
cv_result cv_image_compare_u8(const uint8_t *a, const uint8_t *b, uint32_t width, uint32_t height, uint32_t channels,
                              uint32_t tolerance, cv_image_diff *out);

/* Float images; `peak` (finite, > 0) is the signal peak for the PSNR, e.g. 1
 * for display-referred data. Values that compare equal, and NaN against NaN,
 * differ by 0; a NaN or infinity against anything else differs by +INFINITY. */
cv_result cv_image_compare_f32(const float *a, const float *b, uint32_t width, uint32_t height, uint32_t channels,
                               double tolerance, double peak, cv_image_diff *out);

#endif
