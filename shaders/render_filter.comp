// render.filter: one iteration of a variance-guided edge-avoiding a-trous
// filter (SVGF, Schied et al. 2017; seed 000's shadow filter) over the
// accumulated visibility: 5x5 B3-spline kernel with holes of `step` pixels,
// run with steps 1, 2, 4, ... Each neighbour q of pixel p is weighted by
//   normal:   max(n_p . n_q, 0)^32
//   position: exp(-|x_p - x_q|^2 / sigma^2), sigma per channel (below)
//   signal:   exp(-|l_p - l_q| / (sigma_l * sqrt(g3x3(var_p)) + 1e-4)), per channel
// where var is the variance of the accumulated mean (the estimate the filter
// reduces), so the filter stops at shadow and AO edges that are real and
// smooths where the estimate is noisy. Shadow (r) and AO (g) are filtered
// separately, each with its own variance.
//
// Estimate: the shadow's is the weighted mean of the taps. The AO's is a
// local linear fit (weighted least squares of l ~ a + b u + c v, (u, v) the
// tap's offset in p's tangent plane; the estimate is a, the fit's value at
// p): where the surface's same-surface neighbours lie on one side of p, at a
// crease or a depth step, the mean of an AO gradient is biased toward the
// side it has, and the fit is not. On the glTF engine, one frame at 640x360,
// that bias was most of the error at its edges (docs/renderer-quality.md, "AO:
// a local linear fit; shadow rays per pixel"). The shadow keeps the mean: its edges are steps, which
// a line fits no better, and the fit's larger variance cost it at 64x36.
//
// Pixel footprint: F = the distance from the eye to p times pixel_angle (the
// world size of one pixel at p facing the camera).
//
// AO sigma: ao_sigma_scale x F^(1/3), where the host puts 1.05 x sqrt(4 /
// ao_samples) x ao_radius^(2/3) in ao_sigma_scale. The kernel trades bias (an
// AO gradient ~ 1 / radius^2 curvature averaged over sigma^2) against noise
// (pixels in the kernel ~ (sigma / F)^2); the sum's least is at sigma^3 ~
// radius^2 F. A fixed world sigma (1% of the diagonal) was too narrow at
// 160x90 and too wide at 640x360; this one matches the best fixed sigma at
// each size measured (docs/renderer-quality.md, "Filter reach from the pixel
// footprint"). The fit allows a wider kernel than the mean's best (1.05 against 0.7 at 4
// rays), and fewer rays want a wider one (the sqrt: measured at 1, 4 and 16).
//
// Penumbra-aware shadow (seed 000's shadow filter: the kernel follows the
// penumbra): the shadow's position sigma follows the width P of the penumbra
// at p, penumbra_scale (2 tan(cone)) times the mean blocker distance of the
// shadow rays that hit something in p's 5x5 same-surface neighbourhood
// (render.resolve's b, a of the last frame): eye.w x P^(2/3) x F^(1/3) (the
// AO's trade-off, with the penumbra's width for the AO radius), between one
// pixel footprint and 8 position_sigma: a sharp contact shadow is filtered
// within its narrow penumbra, a soft one far from its blocker across its
// width. Without a blocker nearby (lit, or facing away from the sun: a
// terminator is as sharp as the geometry) the shadow's sigma is two
// footprints. The sigma is then scaled by shadow_sigma_scale, 1 /
// sqrt(shadow_samples): more rays a frame, less noise to remove.
//
// Variance: the history holds per pixel the means over n frames of the
// per-frame value and of its square, so the per-frame variance is
// m2 - m1^2 and the variance of the mean (var / n). With fewer than 4 frames
// that temporal estimate means nothing (0 after one frame), and the first
// iteration estimates the per-frame variance spatially instead, from the
// moments of the 7x7 neighbours on the same surface (normal and position
// weights), as SVGF does; from 4 frames on, the first iteration takes the
// temporal one. Each iteration writes the variance of its output (for an
// estimate sum g_q l_q: sum g_q^2 var_q; the mean's g_q = w_q / sum w) in b, a
// for the next, which pre-filters it 3x3 (Gaussian) before use.
//
// Converged: a channel whose own variance of the mean (the first iteration's
// estimate, unfiltered) is below `converged_variance` is left as accumulated
// by every iteration: a long accumulation comes back unfiltered.
//
// Push: { uint width; uint height; uint step; uint frames; float position_sigma;
//         float sigma_l; float converged_variance; uint flags;
//         float penumbra_scale (2 tan(cone); 0 = off);
//         float sigma_l_spatial (sigma_l where the variance is the spatial
//         estimate, fewer than 4 frames); float pixel_angle (2 tan(fov / 2) /
//         height); float ao_sigma_scale; vec4 eye (xyz: the camera, w: the
//         shadow sigma's constant); float shadow_sigma_scale; }
// flags: bit 0 = first iteration (source is the history), bit 1 = last (b, a
// get the history's mean squares, as render.accumulate wrote them, so the
// output keeps its documented layout), bit 2 = moving camera: each pixel's
// history length is its own (i5's z, render.reproject's), not `frames`.
// i0: positions, i1: normals (RGBA32F), i2: input (RGBA32F: r = sun, g = AO,
// b, a = their variances of the mean, or in the first iteration the history's
// mean squares), i3: output (RGBA32F, as i2), i4: the history (RGBA32F, read only),
// i5: motion (RGBA32F, z = history length; read only with bit 2),
// i6: the last frame's visibility (R32_UINT, render.resolve's: render_visibility.glsl; b = blocker distance, a = blocked).
#version 460
#extension GL_GOOGLE_include_directive : require
#include "render_visibility.glsl"
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;

