// render.alpha_continue: one round of the alpha-mask rule for secondary rays
// (renderer.h): trace_rays knows nothing of materials, so after a trace this
// pass looks at each ray's hit and, where the hit triangle's material is
// alpha-masked (alpha_mode 1) and its alpha at the hit's uv (alpha factor x
// base color image a, level 0, as render_material.glsl's material_evaluate
// with no footprint) is below the cutoff, keeps the ray for another trace:
// the same ray with tmin = t + bias (bias = 2e-5 x the scene diagonal, the
// renderer's ray-origin offset), so the next closest hit lies past the cut
// point. Rays are re-traced closest-hit, in lockstep rounds:
//   round 0 reads the first trace's hits in place; every later round reads
//   the re-trace's hits (b2), copies a live ray's into b1 and decides again.
//   A ray whose hit stands (a miss, an opaque or masked-but-kept point) is
//   retired: tmin = +infinity, above the renderer's finite tmax, so the next
//   re-traces reject it at the root on the compute path and skip it on the
//   pipeline path (trace_rt.rgen: tmin > tmax is a miss); only tmin changes:
//   every later pass reads origin, dir and tmax alone.
//   Any-hit rays (any_hit = 1: shadow and AO) stop at any hit, perhaps a cut
//   one with an opaque one nearer: such a ray is not moved in round 0 but
//   re-traced closest-hit from its own tmin, and walks front to back from
//   round 1 on.
//   A ray passes at most `layers` cut points (CV_RENDER_ALPHA_LAYERS); the
//   next cut point it meets counts as opaque.
// renderer/src/reference.c applies the same rule on the CPU.
// One invocation per ray record: index = (group.y * groups.x + group.x) * 64 + local.x.
// Push: { uint count; uint round; uint any_hit; float bias; uint material_count;
//         uint layers; uint pad[2]; }.
// b0: cv_ray[] (tmin written), b1: cv_hit[] (the hits that stand, written),
// b2: cv_hit[] of the last re-trace, b3: Vertex[], b4: uint instance_first[],
// b5: vec2 uvs[] (per vertex, as b3), b6: Material[], b7: the image table, b8: the image pool.
#version 460
#extension GL_GOOGLE_include_directive : require
#include "render_reflect_hit.glsl"
#define MATERIAL_BINDING 6
#define IMAGE_TABLE_BINDING 7
#define IMAGE_POOL_BINDING 8
#include "render_material.glsl"
layout(local_size_x = 64, local_size_y = 1, local_size_z = 1) in;

layout(push_constant, std430) uniform Push {
    uint count;
    uint round;
    uint any_hit;
    float bias;
    uint material_count;
    uint layers;
    uint pad0;
    uint pad1;
} pc;

layout(set = 0, binding = 0, std430) buffer Rays { Ray rays[]; };
layout(set = 0, binding = 1, std430) buffer Hits { Hit hits[]; };
layout(set = 0, binding = 2, std430) readonly buffer NextHits { Hit next_hits[]; };
layout(set = 0, binding = 3, std430) readonly buffer Vertices { Vertex vertices[]; };
layout(set = 0, binding = 4, std430) readonly buffer InstanceFirst { uint instance_first[]; };
layout(set = 0, binding = 5, std430) readonly buffer Uvs { vec2 uvs[]; };

// The alpha mask cuts the hit point away (cv_material_evaluate's !present at level 0).
bool hit_cut(Hit h) {
    uint first = 3u * (instance_first[h.instance] + h.triangle);
    Material m = materials[min(vertices[first].material, pc.material_count - 1u)];
    if (m.alpha_mode != 1u)
        return false;
    float alpha = m.alpha;
    if (m.base_color_image != 0u) {
        float w = 1.0 - h.u - h.v;
        vec2 uv = uvs[first] * w + uvs[first + 1u] * h.u + uvs[first + 2u] * h.v;
        alpha = alpha * image_sample(m.base_color_image - 1u, true, uv.x, uv.y, vec4(0.0)).a;
    }
    return !(alpha >= m.alpha_cutoff);
}

void main() {
    uint i = (gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x) * 64u + gl_LocalInvocationID.x;
    if (i >= pc.count)
        return;
    const float retired = uintBitsToFloat(0x7F800000u);
    float tmin = rays[i].tmin;
    if (pc.round > 0u && isinf(tmin))
        return;
    // Member by member: glslang's struct copies between the blocks' Hit types are invalid SPIR-V.
    Hit h;
    if (pc.round == 0u) {
        h = Hit(hits[i].t, hits[i].u, hits[i].v, hits[i].triangle, hits[i].instance);
    } else {
        h = Hit(next_hits[i].t, next_hits[i].u, next_hits[i].v, next_hits[i].triangle, next_hits[i].instance);
        hits[i].t = h.t;
        hits[i].u = h.u;
        hits[i].v = h.v;
        hits[i].triangle = h.triangle;
        hits[i].instance = h.instance;
    }
    if (h.triangle == 0xFFFFFFFFu || !hit_cut(h)) {
        rays[i].tmin = retired;
        return;
    }
    if (pc.round == 0u && pc.any_hit != 0u)
        return; // re-traced closest-hit from its own tmin
    uint passed = pc.round - pc.any_hit;
    rays[i].tmin = passed < pc.layers ? h.t + pc.bias : retired;
}
