/* Sine and cosine that give the same bits everywhere: Cody-Waite range
 * reduction and Taylor polynomials in double precision, using only exactly
 * rounded IEEE operations (libm's sinf/cosf differ in the last bit between
 * library versions, which would change procedural scenes between machines). */
#ifndef CORVID_SCENE_DET_MATH_H
#define CORVID_SCENE_DET_MATH_H

#include <math.h>

#define CVS_PI 3.14159265358979323846

static inline void cvs_sincos(double a, double *s, double *c) {
    /* pi/2 split in a part with few significant bits and a remainder, so
     * k * PIO2_HI is exact for the |k| < 2^20 used here. */
    const double PIO2_HI = 1.57079632673412561417;
    const double PIO2_LO = 6.07710050650619224932e-11;
    double k = nearbyint(a * (2.0 / CVS_PI));
    double r = (a - k * PIO2_HI) - k * PIO2_LO;
    double r2 = r * r;
    double sn = r * (1.0 + r2 * (-1.0 / 6 +
                                 r2 * (1.0 / 120 +
                                       r2 * (-1.0 / 5040 +
                                             r2 * (1.0 / 362880 +
                                                   r2 * (-1.0 / 39916800 + r2 * (1.0 / 6227020800.0 +
                                                                                 r2 * (-1.0 / 1307674368000.0))))))));
    double cs = 1.0 +
                r2 * (-1.0 / 2 +
                      r2 * (1.0 / 24 +
                            r2 * (-1.0 / 720 +
                                  r2 * (1.0 / 40320 + r2 * (-1.0 / 3628800 + r2 * (1.0 / 479001600.0 +
                                                                                   r2 * (-1.0 / 87178291200.0)))))));
    switch (((long)k) & 3) {
    case 0:
        *s = sn;
        *c = cs;
        break;
    case 1:
        *s = cs;
        *c = -sn;
        break;
    case 2:
        *s = -sn;
        *c = -cs;
        break;
    default:
        *s = -cs;
        *c = sn;
        break;
    }
}

/* Cube root of x > 0 by Newton steps from a power-of-two guess (frexp and
 * ldexp are exact), for the same reason. */
static inline double cvs_cbrt(double x) {
    int e;
    frexp(x, &e);
    double y = ldexp(1.0, e / 3);
    for (int i = 0; i < 60; i++)
        y = y - (y * y * y - x) / (3.0 * y * y);
    return y;
}

static inline float cvs_sinf(double a) {
    double s, c;
    cvs_sincos(a, &s, &c);
    return (float)s;
}
static inline float cvs_cosf(double a) {
    double s, c;
    cvs_sincos(a, &s, &c);
    return (float)c;
}

#endif
