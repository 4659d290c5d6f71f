/* Float to texel encoding (see texel.h). */
#include "corvid/texel.h"

#include <math.h>
#include <string.h>

static uint32_t float_bits(float f) {
    uint32_t u;
    memcpy(&u, &f, 4);
    return u;
}

/* Rounds a non-negative finite float to a small float with `mbits` mantissa
 * bits and a 5-bit exponent (bias 15), no sign: the 11/10-bit packed formats. */
static uint32_t to_small_float(float f, int mbits) {
    if (isnan(f))
        return (0x1Fu << mbits) | 1u;
    if (f <= 0.0f)
        return 0;
    uint32_t max = (0x1Eu << mbits) | ((1u << mbits) - 1); /* largest finite */
    int e;
    float m = frexpf(f, &e); /* f = m * 2^e, m in [0.5, 1) */
    int exp = e - 1 + 15;    /* biased exponent of 1.xxx form */
    if (exp >= 0x1F)
        return isinf(f) ? (0x1Fu << mbits) : max;
    if (exp <= 0) { /* denormal: value = mant * 2^(-14 - mbits) */
        float mant = ldexpf(f, 14 + mbits);
        return (uint32_t)lrintf(mant);
    }
    uint32_t mant = (uint32_t)lrintf((m * 2.0f - 1.0f) * (float)(1u << mbits));
    uint32_t v = ((uint32_t)exp << mbits) + mant; /* mantissa carry bumps the exponent */
    return v > max ? max : v;
}

uint16_t cv_float_to_half(float f) {
    uint32_t u = float_bits(f);
    uint16_t sign = (uint16_t)((u >> 16) & 0x8000u);
    if (isnan(f))
        return sign | 0x7E00u;
    return sign | (uint16_t)to_small_float(fabsf(f), 10);
}

float cv_half_to_float(uint16_t h) {
    int exp = (h >> 10) & 0x1F;
    int mant = h & 0x3FF;
    float v;
    if (exp == 0)
        v = ldexpf((float)mant, -24);
    else if (exp == 31)
        v = mant ? NAN : INFINITY;
    else
        v = ldexpf((float)(mant | 0x400), exp - 25);
    return (h & 0x8000u) ? -v : v;
}

static uint8_t unorm8(float f) {
    if (!(f > 0.0f))
        return 0;
    if (f >= 1.0f)
        return 255;
    return (uint8_t)lrintf(f * 255.0f);
}

void cv_texel_encode(cv_format format, const float c[4], void *out) {
    uint8_t *o = out;
    switch (format) {
    case CV_FORMAT_RGBA8_UNORM:
        for (int i = 0; i < 4; i++)
            o[i] = unorm8(c[i]);
        break;
    case CV_FORMAT_RGBA16F:
    case CV_FORMAT_RG16F: {
        int n = format == CV_FORMAT_RGBA16F ? 4 : 2;
        for (int i = 0; i < n; i++) {
            uint16_t h = cv_float_to_half(c[i]);
            memcpy(o + 2 * i, &h, 2);
        }
        break;
    }
    case CV_FORMAT_RGBA32F: memcpy(o, c, 16); break;
    case CV_FORMAT_R32F:
    case CV_FORMAT_D32F: memcpy(o, c, 4); break;
    case CV_FORMAT_R32_UINT: {
        uint32_t u = c[0] > 0.0f ? (uint32_t)c[0] : 0u;
        memcpy(o, &u, 4);
        break;
    }
    case CV_FORMAT_R11G11B10F: {
        uint32_t packed = to_small_float(c[0], 6) | (to_small_float(c[1], 6) << 11) | (to_small_float(c[2], 5) << 22);
        memcpy(o, &packed, 4);
        break;
    }
    default: break;
    }
}
