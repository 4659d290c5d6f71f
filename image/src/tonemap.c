/* Tone curves and sRGB encoding. See corvid/tonemap.h for the curves. */
#include <math.h>
#include <stddef.h>

#include "corvid/tonemap.h"

/* Both curves are evaluated in double: in float, rounding of the
 * denominator makes them step backwards now and then near 1. */
static float aces(double x) {
    double y = x * (2.51 * x + 0.03) / (x * (2.43 * x + 0.59) + 0.14);
    return y < 1.0 ? (float)y : 1.0f;
}

float cv_tonemap_curve_eval(cv_tonemap_curve curve, float x) {
    if (!(x > 0.0f))
        return 0.0f; /* negative, zero and NaN */
    if (curve == CV_TONEMAP_REINHARD)
        return isinf(x) ? 1.0f : (float)((double)x / (1.0 + x));
    /* The fit reaches 1 at about 7.25; stopping at 8 also keeps x * x from
     * overflowing into infinity / infinity. */
    return x >= 8.0f ? 1.0f : aces(x);
}

float cv_srgb_encode(float linear) {
    if (!(linear > 0.0f))
        return 0.0f;
    if (linear >= 1.0f)
        return 1.0f;
    return linear <= 0.0031308f ? 12.92f * linear : 1.055f * powf(linear, 1.0f / 2.4f) - 0.055f;
}

uint8_t cv_srgb_encode8(float linear) { return (uint8_t)lrintf(cv_srgb_encode(linear) * 255.0f); }

static uint8_t alpha8(float a) {
    if (!(a > 0.0f))
        return 0;
    return a >= 1.0f ? 255 : (uint8_t)lrintf(a * 255.0f);
}

cv_result cv_tonemap_to_srgb8(const cv_tonemap_desc *desc, const float *in, uint32_t in_channels, uint32_t width,
                              uint32_t height, uint8_t *out, uint32_t out_channels) {
    if (desc == NULL || in == NULL || out == NULL)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "tonemap: %s is NULL",
                        desc == NULL ? "desc"
                        : in == NULL ? "in"
                                     : "out");
    if (!isfinite(desc->exposure))
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "tonemap: exposure %g is not finite", (double)desc->exposure);
    if (desc->curve != CV_TONEMAP_ACES && desc->curve != CV_TONEMAP_REINHARD)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "tonemap: curve %d is neither ACES nor REINHARD",
                        (int)desc->curve);
    if ((in_channels != 3 && in_channels != 4) || (out_channels != 3 && out_channels != 4))
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "tonemap: %u input and %u output channels (each must be 3 or 4)",
                        in_channels, out_channels);
    if (width == 0 || height == 0)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "tonemap: size %ux%u is empty", width, height);

    float scale = exp2f(desc->exposure);
    size_t pixels = (size_t)width * height;
    for (size_t i = 0; i < pixels; i++) {
        const float *src = in + i * in_channels;
        uint8_t *dst = out + i * out_channels;
        for (int c = 0; c < 3; c++)
            dst[c] = cv_srgb_encode8(cv_tonemap_curve_eval(desc->curve, src[c] * scale));
        if (out_channels == 4)
            dst[3] = in_channels == 4 ? alpha8(src[3]) : 255;
    }
    return CV_OK;
}
