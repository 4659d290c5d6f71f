// test.luminance: the Rec. 709 luminance of every texel of an RGBA32F image,
// written grey with the source's alpha:
//   l = 0.2126 r + 0.7152 g + 0.0722 b,  view = (l, l, l, a).
// The example pass written from scratch (tests/renderer/custom_pass_test.c,
// docs/render-graph.md "Writing a pass") runs it on the composite's radiance.
// Push constants: { uint width; uint height; }. Binding 0: source (RGBA32F,
// read), binding 1: view (RGBA32F, written). Groups: ceil(width / 8) x
// ceil(height / 8).
#version 460
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;

layout(push_constant, std430) uniform Push {
    uint width;
    uint height;
} pc;

layout(set = 0, binding = 0, rgba32f) uniform readonly image2D source;
layout(set = 0, binding = 1, rgba32f) uniform writeonly image2D view;

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (p.x >= int(pc.width) || p.y >= int(pc.height))
        return;
    vec4 c = imageLoad(source, p);
    float l = 0.2126 * c.r + 0.7152 * c.g + 0.0722 * c.b;
    imageStore(view, p, vec4(l, l, l, c.a));
}
