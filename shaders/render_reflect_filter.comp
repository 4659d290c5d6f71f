// render.reflect_filter: reconstruction of the frame's reflection samples
// (render.reflect_shade) and their running mean over frames (seed 000,
// reflections: spatial reuse of the neighbours' rays, then temporal
// accumulation; a moving camera's history is reprojected by
// render.reflect_reproject).
// Two running means are kept: of the reconstructed estimate (low variance,
// a little bias from reuse) and of the pixel's own samples (unbiased, the
// CPU reference's estimator); the output blends them per pixel by their
// estimated errors (luminance): alpha = v_own / (v_own + v_reuse + b^2), with
// v = variance of each mean (from its second moment, / frames) and b^2 =
// max(0, (reuse - own)^2 - v_own) the reuse's squared bias, so a pixel moves
// from the reconstruction to its own samples as they converge (before 4
// frames: the reconstruction).
// Spatial reuse (radius > 0, not on mirrors): every neighbour q within
// `radius` pixels whose surface is p's (shading normals within ~25 degrees,
// q on p's tangent plane within plane_sigma, roughness within 0.1) lends its
// sample as if p had drawn it: q's direction l_q is drawn again
// (render_reflect_sample.glsl, same pixel and frame), its hit point seen
// from p gives p's direction l (the sky: l_q), and the sample is weighted by
// the ratio w = BRDF_p(l) cos / pdf_q(l_q) (Fresnel is render.composite's).
// The estimate is the ratio estimator E_p * sum(w L) / sum(w) (Stachowiak
// 2015, stochastic screen-space reflections), where E_p, the integral of
// BRDF_p cos over the hemisphere (the mean sample weight G2 / G1, lost
// samples 0), is computed without tracing from 16 stratified VNDF samples.
// Lost samples of neighbours carry no radiance and are skipped. A frame of
// n samples a pixel (reflection_samples, renderer.h) lends all n of every
// neighbour, and a pixel's own estimate is its n samples' mean. Mirrors
// (alpha < ALPHA_MIRROR) and radius 0 keep their own sample, G2 / G1 * L:
// the estimator of the CPU reference.
// Quarter rate (render.reflect_raygen traced one pixel per 2x2 quad; samples
// marked -2 were not traced): the own mean of a pixel counts only the frames
// it was traced in; the reconstruction uses the traced neighbours (a frame
// where none qualifies repeats the current mean); a mirror pixel not yet
// traced shows the mean of its traced same-surface neighbours.
// Moving camera (moving_cap != 0; render.reflect_reproject brought the
// history to this frame's pixels, i7..i9): the same estimates, but the running
// means count each pixel's own history length (reset where the history was
// not kept), capped at moving_cap frames (the history follows the newest
// frames: its reprojection error does not pile up), and the output is the
// reconstruction's mean (reuse) or the own mean (no reuse, mirrors) without
// the error blend (it starts at 16 frames, beyond the cap). A mirror's
// samples are exact, so a traced mirror pixel shows its own sample of the
// frame (history length 1) and, at quarter rate, an untraced one its traced
// same-surface neighbours' samples of the frame. The state (i10)
// keeps the length, the own-sample count, the mean 1/hit distance (the sky
// 0; -1 unknown) for the next frame's virtual point, and the roughness for its
// disocclusion test. A still camera (moving_cap 0) reads none of i7..i10.
// Push: { uint width; uint height; uint frame (sample index, as
//         render.reflect_raygen's); uint accumulated (frames before this one
//         in the running mean); vec4 camera (xyz = eye, w = plane_sigma);
//         int radius; uint material_count; uint quarter; uint moving_cap;
//         uint samples (n); uint pad[3]; }.
// i0: G-buffer positions, i1: G-buffer normals (w = material), i2: G-buffer
// material (RGBA32F, w = roughness, textures included: render_gbuffer.frag),
// i3: this frame's samples (RGBA16F, a = 1/hit distance; n images, one above the other: render.reflect_shade), i4: reconstruction history, i5: own
// history (RGBA32F: rgb = mean, a = mean squared luminance; read and
// written), i6: output (RGBA32F: rgb = reflected radiance; a = the variance
// of its luminance, from the running moments once a still camera has 8
// frames (the blend's: a^2 v_reuse + (1 - a)^2 v_own), else -1 (unknown:
// render.reflect_denoise estimates it); 0 off geometry), i7: reprojected reconstruction history, i8:
// reprojected own history, i9: reprojected state (render.reflect_reproject),
// i10: state (RGBA32F, written), b11: the blue-noise mask (render_blue_noise.glsl).
#version 460
#extension GL_GOOGLE_include_directive : require
#include "render_reflect_common.glsl"
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;

