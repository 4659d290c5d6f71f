// render.reflect_denoise: one iteration of an edge-avoiding a-trous filter
// over the reconstructed reflection (render.reflect_filter's output), on the
// frame that is composited (seed 000, reflections: a cleanup filter after the
// spatial and temporal reconstruction; the 5x5 B3-spline kernel with holes of
// `step` pixels of SVGF, Schied et al. 2017). The running means are not
// touched: the next frame accumulates unfiltered estimates.
// Neighbour q of pixel p is weighted by
//   surface: max(n_p . n_q, 0)^32 exp(-(n_p . (x_q - x_p))^2 / plane_sigma^2),
//            0 unless |roughness_q - roughness_p| <= 0.1 (reflect_filter's test)
//   lobe:    exp(-|x_q - x_p|^2 / (lobe_scale alpha_p t_p)^2): a glossy surface
//            shows the scene blurred over about alpha x the hit distance t_p
//            (1 / the mean of the pixel's samples' 1/t, i3.a; not traced this frame
//            (quarter rate) or lost: a same-surface 3x3 neighbour's; the sky
//            or none: no limit), at least one pixel footprint
//   signal:  exp(-|l_p - l_q| / (sigma_l sqrt(var_p) + 1e-4)), l = luminance.
// Mirrors (alpha < ALPHA_MIRROR) keep their value: their samples are exact.
// Variance: render.reflect_filter gives the variance of its output's
// luminance from its running moments once a still camera has 8 frames
// (temporal, sigma_l_temporal), else -1; then the first iteration estimates it
// from the luminance moments of p's 5x5 same-surface neighbours (spatial, as
// SVGF's first frames, sigma_l_spatial: looser, the spatial estimate holds
// the signal's own variation too). Each iteration passes on the variance of
// its output (sum w^2 var_q / (sum w)^2) in a: v (temporal) or -1 - v
// (spatial). The last iteration writes a = 1 on geometry, 0 elsewhere.
// Push: { uint width; uint height; uint step; uint flags (bit 0 first, bit 1
//         last, bit 2 copy: unfiltered, the input as it is); vec4 camera (xyz
//         = eye, w = plane_sigma); float sigma_l_spatial; float lobe_scale;
//         float pixel_angle (2 tan(fov / 2) / height); float sigma_l_temporal; }
// i0: G-buffer positions, i1: G-buffer normals, i2: G-buffer material (w =
// roughness), i3: this frame's samples (RGBA16F, a = 1/hit distance), i4: input
// (RGBA32F: rgb, a = variance as above), i5: output (RGBA32F).
#version 460
#extension GL_GOOGLE_include_directive : require
#include "render_reflect_common.glsl"
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;

layout(push_constant, std430) uniform Push {
    uint width;
    uint height;
    uint step;
    uint flags;
    vec4 camera;
    float sigma_l_spatial;
    float lobe_scale;
    float pixel_angle;
    float sigma_l_temporal;
} pc;

layout(set = 0, binding = 0, rgba32f) uniform readonly image2D gbuffer_position;
layout(set = 0, binding = 1, rgba32f) uniform readonly image2D gbuffer_normal;
layout(set = 0, binding = 2, rgba32f) uniform readonly image2D gbuffer_material;
layout(set = 0, binding = 3, rgba16f) uniform readonly image2D samples;
layout(set = 0, binding = 4, rgba32f) uniform readonly image2D source;
layout(set = 0, binding = 5, rgba32f) uniform writeonly image2D target;

const uint FIRST = 1u, LAST = 2u, COPY = 4u;

// Between iterations a holds the variance: v for a temporal estimate, -1 - v
// for a spatial one (the first iteration's input: v >= 0, or -1 unknown).
float variance_of(float a) { return a >= 0.0 ? a : max(-1.0 - a, 0.0); }

float luminance(vec3 c) { return dot(c, vec3(0.2126, 0.7152, 0.0722)); }

// A pixel's mean 1/hit distance over its samples of the frame (the sample
// texture holds one image a sample, one above the other); -1 if it has none.
float mean_inv_t(ivec2 q) {
    uint n = uint(imageSize(samples).y) / pc.height;
    float sum = 0.0, count = 0.0;
    for (uint k = 0u; k < n; k++) {
        float a = imageLoad(samples, q + ivec2(0, int(k * pc.height))).a;
        if (a >= 0.0) {
            sum += a;
            count += 1.0;
        }
    }
    return count > 0.0 ? sum / count : -1.0;
}

bool inside(ivec2 q) {
    return all(greaterThanEqual(q, ivec2(0))) && all(lessThan(q, ivec2(pc.width, pc.height)));
}

