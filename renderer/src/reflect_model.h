/* The reflection model of render_reflect_common.glsl in C, for the CPU
 * reference (reference.c): GGX with alpha = roughness^2, Smith
 * height-correlated masking-shadowing, half vectors from the distribution of
 * visible normals (Heitz 2018), sample weight G2 / G1 (Fresnel is the
 * composite's); below REFLECT_ALPHA_MIRROR a mirror. The shaders and this file
 * must change together.
 *
 *     float l[3], w;
 *     if (reflect_sample(v, n, ng, roughness, u, l, &w))
 *         sum += w * radiance_along(l);   // else the sample is lost: 0
 */
#ifndef CORVID_RENDER_REFLECT_MODEL_H
#define CORVID_RENDER_REFLECT_MODEL_H

#include <stdbool.h>

#define REFLECT_ALPHA_MIRROR 1e-3f

/* The reflection direction l for the view v (unit, toward the eye), shading
 * normal n, geometric normal ng and the point u in [0, 1)^2, and its weight.
 * False when the sample is lost (v behind n, or l below n or ng); l and
 * *weight are written either way. */
bool reflect_sample(const float v[3], const float n[3], const float ng[3], float roughness, const float u[2],
                    float l[3], float *weight);

/* Schlick's Fresnel at the view for a metal/roughness material:
 * F0 = mix(0.04, base, metallic). */
void reflect_fresnel(const float base[3], float metallic, float n_dot_v, float out[3]);

#endif
