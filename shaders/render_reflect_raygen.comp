// render.reflect_raygen: one GGX reflection ray per pixel for one band of one
// column partition of the G-buffer: columns [x0, x0 + width), rows [y0, y0 +
// height), pixel-major (render_reflect_common.glsl draws the direction); the
// ray of sample k of the frame's n (render_reflect_sample.glsl).
// Pixels without geometry get empty rays (tmin 0, tmax 0: a miss nobody
// reads); a lost sample (render_reflect_common.glsl) gets tmax -1, which
// render.reflect_shade reads as radiance 0. At quarter rate (half resolution,
// `quarter` 1) one pixel of each 2x2 quad is traced per frame, the quad's
// pixel (x & 1) + 2 (y & 1) == frame % 4; the others get untraced rays
// (tmin 1, tmax 0: rejected at the root). The origin is offset along the
// geometric normal (the G-buffer position's w), as render.raygen's rays.
// Push: { uint x0; uint width; uint height; uint y0; vec4 camera (xyz = eye,
//         w = origin offset); uint frame; uint material_count; uint quarter;
//         uint samples (n); uint sample (k); uint pad[3]; }.
// i0: G-buffer positions, i1: G-buffer normals (w = material), i2: G-buffer
// material (RGBA32F, w = roughness, textures included: render_gbuffer.frag),
// b3: cv_ray[] (written), b4: the blue-noise mask (render_blue_noise.glsl).
#version 460
#extension GL_GOOGLE_include_directive : require
#include "render_reflect_common.glsl"
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;

struct Ray {
    vec3 origin;
    float tmin;
    vec3 dir;
    float tmax;
};

layout(push_constant, std430) uniform Push {
    uint x0;
    uint width;
    uint height;
    uint y0;
    vec4 camera;
    uint frame;
    uint material_count;
    uint quarter;
    uint samples;
    uint sample_index;
    uint pad0;
    uint pad1;
    uint pad2;
} pc;

layout(set = 0, binding = 0, rgba32f) uniform readonly image2D gbuffer_position;
layout(set = 0, binding = 1, rgba32f) uniform readonly image2D gbuffer_normal;
layout(set = 0, binding = 2, rgba32f) uniform readonly image2D gbuffer_material;
layout(set = 0, binding = 3, std430) writeonly buffer Rays { Ray rays[]; };
#define BLUE_NOISE_BINDING 4
#include "render_blue_noise.glsl"
#include "render_reflect_sample.glsl"

void main() {
    uvec2 local = gl_GlobalInvocationID.xy;
    if (local.x >= pc.width || local.y >= pc.height)
        return;
    uvec2 pixel = uvec2(local.x + pc.x0, local.y + pc.y0);
    uint i = local.y * pc.width + local.x;
    vec4 p = imageLoad(gbuffer_position, ivec2(pixel));
    if (p.w == 0.0) {
        rays[i] = Ray(vec3(0.0), 0.0, vec3(0.0, 0.0, 1.0), 0.0);
        return;
    }
    if (pc.quarter != 0u && (pixel.x & 1u) + 2u * (pixel.y & 1u) != pc.frame % 4u) {
        rays[i] = Ray(vec3(0.0), 1.0, vec3(0.0, 0.0, 1.0), 0.0);
        return;
    }
    vec4 nm = imageLoad(gbuffer_normal, ivec2(pixel));
    vec3 ng = unpack_normal(p.w);
    float roughness = imageLoad(gbuffer_material, ivec2(pixel)).w;
    vec3 v = normalize(pc.camera.xyz - p.xyz), l;
    float weight;
    bool ok = reflect_sample(v, nm.xyz, ng, roughness, reflect_sample_point(pixel, pc.frame, pc.quarter != 0u, pc.sample_index, pc.samples), l, weight);
    rays[i] = Ray(p.xyz + ng * pc.camera.w, 0.0, l, ok ? 1e30 : -1.0);
}