// How much q lies on p's surface (normal, tangent plane, roughness), 0..1.
float surface_weight(vec3 cp, vec3 cn, float rough, ivec2 q, out vec3 qp) {
    vec4 qpos = imageLoad(gbuffer_position, q);
    qp = qpos.xyz;
    if (qpos.w == 0.0 || abs(imageLoad(gbuffer_material, q).w - rough) > 0.1)
        return 0.0;
    vec3 qn = imageLoad(gbuffer_normal, q).xyz;
    float plane = dot(cn, qp - cp) / pc.camera.w;
    return pow(max(dot(cn, qn), 0.0), 32.0) * exp(-plane * plane);
}

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (!inside(p))
        return;
    bool first = (pc.flags & FIRST) != 0u, last = (pc.flags & LAST) != 0u;
    vec4 centre = imageLoad(source, p);
    vec4 pos = imageLoad(gbuffer_position, p);
    if (pos.w == 0.0) {
        imageStore(target, p, vec4(centre.rgb, 0.0));
        return;
    }
    float rough = imageLoad(gbuffer_material, p).w, alpha = rough * rough;
    if ((pc.flags & COPY) != 0u || alpha < ALPHA_MIRROR) {
        imageStore(target, p, vec4(centre.rgb, last ? 1.0 : centre.a));
        return;
    }
    vec3 cn = imageLoad(gbuffer_normal, p).xyz;
    bool temporal = centre.a >= 0.0;
    float var_p = variance_of(centre.a);
    float l_p = luminance(centre.rgb);
    if (first && !temporal) {
        float m1 = 0.0, m2 = 0.0, wsum = 0.0;
        for (int dy = -2; dy <= 2; dy++)
            for (int dx = -2; dx <= 2; dx++) {
                ivec2 q = p + ivec2(dx, dy);
                vec3 qp;
                float w = inside(q) ? surface_weight(pos.xyz, cn, rough, q, qp) : 0.0;
                if (w <= 0.0)
                    continue;
                float l = luminance(imageLoad(source, q).rgb);
                m1 += w * l;
                m2 += w * l * l;
                wsum += w;
            }
        m1 /= wsum;
        var_p = max(m2 / wsum - m1 * m1, 0.0);
    }
    float footprint = distance(pos.xyz, pc.camera.xyz) * pc.pixel_angle;
    // The hit distance: the pixel's own sample, else (not traced this frame
    // at quarter rate, or lost) a 3x3 neighbour's on its surface (at quarter
    // rate 0.0663 / 0.0352 at 1 / 4 frames against no limit's 0.0666 / 0.0361).
    float inv_t = mean_inv_t(p);
    for (int dy = -1; dy <= 1 && inv_t < 0.0; dy++)
        for (int dx = -1; dx <= 1 && inv_t < 0.0; dx++) {
            ivec2 q = p + ivec2(dx, dy);
            vec3 qp;
            if (q != p && inside(q) && surface_weight(pos.xyz, cn, rough, q, qp) > 0.5)
                inv_t = mean_inv_t(q);
        }
    float lobe = inv_t > 0.0 ? max(pc.lobe_scale * alpha / inv_t, footprint) : 1e30;
    float denom = (temporal ? pc.sigma_l_temporal : pc.sigma_l_spatial) * sqrt(var_p) + 1e-4;

    const float kernel[3] = float[3](3.0 / 8.0, 1.0 / 4.0, 1.0 / 16.0);
    vec3 sum = vec3(0.0);
    float weight = 0.0, var_sum = 0.0;
    for (int dy = -2; dy <= 2; dy++)
        for (int dx = -2; dx <= 2; dx++) {
            ivec2 q = p + ivec2(dx, dy) * int(pc.step);
            if (!inside(q))
                continue;
            vec3 qp;
            float w = kernel[abs(dx)] * kernel[abs(dy)] * surface_weight(pos.xyz, cn, rough, q, qp);
            if (w <= 0.0)
                continue;
            vec4 v = imageLoad(source, q);
            vec3 d = qp - pos.xyz;
            w *= exp(-dot(d, d) / (lobe * lobe)) * exp(-abs(luminance(v.rgb) - l_p) / denom);
            sum += w * v.rgb;
            weight += w;
            var_sum += w * w * (dx == 0 && dy == 0 || (first && !temporal) ? var_p : variance_of(v.a));
        }
    // weight > 0: the centre has weight 3/8^2 in every factor.
    float var_out = var_sum / (weight * weight);
    imageStore(target, p, vec4(sum / weight, last ? 1.0 : (temporal ? var_out : -1.0 - var_out)));
}
