/* Float3 helpers on plain float[3] arrays, shared by the scene code. */
#ifndef CORVID_SCENE_VEC3_H
#define CORVID_SCENE_VEC3_H

#include <math.h>

static inline void v3_set(float o[3], float x, float y, float z) {
    o[0] = x;
    o[1] = y;
    o[2] = z;
}
static inline void v3_copy(float o[3], const float a[3]) {
    o[0] = a[0];
    o[1] = a[1];
    o[2] = a[2];
}
static inline void v3_add(float o[3], const float a[3], const float b[3]) {
    o[0] = a[0] + b[0];
    o[1] = a[1] + b[1];
    o[2] = a[2] + b[2];
}
static inline void v3_sub(float o[3], const float a[3], const float b[3]) {
    o[0] = a[0] - b[0];
    o[1] = a[1] - b[1];
    o[2] = a[2] - b[2];
}
static inline void v3_scale(float o[3], const float a[3], float s) {
    o[0] = a[0] * s;
    o[1] = a[1] * s;
    o[2] = a[2] * s;
}
/* o = a + b * s */
static inline void v3_madd(float o[3], const float a[3], const float b[3], float s) {
    o[0] = a[0] + b[0] * s;
    o[1] = a[1] + b[1] * s;
    o[2] = a[2] + b[2] * s;
}
static inline float v3_dot(const float a[3], const float b[3]) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
static inline void v3_cross(float o[3], const float a[3], const float b[3]) {
    float x = a[1] * b[2] - a[2] * b[1];
    float y = a[2] * b[0] - a[0] * b[2];
    float z = a[0] * b[1] - a[1] * b[0];
    o[0] = x;
    o[1] = y;
    o[2] = z;
}
static inline float v3_length(const float a[3]) { return sqrtf(v3_dot(a, a)); }
/* Unit vector along a; a itself if its length is 0. */
static inline void v3_normalize(float o[3], const float a[3]) {
    float len = v3_length(a);
    if (len > 0.0f)
        v3_scale(o, a, 1.0f / len);
    else
        v3_copy(o, a);
}
static inline float v3_min_f(float a, float b) { return a < b ? a : b; }
static inline float v3_max_f(float a, float b) { return a > b ? a : b; }

#endif
