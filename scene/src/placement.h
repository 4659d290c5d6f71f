/* Placing procedural shapes: 3x4 transforms from scale, rotation and
 * translation, with rotations built from det_math.h only. */
#ifndef CORVID_SCENE_PLACEMENT_H
#define CORVID_SCENE_PLACEMENT_H

#include <math.h>
#include "det_math.h"
#include "prng.h"

/* out = translate(t) * rotate(unit quaternion q = (x, y, z, w)) * scale(s). */
static inline void cvs_transform_trs(float out[3][4], const double q[4], const float s[3], const float t[3]) {
    double x = q[0], y = q[1], z = q[2], w = q[3];
    double r[3][3] = {
        { 1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w) },
        { 2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w) },
        { 2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y) },
    };
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 3; j++)
            out[i][j] = (float)(r[i][j] * s[j]);
        out[i][3] = t[i];
    }
}

/* Rotation by `angle` radians around +y. */
static inline void cvs_quat_yaw(double q[4], double angle) {
    double s, c;
    cvs_sincos(0.5 * angle, &s, &c);
    q[0] = 0.0;
    q[1] = s;
    q[2] = 0.0;
    q[3] = c;
}

/* A uniformly distributed rotation (Shoemake's method). */
static inline void cvs_quat_random(double q[4], cvs_rng *rng) {
    double u1 = cvs_rng_float(rng), u2 = cvs_rng_float(rng), u3 = cvs_rng_float(rng);
    double a = sqrt(1.0 - u1), b = sqrt(u1);
    double s2, c2, s3, c3;
    cvs_sincos(2.0 * CVS_PI * u2, &s2, &c2);
    cvs_sincos(2.0 * CVS_PI * u3, &s3, &c3);
    q[0] = a * s2;
    q[1] = a * c2;
    q[2] = b * s3;
    q[3] = b * c3;
}

#endif
