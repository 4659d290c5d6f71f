// test.sample_copy: for every texel (x, y) of the destination, samples the
// source at the centre of texel (x + offset_x, y + offset_y), level 0, through
// the bound sampler, and stores the result. With a NEAREST sampler this is an
// exact copy of that source texel (clamped to the edge or wrapped, per the
// sampler's address mode).
// Push constants: { int offset_x; int offset_y; }.
// Bindings: 0 = sampled texture + sampler, 1 = storage texture (float format).
#version 460
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;

layout(push_constant, std430) uniform Push {
    int offset_x;
    int offset_y;
} pc;

layout(set = 0, binding = 0) uniform sampler2D source;
layout(set = 0, binding = 1) uniform writeonly image2D target;

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(p, imageSize(target))))
        return;
    vec2 texel_centre = vec2(p + ivec2(pc.offset_x, pc.offset_y)) + 0.5;
    vec2 uv = texel_centre / vec2(textureSize(source, 0));
    imageStore(target, p, textureLod(source, uv, 0.0));
}
