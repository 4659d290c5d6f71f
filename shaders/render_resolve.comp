// render.resolve: turns any-hit results of render.raygen's rays into visibility
// for one band of the partition's pixels: the fraction of the shadow rays
// that reach the sun, the unoccluded fraction of the AO rays, the mean
// distance to the shadow rays' blockers (the any-hit t, each at most 65000 to
// stay finite in half float; 0 when nothing was hit), and 1 when a shadow ray
// hit a blocker, else 0 (the penumbra-aware filter averages the distance over
// those), packed into one R32_UINT texel (render_visibility.glsl). Written at
// the pixel's full-image position.
// A shadow ray with tmax < 0 is render.raygen's mark for a direction below
// the surface (it faces away from that point of the sun): in shadow, though
// tracing it is a miss.
// Push: { uint x0; uint width; uint height; uint ao_samples; uint y0;
//         uint shadow_samples (1, 2, 4, 8, 16 or 32); uint pad[2]; }.
// b0: cv_hit[] (20 bytes: t, u, v, triangle, instance), b1: the cv_ray[] they
// answer (32 bytes: origin, tmin, dir, tmax), i2: visibility (R32_UINT, render_visibility.glsl).
#version 460
#extension GL_GOOGLE_include_directive : require
#include "render_visibility.glsl"
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;

struct Hit {
    float t;
    float u;
    float v;
    uint triangle;
    uint instance;
};

layout(push_constant, std430) uniform Push {
    uint x0;
    uint width;
    uint height;
    uint ao_samples;
    uint y0;
    uint shadow_samples;
    uint pad1;
    uint pad2;
} pc;

struct Ray {
    vec3 origin;
    float tmin;
    vec3 dir;
    float tmax;
};

layout(set = 0, binding = 0, std430) readonly buffer Hits { Hit hits[]; };
layout(set = 0, binding = 1, std430) readonly buffer Rays { Ray rays[]; };
layout(set = 0, binding = 2, r32ui) uniform writeonly uimage2D visibility;

void main() {
    uvec2 local = gl_GlobalInvocationID.xy;
    if (local.x >= pc.width || local.y >= pc.height)
        return;
    uint first = (local.y * pc.width + local.x) * (pc.shadow_samples + pc.ao_samples);
    uint lit = 0u;
    float blockers = 0.0, blocker_sum = 0.0;
    for (uint k = 0u; k < pc.shadow_samples; k++) {
        if (rays[first + k].tmax < 0.0)
            continue;
        if (hits[first + k].triangle == 0xFFFFFFFFu) {
            lit++;
        } else {
            blockers += 1.0;
            blocker_sum += min(hits[first + k].t, 65000.0);
        }
    }
    float open = 0.0;
    uint ao_first = first + pc.shadow_samples;
    for (uint k = 0u; k < pc.ao_samples; k++)
        open += hits[ao_first + k].triangle == 0xFFFFFFFFu ? 1.0 : 0.0;
    float ao = pc.ao_samples > 0u ? open / float(pc.ao_samples) : 1.0;
    vec2 blocker = blockers > 0.0 ? vec2(blocker_sum / blockers, 1.0) : vec2(0.0);
    imageStore(visibility, ivec2(local.x + pc.x0, local.y + pc.y0), uvec4(visibility_encode(lit * (32u / pc.shadow_samples), ao, blocker.x, blocker.y)));
}