layout(push_constant, std430) uniform Push {
    uint width;
    uint height;
    uint frame;
    uint accumulated;
    vec4 camera;
    int radius;
    uint material_count;
    uint quarter;
    uint moving_cap;
    uint samples;
    uint pad0;
    uint pad1;
    uint pad2;
} pc;

layout(set = 0, binding = 0, rgba32f) uniform readonly image2D gbuffer_position;
layout(set = 0, binding = 1, rgba32f) uniform readonly image2D gbuffer_normal;
layout(set = 0, binding = 2, rgba32f) uniform readonly image2D gbuffer_material;
layout(set = 0, binding = 3, rgba16f) uniform readonly image2D samples;
layout(set = 0, binding = 4, rgba32f) uniform image2D history;
layout(set = 0, binding = 5, rgba32f) uniform image2D own_history;
layout(set = 0, binding = 6, rgba32f) uniform writeonly image2D result;
layout(set = 0, binding = 7, rgba32f) uniform readonly image2D reprojected_history;
layout(set = 0, binding = 8, rgba32f) uniform readonly image2D reprojected_own;
layout(set = 0, binding = 9, rgba32f) uniform readonly image2D reprojected_state;
layout(set = 0, binding = 10, rgba32f) uniform writeonly image2D state_out;
#define BLUE_NOISE_BINDING 11
#include "render_blue_noise.glsl"
#include "render_reflect_sample.glsl"

const uint BLEND_FRAMES = 16u;
const float NOT_TRACED = -2.0;

float luminance(vec3 c) { return dot(c, vec3(0.2126, 0.7152, 0.0722)); }

float roughness_of(ivec2 pixel) { return imageLoad(gbuffer_material, pixel).w; }

// Where sample k of a pixel's n is (render.reflect_shade), and its point.
ivec2 layer(ivec2 pixel, uint k) { return pixel + ivec2(0, int(k * pc.height)); }
vec2 sample_point(ivec2 pixel, uint k) {
    return reflect_sample_point(uvec2(pixel), pc.frame, pc.quarter != 0u, k, pc.samples);
}

// Frames f in [0, n) in which a pixel of quad slot q is traced.
uint traced_before(uint n, uint q) { return pc.quarter != 0u ? (n + 3u - q) / 4u : n; }

