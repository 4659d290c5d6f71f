// render.present: the composite's linear HDR radiance for a screen, as image/'s
// cv_tonemap_to_srgb8 with CV_TONEMAP_ACES computes it on the CPU (image/src/tonemap.c):
// per colour channel x = radiance * scale (scale = 2^exposure, from the host), the ACES fit
// x (2.51 x + 0.03) / (x (2.43 x + 0.59) + 0.14) below 8 (1 from 8 on, 0 for x <= 0), the
// sRGB encoding, stored to RGBA8_UNORM; alpha = the radiance's, clamped to 0..1. The CPU
// evaluates the fit in double, this in float: the bytes agree within 1 in 255.
// Push constants: { uint width; uint height; float scale; float pad; }. Binding 0: radiance
// (RGBA32F, read), binding 1: display (RGBA8_UNORM, written). Groups: ceil(width / 8) x
// ceil(height / 8).
#version 460
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;

layout(push_constant, std430) uniform Push {
    uint width;
    uint height;
    float scale;
    float pad;
} pc;

layout(set = 0, binding = 0, rgba32f) uniform readonly image2D radiance;
layout(set = 0, binding = 1, rgba8) uniform writeonly image2D display;

float aces(float x) {
    if (!(x > 0.0))
        return 0.0; // negative, zero and NaN
    if (x >= 8.0)
        return 1.0; // the fit reaches 1 at about 7.25
    return min(x * (2.51 * x + 0.03) / (x * (2.43 * x + 0.59) + 0.14), 1.0);
}

float srgb(float v) {
    if (!(v > 0.0))
        return 0.0;
    if (v >= 1.0)
        return 1.0;
    return v <= 0.0031308 ? 12.92 * v : 1.055 * pow(v, 1.0 / 2.4) - 0.055;
}

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (p.x >= int(pc.width) || p.y >= int(pc.height))
        return;
    vec4 c = imageLoad(radiance, p);
    float a = c.a > 0.0 ? min(c.a, 1.0) : 0.0;
    imageStore(display, p,
               vec4(srgb(aces(c.r * pc.scale)), srgb(aces(c.g * pc.scale)), srgb(aces(c.b * pc.scale)), a));
}
