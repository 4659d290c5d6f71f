/* Error measures of a scalar image against a reference over a mask of pixels:
 * what corvid-compare prints per EXR layer, and what renderer tests assert.
 *
 * Both images are width * height floats, rows top to bottom; `mask` (NULL =
 * every pixel) marks the pixels compared (covered by geometry in both, say).
 * Pixels where either value is NaN or infinite are left out and counted.
 *
 *  - rmse: sqrt(mean (b - a)^2); bias: mean (b - a); max_abs: largest |b - a|.
 *  - ssim: the mean of SSIM (Wang et al. 2004) over every 8x8 window (stride
 *    1) whose 64 pixels are all compared, with the standard constants
 *    C1 = (0.01 peak)^2, C2 = (0.03 peak)^2 and the sample (n - 1) variances;
 *    NAN when no window qualifies (ssim_windows = 0). Identical images give
 *    exactly 1.
 *
 *     cv_image_metrics m;
 *     cv_image_metrics_f32(reference, render, covered, w, h, 1.0, &m);
 *     CHECK(m.rmse < 0.02 && m.ssim > 0.97); */
#ifndef CORVID_IMAGE_METRICS_H
#define CORVID_IMAGE_METRICS_H

#include <stdint.h>

#include "corvid/result.h"

#define CV_SSIM_WINDOW 8

typedef struct cv_image_metrics {
    uint64_t pixels;    /* pixels compared (in the mask, both values finite) */
    uint64_t nonfinite; /* pixels in the mask left out for a NaN or infinite value */
    double rmse, bias, max_abs;
    double ssim; /* NAN when ssim_windows == 0 */
    uint64_t ssim_windows;
} cv_image_metrics;

/* `peak` (finite, > 0) is the dynamic range L of the SSIM constants, e.g. 1
 * for visibility and albedo. CV_ERROR_INVALID_ARGUMENT for NULL images, a zero
 * size or a bad peak. With no pixel compared, rmse, bias and max_abs are 0. */
cv_result cv_image_metrics_f32(const float *a, const float *b, const uint8_t *mask, uint32_t width, uint32_t height,
                               double peak, cv_image_metrics *out);

#endif
