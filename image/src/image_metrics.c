/* RMSE, bias and SSIM over a mask (see image_metrics.h). */
#include "corvid/image_metrics.h"

#include <math.h>
#include <stdlib.h>

static int usable(const float *a, const float *b, const uint8_t *mask, size_t i) {
    return (!mask || mask[i]) && isfinite(a[i]) && isfinite(b[i]);
}

cv_result cv_image_metrics_f32(const float *a, const float *b, const uint8_t *mask, uint32_t width, uint32_t height,
                               double peak, cv_image_metrics *out) {
    if (!a || !b || !out || width == 0 || height == 0 || !isfinite(peak) || peak <= 0.0)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_image_metrics_f32: NULL image, zero size or peak not > 0");
    cv_image_metrics m = { .ssim = NAN };
    size_t n = (size_t)width * height;
    double sum = 0.0, sq = 0.0;
    uint8_t *ok = malloc(n);
    if (!ok)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "cv_image_metrics_f32: %zu pixels", n);
    for (size_t i = 0; i < n; i++) {
        ok[i] = (uint8_t)usable(a, b, mask, i);
        if (!ok[i]) {
            m.nonfinite += !mask || mask[i];
            continue;
        }
        double e = (double)b[i] - (double)a[i];
        sum += e;
        sq += e * e;
        m.max_abs = fmax(m.max_abs, fabs(e));
        m.pixels++;
    }
    if (m.pixels) {
        m.bias = sum / (double)m.pixels;
        m.rmse = sqrt(sq / (double)m.pixels);
    }
    /* SSIM over every fully compared 8x8 window. A window is fully compared
     * when the count of usable pixels in it (a summed-area table) is 64. */
    const uint32_t w = CV_SSIM_WINDOW;
    const double c1 = (0.01 * peak) * (0.01 * peak), c2 = (0.03 * peak) * (0.03 * peak), k = (double)(w * w);
    double total = 0.0;
    if (width >= w && height >= w) {
        uint32_t *sat = calloc((size_t)(width + 1) * (height + 1), sizeof(uint32_t));
        if (!sat) {
            free(ok);
            return cv_error(CV_ERROR_OUT_OF_MEMORY, "cv_image_metrics_f32: %zu pixels", n);
        }
        for (uint32_t y = 0; y < height; y++)
            for (uint32_t x = 0; x < width; x++)
                sat[(size_t)(y + 1) * (width + 1) + x + 1] = ok[(size_t)y * width + x] +
                                                             sat[(size_t)y * (width + 1) + x + 1] +
                                                             sat[(size_t)(y + 1) * (width + 1) + x] -
                                                             sat[(size_t)y * (width + 1) + x];
        for (uint32_t y = 0; y + w <= height; y++)
            for (uint32_t x = 0; x + w <= width; x++) {
                uint32_t count = sat[(size_t)(y + w) * (width + 1) + x + w] - sat[(size_t)y * (width + 1) + x + w] -
                                 sat[(size_t)(y + w) * (width + 1) + x] + sat[(size_t)y * (width + 1) + x];
                if (count != w * w)
                    continue;
                double sa = 0, sb = 0;
                for (uint32_t j = 0; j < w; j++)
                    for (uint32_t i = 0; i < w; i++) {
                        size_t p = (size_t)(y + j) * width + x + i;
                        sa += a[p];
                        sb += b[p];
                    }
                double ma = sa / k, mb = sb / k, vaa = 0, vbb = 0, vab = 0;
                for (uint32_t j = 0; j < w; j++)
                    for (uint32_t i = 0; i < w; i++) {
                        size_t p = (size_t)(y + j) * width + x + i;
                        double da = a[p] - ma, db = b[p] - mb;
                        vaa += da * da;
                        vbb += db * db;
                        vab += da * db;
                    }
                vaa /= k - 1.0;
                vbb /= k - 1.0;
                vab /= k - 1.0;
                total += (2.0 * ma * mb + c1) * (2.0 * vab + c2) / ((ma * ma + mb * mb + c1) * (vaa + vbb + c2));
                m.ssim_windows++;
            }
        free(sat);
    }
    if (m.ssim_windows)
        m.ssim = total / (double)m.ssim_windows;
    free(ok);
    *out = m;
    return CV_OK;
}