layout(push_constant, std430) uniform Push {
    uint width;
    uint height;
    uint step;
    uint frames;
    float position_sigma;
    float sigma_l;
    float converged_variance;
    uint flags;
    float penumbra_scale;
    float sigma_l_spatial;
    float pixel_angle;
    float ao_sigma_scale;
    vec4 eye;
    float shadow_sigma_scale;
} pc;

// The shadow's sigma in pixel footprints: at least SHADOW_MIN_FOOTPRINTS,
// SHADOW_UNBLOCKED_FOOTPRINTS without a blocker nearby (see the header).
const float SHADOW_MIN_FOOTPRINTS = 1.0, SHADOW_UNBLOCKED_FOOTPRINTS = 2.0;

layout(set = 0, binding = 0, rgba32f) uniform readonly image2D gbuffer_position;
layout(set = 0, binding = 1, rgba32f) uniform readonly image2D gbuffer_normal;
layout(set = 0, binding = 2, rgba32f) uniform readonly image2D source;
layout(set = 0, binding = 3, rgba32f) uniform writeonly image2D target;
layout(set = 0, binding = 4, rgba32f) uniform readonly image2D history;
layout(set = 0, binding = 5, rgba32f) uniform readonly image2D motion;
layout(set = 0, binding = 6, r32ui) uniform readonly uimage2D frame_visibility;

const uint FIRST = 1u, LAST = 2u, PER_PIXEL_LENGTH = 4u;

// Frames in q's history.
float history_length(ivec2 q) {
    return (pc.flags & PER_PIXEL_LENGTH) != 0u ? max(imageLoad(motion, q).z, 1.0) : float(pc.frames);
}

bool inside(ivec2 q) {
    return all(greaterThanEqual(q, ivec2(0))) && all(lessThan(q, ivec2(pc.width, pc.height)));
}

// Normal and position similarity of q to p (0 for sky), for position sigmas
// (shadow, AO).
vec2 geometry_weights(vec3 cp, vec3 cn, ivec2 q, vec2 sigma) {
    vec4 qp = imageLoad(gbuffer_position, q);
    if (qp.w == 0.0)
        return vec2(0.0);
    vec3 qn = imageLoad(gbuffer_normal, q).xyz;
    vec3 d = qp.xyz - cp.xyz;
    return pow(max(dot(cn, qn), 0.0), 32.0) * exp(-dot(d, d) / (sigma * sigma));
}

float geometry_weight(vec3 cp, vec3 cn, ivec2 q) {
    return geometry_weights(cp, cn, q, vec2(pc.position_sigma)).y;
}