// The running mean h (rgb, luminance^2) of n - 1 values, with value c added;
// the variance of the mean in v.
vec4 accumulate(vec4 h, vec3 c, uint n, out float v) {
    float y = luminance(c);
    vec4 m = vec4(c, y * y);
    h = n <= 1u ? m : h + (m - h) / float(n);
    float my = luminance(h.rgb);
    v = max(h.a - my * my, 0.0) / float(max(n, 1u));
    return h;
}

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (p.x >= int(pc.width) || p.y >= int(pc.height))
        return;
    vec4 pos = imageLoad(gbuffer_position, p);
    if (pos.w == 0.0) {
        imageStore(history, p, vec4(0.0));
        imageStore(own_history, p, vec4(0.0));
        imageStore(result, p, vec4(0.0));
        if (pc.moving_cap != 0u)
            imageStore(state_out, p, vec4(0.0, 0.0, -1.0, 0.0));
        return;
    }
    vec4 nm = imageLoad(gbuffer_normal, p);
    vec3 ng = unpack_normal(pos.w), v = normalize(pc.camera.xyz - pos.xyz);
    float roughness = roughness_of(p), alpha = roughness * roughness;

    // The pixel's own samples, if it was traced this frame: their mean
    // estimate (a lost sample counts 0) and mean inverse hit distance.
    bool traced = imageLoad(samples, p).a != NOT_TRACED;
    vec3 own = vec3(0.0);
    float inv_t_sum = 0.0, inv_t_count = 0.0;
    for (uint k = 0u; k < pc.samples; k++) {
        vec4 own_sample = imageLoad(samples, layer(p, k));
        vec3 l;
        float weight;
        if (own_sample.a >= 0.0) {
            inv_t_sum += own_sample.a;
            inv_t_count += 1.0;
        }
        if (own_sample.a >= 0.0 && reflect_sample(v, nm.xyz, ng, roughness, sample_point(p, k), l, weight))
            own += own_sample.rgb * weight;
    }
    own /= float(pc.samples);

    // Spatial reuse (also gathers the traced same-surface neighbours of a mirror at quarter rate).
    bool mirror = alpha < ALPHA_MIRROR, reuse = pc.radius > 0 && !mirror;
    vec3 sum = vec3(0.0), fill = vec3(0.0);
    float total = 0.0, albedo = 0.0, filled = 0.0;
    if (reuse) {
        for (uint k = 0u; k < 16u; k++) {
            vec3 l;
            float weight;
            vec2 u = (vec2(float(k & 3u), float(k >> 2u)) + 0.5) / 4.0;
            if (reflect_sample(v, nm.xyz, ng, roughness, u, l, weight))
                albedo += weight / 16.0;
        }
    }
    int radius = reuse ? pc.radius : (mirror && pc.quarter != 0u ? 1 : 0);
    for (int dy = -radius; dy <= radius; dy++)
        for (int dx = -radius; dx <= radius; dx++) {
            ivec2 q = p + ivec2(dx, dy);
            if (q.x < 0 || q.y < 0 || q.x >= int(pc.width) || q.y >= int(pc.height))
                continue;
            vec4 qpos = imageLoad(gbuffer_position, q);
            if (qpos.w == 0.0)
                continue;
            vec4 qnm = imageLoad(gbuffer_normal, q);
            float qrough = roughness_of(q), qalpha = qrough * qrough;
            if (dot(nm.xyz, qnm.xyz) < 0.9 || abs(dot(nm.xyz, qpos.xyz - pos.xyz)) > pc.camera.w ||
                abs(qrough - roughness) > 0.1 || (qalpha < ALPHA_MIRROR) != mirror)
                continue;
            vec3 qv = normalize(pc.camera.xyz - qpos.xyz), qng = unpack_normal(qpos.w);
            for (uint k = 0u; k < pc.samples; k++) {
                vec4 s = imageLoad(samples, layer(q, k));
                if (s.a < 0.0) /* lost or not traced: no radiance to lend */
                    continue;
                vec3 lq;
                float qweight;
                if (!reflect_sample(qv, qnm.xyz, qng, qrough, sample_point(q, k), lq, qweight))
                    continue;
                if (mirror) {
                    fill += s.rgb * qweight;
                    filled += 1.0;
                    continue;
                }
                if (q == p) {
                    sum += s.rgb * qweight;
                    total += qweight;
                    continue;
                }
                vec3 l = s.a == 0.0 ? lq : normalize(qpos.xyz + lq / s.a - pos.xyz);
                if (dot(l, ng) <= 0.0)
                    continue;
                float pdf = ggx_pdf(qv, qnm.xyz, lq, qalpha);
                if (pdf > 0.0) {
                    float w = ggx_brdf_cos(v, nm.xyz, l, alpha) / pdf;
                    sum += s.rgb * w;
                    total += w;
                }
            }
        }

    if (pc.moving_cap != 0u) {
        vec4 st = imageLoad(reprojected_state, p);
        bool kept = st.w > 0.0;
        uint n = kept ? min(uint(st.x + 0.5) + 1u, pc.moving_cap) : 1u;
        uint own_n = kept ? uint(st.y + 0.5) : 0u;
        float v;
        vec4 ho = imageLoad(reprojected_own, p);
        /* A mirror's samples are exact: a traced one keeps this frame's
         * (history length 1, an older sample can only lag); at quarter rate
         * the frames between show it reprojected. */
        bool exact = mirror && traced;
        if (exact)
            own_n = 0u;
        if (traced) {
            own_n = min(own_n + 1u, pc.moving_cap);
            ho = accumulate(ho, own, own_n, v);
        } else if (own_n == 0u) {
            ho = vec4(0.0);
        }
        imageStore(own_history, p, ho);
        vec3 color = ho.rgb;
        if (mirror && (own_n == 0u || (!traced && filled > 0.0)))
            color = filled > 0.0 ? fill / filled : vec3(0.0);
        vec4 hr = imageLoad(reprojected_history, p);
        if (reuse) {
            vec3 estimate = total > 0.0 ? sum * (albedo / total) : (traced || n == 1u ? vec3(0.0) : hr.rgb);
            hr = accumulate(hr, estimate, n, v);
            color = hr.rgb;
        }
        imageStore(history, p, hr);
        float inv_t = kept ? st.z : -1.0;
        if (inv_t_count > 0.0) {
            float x = inv_t_sum / inv_t_count;
            inv_t = inv_t < 0.0 || exact ? x : inv_t + (x - inv_t) / float(n);
        }
        imageStore(state_out, p, vec4(float(n), float(own_n), inv_t, roughness));
        imageStore(result, p, vec4(color, -1.0));
        return;
    }

    // The own mean counts the frames the pixel was traced in.
    uint slot = uint(p.x & 1) + 2u * uint(p.y & 1), first = pc.frame - pc.accumulated;
    uint own_n = traced_before(pc.frame + 1u, slot) - traced_before(first, slot);
    float v_own = 0.0, v_reuse = 0.0;
    vec4 ho = imageLoad(own_history, p);
    if (traced)
        ho = accumulate(ho, own, own_n, v_own);
    else if (own_n > 0u)
        v_own = max(ho.a - luminance(ho.rgb) * luminance(ho.rgb), 0.0) / float(own_n);
    else
        ho = vec4(0.0);
    imageStore(own_history, p, ho);
    vec3 color = ho.rgb;
    float variance = v_own;
    if (mirror && own_n == 0u)
        color = filled > 0.0 ? fill / filled : vec3(0.0);
    if (reuse) {
        vec4 hr = imageLoad(history, p);
        vec3 estimate = total > 0.0 ? sum * (albedo / total) : (traced || pc.accumulated == 0u ? vec3(0.0) : hr.rgb);
        hr = accumulate(hr, estimate, pc.accumulated + 1u, v_reuse);
        imageStore(history, p, hr);
        v_own = max(v_own, v_reuse);
        float d = luminance(hr.rgb) - luminance(ho.rgb), b2 = max(d * d - v_own, 0.0);
        float a = pc.accumulated + 1u < BLEND_FRAMES || own_n < 4u ? 1.0 : v_own / max(v_own + v_reuse + b2, 1e-20);
        color = mix(ho.rgb, hr.rgb, a);
        variance = a * a * v_reuse + (1.0 - a) * (1.0 - a) * v_own;
    }
    imageStore(result, p, vec4(color, pc.accumulated + 1u >= 8u && own_n >= 8u ? variance : -1.0));
}
