/* Image difference statistics. See corvid/image_compare.h. */
#include <math.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdlib.h>

#include "corvid/image_compare.h"

typedef struct diff_sums {
    double max_abs;
    double sum_squares;
    uint64_t pixels_over;
} diff_sums;

static cv_result check_args(const void *a, const void *b, uint32_t width, uint32_t height, uint32_t channels,
                            const cv_image_diff *out) {
    if (a == NULL || b == NULL || out == NULL)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "image compare: %s is NULL",
                        a == NULL   ? "a"
                        : b == NULL ? "b"
                                    : "out");
    if (width == 0 || height == 0 || channels == 0)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "image compare: %ux%u pixels of %u channels is empty", width,
                        height, channels);
    return CV_OK;
}

/* Adds one channel value's difference; returns whether it is over tolerance. */
static bool add_value(diff_sums *sums, double diff, double tolerance) {
    sums->max_abs = fmax(sums->max_abs, diff);
    sums->sum_squares += diff * diff;
    return diff > tolerance;
}

static void finish(const diff_sums *sums, uint64_t pixels, uint32_t channels, double peak, cv_image_diff *out) {
    double mse = sums->sum_squares / ((double)pixels * channels);
    *out = (cv_image_diff){
        .max_abs = sums->max_abs,
        .rmse = sqrt(mse),
        .psnr = mse == 0.0 ? INFINITY : 10.0 * log10(peak * peak / mse),
        .pixels_over = sums->pixels_over,
        .pixel_count = pixels,
    };
}

cv_result cv_image_compare_u8(const uint8_t *a, const uint8_t *b, uint32_t width, uint32_t height, uint32_t channels,
                              uint32_t tolerance, cv_image_diff *out) {
    cv_result r = check_args(a, b, width, height, channels, out);
    if (r != CV_OK)
        return r;
    diff_sums sums = { 0 };
    uint64_t pixels = (uint64_t)width * height;
    for (uint64_t i = 0; i < pixels; i++) {
        bool over = false;
        for (uint32_t c = 0; c < channels; c++) {
            int diff = abs((int)a[i * channels + c] - (int)b[i * channels + c]);
            over |= add_value(&sums, diff, tolerance);
        }
        sums.pixels_over += over;
    }
    finish(&sums, pixels, channels, 255.0, out);
    return CV_OK;
}

static double float_diff(float x, float y) {
    if (x == y || (isnan(x) && isnan(y)))
        return 0.0;
    double d = fabs((double)x - (double)y);
    return isnan(d) ? INFINITY : d;
}

cv_result cv_image_compare_f32(const float *a, const float *b, uint32_t width, uint32_t height, uint32_t channels,
                               double tolerance, double peak, cv_image_diff *out) {
    cv_result r = check_args(a, b, width, height, channels, out);
    if (r != CV_OK)
        return r;
    if (!(tolerance >= 0.0) || !(peak > 0.0) || !isfinite(peak))
        return cv_error(CV_ERROR_INVALID_ARGUMENT,
                        "image compare: tolerance %g must be >= 0 and peak %g finite and > 0", tolerance, peak);
    diff_sums sums = { 0 };
    uint64_t pixels = (uint64_t)width * height;
    for (uint64_t i = 0; i < pixels; i++) {
        bool over = false;
        for (uint32_t c = 0; c < channels; c++)
            over |= add_value(&sums, float_diff(a[i * channels + c], b[i * channels + c]), tolerance);
        sums.pixels_over += over;
    }
    finish(&sums, pixels, channels, peak, out);
    return CV_OK;
}