// The shadow's position sigma at p, whose pixel footprint is `footprint`:
// the penumbra's width (see the header).
float shadow_sigma(ivec2 p, vec3 cp, vec3 cn, float footprint) {
    if (pc.penumbra_scale <= 0.0)
        return pc.position_sigma;
    float sum = 0.0, count = 0.0;
    for (int dy = -2; dy <= 2; dy++)
        for (int dx = -2; dx <= 2; dx++) {
            ivec2 q = p + ivec2(dx, dy);
            if (!inside(q))
                continue;
            vec2 b = visibility_decode(imageLoad(frame_visibility, q).r).ba;
            float w = b.y * geometry_weight(cp, cn, q);
            sum += b.x * w;
            count += w;
        }
    if (count <= 1e-6)
        return SHADOW_UNBLOCKED_FOOTPRINTS * footprint;
    float lo = SHADOW_MIN_FOOTPRINTS * footprint;
    float penumbra = pc.penumbra_scale * sum / count;
    float sigma = pc.eye.w * pow(penumbra, 2.0 / 3.0) * pow(footprint, 1.0 / 3.0);
    return clamp(sigma, lo, max(lo, 8.0 * pc.position_sigma));
}

// An orthonormal basis around n (Frisvad, revised by Duff et al.; as render.raygen's).
void basis(vec3 n, out vec3 t, out vec3 b) {
    float s = n.z >= 0.0 ? 1.0 : -1.0;
    float a = -1.0 / (s + n.z);
    float c = n.x * n.y * a;
    t = vec3(1.0 + s * n.x * n.x * a, s * c, -s * n.x);
    b = vec3(c, s + n.y * n.y * a, -n.y);
}

// The weighted least-squares fit of l ~ a + b u + c v over the taps, whose
// sums of w x x^T (x = (1, u, v)) are xtx, gives a = g . sum(w l x) with g
// the first column of xtx's inverse. A ridge of LINEAR_FIT_RIDGE x sum(w) on
// the slopes keeps the fit defined where the taps lie on a line or on p
// alone (it then tends to the weighted mean, g = (1 / sum(w), 0, 0)).
const float LINEAR_FIT_RIDGE = 0.05;
vec3 linear_fit_weights(mat3 xtx) {
    float ridge = LINEAR_FIT_RIDGE * xtx[0][0];
    xtx[1][1] += ridge;
    xtx[2][2] += ridge;
    return inverse(xtx)[0];
}

// The temporal variance of the mean of shadow and AO at q, from the history.
vec2 temporal_variance(ivec2 q) {
    vec4 h = imageLoad(history, q);
    return max(h.ba - h.rg * h.rg, vec2(0.0)) / history_length(q);
}

