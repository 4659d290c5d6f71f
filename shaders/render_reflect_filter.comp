// render.reflect_filter: reconstruction of the frame's reflection samples
// (render.reflect_shade) and their running mean over frames (seed 000,
// reflections: spatial reuse of the neighbours' rays, then temporal
// accumulation; the camera is still, so no reprojection).
// Spatial reuse (radius > 0, not on mirrors): every neighbour q within
// `radius` pixels whose surface is p's (shading normals within ~25 degrees,
// q on p's tangent plane within plane_sigma, roughness within 0.1) lends its
// sample as if p had drawn it: q's direction l_q is drawn again
// (render_reflect_common.glsl, same pixel and frame), its hit point seen
// from p gives p's direction l (the sky: l_q), and the sample counts with the
// ratio BRDF_p(l) cos / pdf_q(l_q) (Fresnel is render.composite's). The
// estimate is the mean over the neighbours (a lost sample counts as 0), so a
// pixel alone gives its own G2 / G1 * L, the estimator of the CPU reference.
// Mirrors (alpha < ALPHA_MIRROR) keep their own sample.
// Push: { uint width; uint height; uint frame (sample index, as
//         render.reflect_raygen's); uint accumulated (frames before this one
//         in the running mean); vec4 camera (xyz = eye, w = plane_sigma);
//         int radius; uint material_count; uint pad[2]; }.
// i0: G-buffer positions, i1: G-buffer normals (w = material), b2: Material[],
// i3: this frame's samples (RGBA32F), i4: history (RGBA32F: rgb = mean
// reflected radiance, a = 1 on geometry, 0 elsewhere; read and written).
#version 460
#extension GL_GOOGLE_include_directive : require
#include "render_reflect_common.glsl"
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;

struct Material {
    vec4 base_color_roughness;
    vec4 emission_metalness;
};

layout(push_constant, std430) uniform Push {
    uint width;
    uint height;
    uint frame;
    uint accumulated;
    vec4 camera;
    int radius;
    uint material_count;
    uint pad0;
    uint pad1;
} pc;

layout(set = 0, binding = 0, rgba32f) uniform readonly image2D gbuffer_position;
layout(set = 0, binding = 1, rgba32f) uniform readonly image2D gbuffer_normal;
layout(set = 0, binding = 2, std430) readonly buffer Materials { Material materials[]; };
layout(set = 0, binding = 3, rgba32f) uniform readonly image2D samples;
layout(set = 0, binding = 4, rgba32f) uniform image2D history;

float roughness_of(float w) { return materials[min(uint(w), pc.material_count - 1u)].base_color_roughness.w; }

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (p.x >= int(pc.width) || p.y >= int(pc.height))
        return;
    vec4 pos = imageLoad(gbuffer_position, p);
    if (pos.w == 0.0) {
        imageStore(history, p, vec4(0.0));
        return;
    }
    vec4 nm = imageLoad(gbuffer_normal, p);
    vec3 ng = unpack_normal(pos.w), v = normalize(pc.camera.xyz - pos.xyz);
    float roughness = roughness_of(nm.w), alpha = roughness * roughness;
    vec3 estimate = vec3(0.0);
    if (pc.radius <= 0 || alpha < ALPHA_MIRROR) {
        vec4 s = imageLoad(samples, p);
        vec3 l;
        float weight;
        if (s.a >= 0.0 && reflect_sample(v, nm.xyz, ng, roughness, reflect_sample_point(uvec2(p), pc.frame), l, weight))
            estimate = s.rgb * weight;
    } else {
        vec3 sum = vec3(0.0);
        float count = 0.0;
        for (int dy = -pc.radius; dy <= pc.radius; dy++)
            for (int dx = -pc.radius; dx <= pc.radius; dx++) {
                ivec2 q = p + ivec2(dx, dy);
                if (q.x < 0 || q.y < 0 || q.x >= int(pc.width) || q.y >= int(pc.height))
                    continue;
                vec4 qpos = imageLoad(gbuffer_position, q);
                if (qpos.w == 0.0)
                    continue;
                vec4 qnm = imageLoad(gbuffer_normal, q);
                float qrough = roughness_of(qnm.w), qalpha = qrough * qrough;
                if (dot(nm.xyz, qnm.xyz) < 0.9 || abs(dot(nm.xyz, qpos.xyz - pos.xyz)) > pc.camera.w ||
                    abs(qrough - roughness) > 0.1 || qalpha < ALPHA_MIRROR)
                    continue;
                count += 1.0;
                vec4 s = imageLoad(samples, q);
                if (s.a < 0.0)
                    continue;
                vec3 qv = normalize(pc.camera.xyz - qpos.xyz), lq;
                float qweight;
                if (!reflect_sample(qv, qnm.xyz, unpack_normal(qpos.w), qrough,
                                    reflect_sample_point(uvec2(q), pc.frame), lq, qweight))
                    continue;
                if (q == p) {
                    sum += s.rgb * qweight;
                    continue;
                }
                vec3 l = s.a >= 1e29 ? lq : normalize(qpos.xyz + lq * s.a - pos.xyz);
                if (dot(l, ng) <= 0.0)
                    continue;
                float pdf = ggx_pdf(qv, qnm.xyz, lq, qalpha);
                if (pdf > 0.0)
                    sum += s.rgb * (ggx_brdf_cos(v, nm.xyz, l, alpha) / pdf);
            }
        estimate = count > 0.0 ? sum / count : vec3(0.0);
    }
    vec4 m = vec4(estimate, 1.0);
    vec4 h = pc.accumulated == 0u ? m : imageLoad(history, p);
    imageStore(history, p, h + (m - h) / float(pc.accumulated + 1u));
}
