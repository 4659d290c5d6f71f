/* Tone mapping: linear HDR radiance to 8-bit sRGB for PNG previews.
 *
 * Each colour channel is scaled by the exposure (2^exposure: +1 doubles the
 * brightness), compressed into [0, 1] by a curve, then encoded with the sRGB
 * transfer function and rounded to 8 bits. Channels are mapped independently,
 * so very bright saturated colours drift toward white as they do on film.
 *
 * Curves:
 *  - CV_TONEMAP_ACES: Krzysztof Narkowicz's fit of the ACES filmic curve,
 *        f(x) = x (2.51 x + 0.03) / (x (2.43 x + 0.59) + 0.14), clamped to [0, 1].
 *    A toe that deepens shadows a little, a soft shoulder; reaches 1 at
 *    x ~ 7.25. f(1) = 0.804 (sRGB byte 232). The default.
 *  - CV_TONEMAP_REINHARD: f(x) = x / (1 + x). Gentler, never quite reaches 1;
 *    f(1) = 0.5 (sRGB byte 188).
 *
 * Both are increasing, so brighter input never maps to a darker byte.
 * Negative and NaN input maps to 0, +infinity to 1. Alpha, when present, is
 * linear coverage: clamped to [0, 1] and scaled to 8 bits, never tone mapped.
 *
 *     cv_tonemap_to_srgb8(&(cv_tonemap_desc){ .exposure = 0.5f }, hdr_rgba, 4,
 *                         w, h, rgb8, 3);
 *     cv_png_write("frame.png", w, h, 3, rgb8); */
#ifndef CORVID_TONEMAP_H
#define CORVID_TONEMAP_H

#include <stdint.h>

#include "corvid/result.h"

typedef enum cv_tonemap_curve {
    CV_TONEMAP_ACES = 0,
    CV_TONEMAP_REINHARD = 1,
} cv_tonemap_curve;

typedef struct cv_tonemap_desc {
    float exposure;         /* stops, finite; 0 leaves the input as it is */
    cv_tonemap_curve curve; /* 0 = ACES */
} cv_tonemap_desc;

/* The curve alone: linear scene value (already exposed) to display value in [0, 1]. */
float cv_tonemap_curve_eval(cv_tonemap_curve curve, float x);

/* The sRGB transfer function: linear [0, 1] to encoded [0, 1] (input clamped). */
float cv_srgb_encode(float linear);

/* A display value in [0, 1] (clamped) to its sRGB-encoded byte, rounded to nearest. */
uint8_t cv_srgb_encode8(float linear);

/* Tone maps width * height pixels of `in_channels` floats (3: RGB, 4: RGBA)
 * into `out_channels` bytes per pixel (3 or 4; alpha 255 when the input has
 * none). Rows are tightly packed in both. */
cv_result cv_tonemap_to_srgb8(const cv_tonemap_desc *desc, const float *in, uint32_t in_channels, uint32_t width,
                              uint32_t height, uint8_t *out, uint32_t out_channels);

#endif