// The per-frame variance of shadow and AO around p estimated from the moments
// of its 7x7 neighbours on the same surface, as a variance of the mean.
vec2 spatial_variance(ivec2 p, vec3 cp, vec3 cn) {
    vec4 sum = vec4(0.0);
    float weight = 0.0;
    for (int dy = -3; dy <= 3; dy++)
        for (int dx = -3; dx <= 3; dx++) {
            ivec2 q = p + ivec2(dx, dy);
            if (!inside(q))
                continue;
            float w = geometry_weight(cp, cn, q);
            sum += imageLoad(history, q) * w;
            weight += w;
        }
    vec4 m = sum / max(weight, 1e-20);
    return max(m.ba - m.rg * m.rg, vec2(0.0)) / history_length(p);
}

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (!inside(p))
        return;
    bool first = (pc.flags & FIRST) != 0u, last = (pc.flags & LAST) != 0u;
    vec4 centre = imageLoad(source, p);
    vec4 h = imageLoad(history, p);
    vec4 cp = imageLoad(gbuffer_position, p);
    if (cp.w == 0.0) {
        imageStore(target, p, vec4(centre.rg, last ? h.ba : vec2(0.0)));
        return;
    }
    vec3 cn = imageLoad(gbuffer_normal, p).xyz;

    // This pixel's variance of the mean (own, for the converged test) and the
    // 3x3 pre-filtered one the signal weights scale with.
    vec2 own, guide;
    bool spatial = history_length(p) < 4.0;
    if (first && spatial) {
        own = guide = spatial_variance(p, cp.xyz, cn);
    } else {
        own = first ? temporal_variance(p) : centre.ba;
        vec2 sum = vec2(0.0);
        float weight = 0.0;
        for (int dy = -1; dy <= 1; dy++)
            for (int dx = -1; dx <= 1; dx++) {
                ivec2 q = p + ivec2(dx, dy);
                if (!inside(q) || imageLoad(gbuffer_position, q).w == 0.0)
                    continue;
                float w = (dx == 0 ? 0.5 : 0.25) * (dy == 0 ? 0.5 : 0.25);   // 1/4 1/8 1/16
                sum += (first ? temporal_variance(q) : imageLoad(source, q).ba) * w;
                weight += w;
            }
        guide = sum / weight;
    }
    // In the first iteration the variance of this pixel's output is its own estimate.
    vec2 var_in = first ? own : centre.ba;
    bvec2 converged = lessThan(own, vec2(pc.converged_variance));
    if (all(converged)) {
        imageStore(target, p, vec4(centre.rg, last ? h.ba : var_in));
        return;
    }

    const float kernel[3] = float[3](3.0 / 8.0, 1.0 / 4.0, 1.0 / 16.0);
    vec2 denom = (spatial ? pc.sigma_l_spatial : pc.sigma_l) * sqrt(guide) + 1e-4;
    float footprint = distance(cp.xyz, pc.eye.xyz) * pc.pixel_angle;
    vec2 sigma = vec2(shadow_sigma(p, cp.xyz, cn, footprint) * pc.shadow_sigma_scale, pc.ao_sigma_scale * pow(footprint, 1.0 / 3.0));
    // The local linear fit's sums, per channel: x = (1, u, v), the offset of q
    // in p's tangent plane in units of the taps' reach.
    vec3 tangent, bitangent;
    basis(cn, tangent, bitangent);
    float reach = float(pc.step) * 2.0 * footprint;
    mat3 xx[2] = mat3[2](mat3(0.0), mat3(0.0)), xx_var[2] = mat3[2](mat3(0.0), mat3(0.0));
    vec3 xl[2] = vec3[2](vec3(0.0), vec3(0.0));
    for (int dy = -2; dy <= 2; dy++) {
        for (int dx = -2; dx <= 2; dx++) {
            ivec2 q = p + ivec2(dx, dy) * int(pc.step);
            if (!inside(q))
                continue;
            vec2 wg = kernel[abs(dx)] * kernel[abs(dy)] * geometry_weights(cp.xyz, cn, q, sigma);
            if (wg.x == 0.0 && wg.y == 0.0)
                continue;
            vec4 v = imageLoad(source, q);
            vec2 var_q = dx == 0 && dy == 0 ? var_in : (first ? (spatial ? var_in : temporal_variance(q)) : v.ba);
            vec2 w = wg * exp(-abs(v.rg - centre.rg) / denom);
            vec3 d = imageLoad(gbuffer_position, q).xyz - cp.xyz;
            vec3 x = vec3(1.0, dot(d, tangent) / reach, dot(d, bitangent) / reach);
            mat3 xxt = outerProduct(x, x);
            for (int c = 0; c < 2; c++) {
                xx[c] += w[c] * xxt;
                xx_var[c] += w[c] * w[c] * var_q[c] * xxt;
                xl[c] += w[c] * v[c] * x;
            }
        }
    }
    // weight > 0: the centre itself has weight 1 in every factor.
    vec2 filtered, var_out;
    for (int c = 0; c < 2; c++) {
        vec3 g = c == 1 ? linear_fit_weights(xx[c]) : vec3(1.0 / xx[c][0][0], 0.0, 0.0);
        filtered[c] = clamp(dot(g, xl[c]), 0.0, 1.0);   // a fit may overshoot; visibility is a fraction
        var_out[c] = dot(g, xx_var[c] * g);
    }
    vec2 value = mix(filtered, centre.rg, vec2(converged));
    vec2 variance = mix(var_out, var_in, vec2(converged));
    imageStore(target, p, vec4(value, last ? h.ba : variance));
}
