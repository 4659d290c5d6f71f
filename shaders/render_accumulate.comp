// render.accumulate: running mean of the visibility over frames (the temporal
// part of the filter), with the second moments the filter estimates variance
// from (seed 000 / SVGF):
// history = (mean sun, mean AO, mean sun^2, mean AO^2) over the pixel's history,
// updated as h + (m - h) / n with m = (c.r, c.g, c.r^2, c.g^2).
//   Still camera (flags bit 0 clear): h is the history in place and n =
//   frame + 1 for every pixel (the camera has not moved since frame 0).
//   Moving camera (bit 0 set): h is render.reproject's reprojected history and
//   n its per-pixel history length (motion.z; 1 = disoccluded: h is not used);
//   the pixel's G-buffer position and normal are kept beside the history
//   (history positions / normals, w of the normals = n) for the next frame's
//   reprojection.
// The history is RGBA32F: in RGBA16F the update rounds away once 1 / (frame + 1)
// is below half a step of h, and partly occluded pixels drifted dark as frames
// grew (issue 11, defect 1); float32 rounding stays below 1e-5 at 4096 frames.
// Push: { uint width; uint height; uint frame; uint flags; }.
// i0: this frame's visibility (R32_UINT, render_visibility.glsl), i1: history (RGBA32F, read and written),
// i2: motion (RGBA32F, z = history length), i3: reprojected history (RGBA32F),
// i4: G-buffer positions, i5: G-buffer normals, i6: history positions out,
// i7: history normals out (all RGBA32F; i2..i7 are used only with bit 0).
#version 460
#extension GL_GOOGLE_include_directive : require
#include "render_visibility.glsl"
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;

layout(push_constant, std430) uniform Push {
    uint width;
    uint height;
    uint frame;
    uint flags;
} pc;

layout(set = 0, binding = 0, r32ui) uniform readonly uimage2D current;
layout(set = 0, binding = 1, rgba32f) uniform image2D history;
layout(set = 0, binding = 2, rgba32f) uniform readonly image2D motion;
layout(set = 0, binding = 3, rgba32f) uniform readonly image2D reprojected;
layout(set = 0, binding = 4, rgba32f) uniform readonly image2D gbuffer_position;
layout(set = 0, binding = 5, rgba32f) uniform readonly image2D gbuffer_normal;
layout(set = 0, binding = 6, rgba32f) uniform writeonly image2D history_position;
layout(set = 0, binding = 7, rgba32f) uniform writeonly image2D history_normal;

const uint MOVING = 1u;

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (p.x >= int(pc.width) || p.y >= int(pc.height))
        return;
    vec2 c = visibility_decode(imageLoad(current, p).r).rg;
    vec4 m = vec4(c, c * c);
    if ((pc.flags & MOVING) == 0u) {
        vec4 h = pc.frame == 0u ? m : imageLoad(history, p);
        imageStore(history, p, h + (m - h) / float(pc.frame + 1u));
        return;
    }
    float n = imageLoad(motion, p).z;
    vec4 h = n <= 1.0 ? m : imageLoad(reprojected, p);
    imageStore(history, p, h + (m - h) / max(n, 1.0));
    vec4 x = imageLoad(gbuffer_position, p);
    imageStore(history_position, p, x.w == 0.0 ? vec4(0.0) : vec4(x.xyz, 1.0));
    imageStore(history_normal, p, vec4(imageLoad(gbuffer_normal, p).xyz, max(n, 1.0)));
}
