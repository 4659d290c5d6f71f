// render.accumulate: running mean of the visibility over frames (the temporal
// part of the filter; the camera is still, so no reprojection is needed), with
// the second moments the filter estimates variance from (seed 000 / SVGF):
// history = (mean sun, mean AO, mean sun^2, mean AO^2) over frames 0..frame,
// updated as h + (m - h) / (frame + 1) with m = (c.r, c.g, c.r^2, c.g^2).
// The history is RGBA32F: in RGBA16F the update rounds away once 1 / (frame + 1)
// is below half a step of h, and partly occluded pixels drifted dark as frames
// grew (issue 11, defect 1); float32 rounding stays below 1e-5 at 4096 frames.
// Push: { uint width; uint height; uint frame; uint pad; }.
// i0: this frame's visibility (RGBA16F), i1: history (RGBA32F, read and written).
#version 460
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;

layout(push_constant, std430) uniform Push {
    uint width;
    uint height;
    uint frame;
    uint pad;
} pc;

layout(set = 0, binding = 0, rgba16f) uniform readonly image2D current;
layout(set = 0, binding = 1, rgba32f) uniform image2D history;

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (p.x >= int(pc.width) || p.y >= int(pc.height))
        return;
    vec2 c = imageLoad(current, p).rg;
    vec4 m = vec4(c, c * c);
    vec4 h = pc.frame == 0u ? m : imageLoad(history, p);
    imageStore(history, p, h + (m - h) / float(pc.frame + 1u));
}
