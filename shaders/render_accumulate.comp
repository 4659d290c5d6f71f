// render.accumulate: running mean of the visibility over frames (the temporal
// part of the filter; the camera is still, so no reprojection is needed):
// history = history + (current - history) / (frame + 1).
// Push: { uint width; uint height; uint frame; uint pad; }.
// i0: this frame's visibility (RGBA16F), i1: history (RGBA16F, read and written).
#version 460
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;

layout(push_constant, std430) uniform Push {
    uint width;
    uint height;
    uint frame;
    uint pad;
} pc;

layout(set = 0, binding = 0, rgba16f) uniform readonly image2D current;
layout(set = 0, binding = 1, rgba16f) uniform image2D history;

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (p.x >= int(pc.width) || p.y >= int(pc.height))
        return;
    vec4 c = imageLoad(current, p);
    vec4 h = pc.frame == 0u ? c : imageLoad(history, p);
    imageStore(history, p, h + (c - h) / float(pc.frame + 1u));
}
