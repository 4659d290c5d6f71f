// test.gradient: writes every texel (x, y) of a storage texture with
//   gx = x + origin_x, gy = y + origin_y (as u32, wrapping),
//   rgba = ((gx & 255) / 256, (gy & 255) / 256, ((gx + gy) & 255) / 256, 1).
// The values are exact in 16- and 32-bit float formats. The image is declared
// without a format, so any float color format with storage support works.
// Push constants: { int origin_x; int origin_y; }. Binding 0: storage texture.
#version 460
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;

layout(push_constant, std430) uniform Push {
    int origin_x;
    int origin_y;
} pc;

layout(set = 0, binding = 0) uniform writeonly image2D target;

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(p, imageSize(target))))
        return;
    uint gx = uint(p.x + pc.origin_x);
    uint gy = uint(p.y + pc.origin_y);
    const float step = 1.0 / 256.0;
    vec4 value = vec4(float(gx & 255u) * step, float(gy & 255u) * step,
                      float((gx + gy) & 255u) * step, 1.0);
    imageStore(target, p, value);
}
