/* cv_image_metrics_f32: RMSE / bias / SSIM over a mask. Identical images give
 * RMSE 0 and SSIM exactly 1; a constant offset gives that bias and RMSE;
 * Gaussian noise of known sigma gives RMSE sigma within sampling error; the
 * mask limits pixels and SSIM windows; NaN pixels are left out and counted;
 * structure lost (a blur) lowers SSIM where an offset hardly does. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "corvid/image_metrics.h"

enum { W = 64, H = 48 };

static float pattern(uint32_t x, uint32_t y) {
    return 0.5f + 0.3f * sinf(x * 0.31f) * cosf(y * 0.17f) + ((x / 9 + y / 7) % 2 ? 0.1f : -0.1f);
}

/* Deterministic standard normal samples (xorshift + Box-Muller). */
static uint32_t rng = 12345u;
static double uniform(void) {
    rng ^= rng << 13;
    rng ^= rng >> 17;
    rng ^= rng << 5;
    return (rng + 0.5) / 4294967296.0;
}
static double gaussian(void) { return sqrt(-2.0 * log(uniform())) * cos(6.283185307179586 * uniform()); }

int main(void) {
    static float a[W * H], b[W * H];
    static uint8_t mask[W * H];
    for (uint32_t i = 0; i < W * H; i++)
        a[i] = b[i] = pattern(i % W, i / W);
    cv_image_metrics m;

    CHECK_OK(cv_image_metrics_f32(a, b, NULL, W, H, 1.0, &m));
    CHECK(m.rmse == 0.0 && m.bias == 0.0 && m.max_abs == 0.0 && m.ssim == 1.0);
    CHECK_EQ_INT(m.pixels, W * H);
    CHECK_EQ_INT(m.ssim_windows, (W - 7) * (H - 7));

    /* B = A + 0.05: bias and RMSE 0.05; SSIM barely moves (luminance term only). */
    for (uint32_t i = 0; i < W * H; i++)
        b[i] = a[i] + 0.05f;
    CHECK_OK(cv_image_metrics_f32(a, b, NULL, W, H, 1.0, &m));
    CHECK(fabs(m.bias - 0.05) < 1e-6 && fabs(m.rmse - 0.05) < 1e-6 && fabs(m.max_abs - 0.05) < 1e-6);
    CHECK(m.ssim > 0.99 && m.ssim < 1.0);

    /* Gaussian noise, sigma 0.1: RMSE 0.1 within 5% (3072 samples: the
     * estimate's spread is ~1.3%), bias within 4 standard errors of 0. */
    for (uint32_t i = 0; i < W * H; i++)
        b[i] = a[i] + (float)(0.1 * gaussian());
    CHECK_OK(cv_image_metrics_f32(a, b, NULL, W, H, 1.0, &m));
    CHECK(fabs(m.rmse - 0.1) < 0.005);
    CHECK(fabs(m.bias) < 4 * 0.1 / sqrt(W * H));
    CHECK(m.ssim < 0.9);

    /* A 3x3 box blur keeps the mean but loses structure: SSIM drops below the offset's. */
    for (uint32_t y = 0; y < H; y++)
        for (uint32_t x = 0; x < W; x++) {
            float s = 0;
            int c = 0;
            for (int dy = -1; dy <= 1; dy++)
                for (int dx = -1; dx <= 1; dx++)
                    if ((int)x + dx >= 0 && (int)x + dx < W && (int)y + dy >= 0 && (int)y + dy < H) {
                        s += a[(y + dy) * W + x + dx];
                        c++;
                    }
            b[y * W + x] = s / c;
        }
    CHECK_OK(cv_image_metrics_f32(a, b, NULL, W, H, 1.0, &m));
    CHECK(fabs(m.bias) < 0.01 && m.ssim < 0.99);

    /* The mask: the left 16 columns out. Pixels and windows follow; a NaN in
     * the masked part is ignored, one in the compared part is left out and counted. */
    memcpy(b, a, sizeof(a));
    for (uint32_t i = 0; i < W * H; i++)
        mask[i] = i % W >= 16;
    b[0] = NAN;
    b[20] = NAN;
    CHECK_OK(cv_image_metrics_f32(a, b, mask, W, H, 1.0, &m));
    CHECK_EQ_INT(m.pixels, (W - 16) * H - 1);
    CHECK_EQ_INT(m.nonfinite, 1);
    CHECK(m.rmse == 0.0 && m.ssim == 1.0);
    CHECK_EQ_INT(m.ssim_windows, (W - 16 - 7) * (H - 7) - 5); /* less the windows over (20, 0): x0 16..20, y0 0 */

    /* Nothing compared: zeros and no SSIM. Bad arguments refused. */
    memset(mask, 0, sizeof(mask));
    CHECK_OK(cv_image_metrics_f32(a, b, mask, W, H, 1.0, &m));
    CHECK(m.pixels == 0 && m.rmse == 0.0 && isnan(m.ssim) && m.ssim_windows == 0);
    CHECK_OK(cv_image_metrics_f32(a, b, NULL, 4, 4, 1.0, &m));  /* smaller than a window */
    CHECK(isnan(m.ssim) && m.pixels == 15 && m.nonfinite == 1); /* b[0] is NaN */
    CHECK_RESULT(cv_image_metrics_f32(NULL, b, NULL, W, H, 1.0, &m), CV_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(cv_image_metrics_f32(a, b, NULL, 0, H, 1.0, &m), CV_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(cv_image_metrics_f32(a, b, NULL, W, H, 0.0, &m), CV_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(cv_image_metrics_f32(a, b, NULL, W, H, NAN, &m), CV_ERROR_INVALID_ARGUMENT);
    return check_report("image metrics");
}
