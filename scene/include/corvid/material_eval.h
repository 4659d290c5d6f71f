/* A material at a surface point: its factors times its images' texels
 * (glTF 2.0 PBR metallic-roughness), evaluated on the CPU exactly as the
 * renderer's shaders evaluate it on the GPU (shaders/render_material.glsl is
 * this file's rules in GLSL), so the reference path tracer and the GPU
 * frame see the same materials.
 *
 *     cv_material_eval e;
 *     float duv[4] = { du_dx, dv_dx, du_dy, dv_dy };   // the pixel's uv footprint, or NULL: level 0
 *     cv_material_evaluate(scene, cv_scene_material(scene, m), u, v, duv, &e);
 *     if (!e.present) ...                                // cut away by the alpha mask
 *     shade(e.base_color, e.roughness, e.metalness, e.emission, tangent_frame * e.normal);
 *
 * Sampling an image (cv_image_sample), the rules both sides follow:
 *   - wrap: repeat in u and v (u - floor(u)); a non-finite u or v is 0;
 *   - level of detail: Vulkan's isotropic rule, lod = log2(rho) with
 *     rho = max(|(du_dx * w, dv_dx * h)|, |(du_dy * w, dv_dy * h)|) for the
 *     image's level-0 size w x h, clamped to [0, levels - 1]; no footprint
 *     (NULL), or a rho of 0 or NaN, is level 0 (an infinite rho the last);
 *   - between the two levels floor(lod) and floor(lod) + 1: linear in the
 *     fraction (trilinear); within a level: bilinear between the four
 *     texels around (u * side - 0.5, v * side - 0.5), wrapped;
 *   - every texel is decoded before it is filtered: sRGB-encoded channels
 *     (the base color's and the emissive image's rgb) with the sRGB transfer
 *     function, all others as byte / 255.
 * The material at (u, v):
 *   base_color = factor x image rgb;   alpha = alpha factor x image a
 *   roughness  = factor x image g;     metalness = factor x image b
 *   emission   = factor x image rgb
 *   normal     = normalize(x * s, y * s, z) with (x, y, z) = 2 x image rgb - 1
 *                and s = normal_scale; (0, 0, 1) without a normal image;
 *                a normal whose z <= 0 or whose squared length is 0 or not
 *                finite becomes (0, 0, 1)
 *   present    = alpha_mode != CV_ALPHA_MASK || alpha >= alpha_cutoff
 * Without an image a factor stands alone (as if the texel were 1).
 *
 * The tangent frame that carries a tangent-space normal to the world is the
 * triangle's (cv_triangle_tangent_frame): T = dp/du and B = dp/dv from its
 * three positions and uvs (solving the 2x2 system of its edges), then
 * T' = normalize(T - N (N . T)) against the unit shading normal N and
 * B' = cross(N, T') times the sign of dot(cross(N, T'), B) (handedness kept);
 * world normal = normalize(T' x + B' y + N z). A triangle whose uv
 * determinant is 0 (or not finite), or whose T is parallel to N, has no frame
 * (the world normal is N).
 */
#ifndef CORVID_MATERIAL_EVAL_H
#define CORVID_MATERIAL_EVAL_H

#include <stdbool.h>

#include "corvid/scene.h"

typedef struct cv_material_eval {
    float base_color[3];
    float alpha;
    bool present; /* false: the alpha mask cuts this point away */
    float roughness;
    float metalness;
    float emission[3];
    float normal[3]; /* tangent space, unit */
} cv_material_eval;

/* The sRGB transfer function's inverse (IEC 61966-2-1) of byte / 255. */
float cv_srgb_to_linear(uint8_t encoded);

/* Samples `image` at (u, v) with the footprint duv (du/dx, dv/dx, du/dy,
 * dv/dy; NULL = level 0) into out (rgba, linear; rgb sRGB-decoded when
 * `srgb`). */
void cv_image_sample(const cv_image *image, bool srgb, float u, float v, const float duv[4], float out[4]);

/* Evaluates material m of `scene` at (u, v) as above. m's image references
 * must be images of `scene` (cv_scene_add_material checked them). */
void cv_material_evaluate(const cv_scene *scene, const cv_material *m, float u, float v, const float duv[4],
                          cv_material_eval *out);

/* The triangle's tangent frame (above): false when its uvs are degenerate
 * (the frame is then unused). p: 3 positions (xyz each), uv: 3 uvs, n: the
 * unit shading normal; t, b: out. */
bool cv_triangle_tangent_frame(const float p[3][3], const float uv[3][2], const float n[3], float t[3], float b[3]);

#endif
