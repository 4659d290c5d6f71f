/* See reflect_model.h (render_reflect_common.glsl, line for line). */
#include "reflect_model.h"

#include <math.h>

#define MODEL_PI 3.14159265358979f

static float dot3(const float a[3], const float b[3]) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

static void normalize3(float v[3]) {
    float l = sqrtf(dot3(v, v));
    for (int k = 0; k < 3 && l > 0.0f; k++)
        v[k] /= l;
}

static void basis(const float n[3], float t[3], float b[3]) {
    float s = n[2] >= 0.0f ? 1.0f : -1.0f, a = -1.0f / (s + n[2]), c = n[0] * n[1] * a;
    t[0] = 1.0f + s * n[0] * n[0] * a, t[1] = s * c, t[2] = -s * n[0];
    b[0] = c, b[1] = s + n[1] * n[1] * a, b[2] = -n[1];
}

static float ggx_lambda(float c, float alpha) {
    float c2 = c * c;
    return 0.5f * (-1.0f + sqrtf(1.0f + alpha * alpha * (1.0f - c2) / c2));
}

/* A half vector (local frame, z = n) from the visible normals seen from ve. */
static void sample_vndf(const float ve[3], float alpha, const float u[2], float out[3]) {
    float vh[3] = { alpha * ve[0], alpha * ve[1], ve[2] };
    normalize3(vh);
    float len2 = vh[0] * vh[0] + vh[1] * vh[1], t1[3] = { 1.0f, 0.0f, 0.0f }, t2[3];
    if (len2 > 0.0f) {
        float inv = 1.0f / sqrtf(len2);
        t1[0] = -vh[1] * inv, t1[1] = vh[0] * inv, t1[2] = 0.0f;
    }
    t2[0] = vh[1] * t1[2] - vh[2] * t1[1];
    t2[1] = vh[2] * t1[0] - vh[0] * t1[2];
    t2[2] = vh[0] * t1[1] - vh[1] * t1[0];
    float r = sqrtf(u[0]), phi = 2.0f * MODEL_PI * u[1];
    float p1 = r * cosf(phi), p2 = r * sinf(phi), s = 0.5f * (1.0f + vh[2]);
    p2 = (1.0f - s) * sqrtf(fmaxf(0.0f, 1.0f - p1 * p1)) + s * p2;
    float p3 = sqrtf(fmaxf(0.0f, 1.0f - p1 * p1 - p2 * p2));
    float nh[3];
    for (int k = 0; k < 3; k++)
        nh[k] = p1 * t1[k] + p2 * t2[k] + p3 * vh[k];
    out[0] = alpha * nh[0], out[1] = alpha * nh[1], out[2] = fmaxf(0.0f, nh[2]);
    normalize3(out);
}

bool reflect_sample(const float v[3], const float n[3], const float ng[3], float roughness, const float u[2],
                    float l[3], float *weight) {
    l[0] = 0.0f, l[1] = 0.0f, l[2] = 1.0f;
    *weight = 0.0f;
    float n_dot_v = dot3(n, v);
    if (!(n_dot_v > 1e-4f))
        return false;
    float alpha = roughness * roughness;
    if (alpha < REFLECT_ALPHA_MIRROR) {
        for (int k = 0; k < 3; k++)
            l[k] = 2.0f * n_dot_v * n[k] - v[k];
        normalize3(l);
        *weight = 1.0f;
    } else {
        float t[3], b[3], h[3], hw[3];
        basis(n, t, b);
        float ve[3] = { dot3(v, t), dot3(v, b), n_dot_v };
        sample_vndf(ve, alpha, u, h);
        for (int k = 0; k < 3; k++)
            hw[k] = t[k] * h[0] + b[k] * h[1] + n[k] * h[2];
        normalize3(hw);
        float vh = dot3(v, hw);
        for (int k = 0; k < 3; k++)
            l[k] = 2.0f * vh * hw[k] - v[k];
        normalize3(l);
        float n_dot_l = dot3(n, l);
        if (n_dot_l > 0.0f) {
            float lv = ggx_lambda(n_dot_v, alpha);
            *weight = (1.0f + lv) / (1.0f + lv + ggx_lambda(n_dot_l, alpha));
        }
    }
    return dot3(l, n) > 0.0f && dot3(l, ng) > 0.0f && *weight > 0.0f;
}

void reflect_fresnel(const float base[3], float metallic, float n_dot_v, float out[3]) {
    float c = n_dot_v < 0.0f ? 0.0f : n_dot_v > 1.0f ? 1.0f : n_dot_v, k = 1.0f - c, k5 = k * k * k * k * k;
    for (int i = 0; i < 3; i++) {
        float f0 = 0.04f + (base[i] - 0.04f) * metallic;
        out[i] = f0 + (1.0f - f0) * k5;
    }
}
