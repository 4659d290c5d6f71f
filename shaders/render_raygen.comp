// render.raygen: rays for one band of one column partition of the G-buffer:
// columns [x0, x0 + width), rows [y0, y0 + height).
// Per pixel, shadow_samples + ao_samples rays, pixel-major: the shadow rays
// toward the sun, jittered inside the sun's cone (soft shadows), then
// cosine-distributed AO rays of length ao_radius. Sample points come from a
// 64x64 blue-noise rank mask (corvid/blue_noise.h, b3, filled by the
// renderer), a value per pixel and sample dimension, offset by the frame's
// point of a Roberts sequence (shadow_sample, ao_sample): within a frame
// neighbouring pixels' errors are blue noise, which the a-trous filter
// removes best; over the frames each pixel walks a low-discrepancy sequence.
// All in 0.32 fixed point: the points are a function of (pixel, frame) only,
// the same bits on every device. Pixels without geometry get empty
// rays (tmax = 0); a shadow ray whose direction is below the surface (the
// pixel faces away from that point of the sun) gets tmin 0 > tmax -1: no ray,
// and render.resolve reads it as shadowed, not as a miss.
// Rays leave from the geometric surface (issue 11, defect 4): the origin is
// offset along the triangle's geometric normal (packed in the G-buffer
// position's w), the shadow ray counts as below the surface when its
// direction is below the shading or the geometric plane, and an AO direction
// drawn around the shading normal that falls below the geometric plane is
// mirrored across it, so a smooth low-poly mesh does not occlude itself.
// Push: { uint x0; uint width; uint height; uint ao_samples; vec4 sun (xyz = unit
//         direction the light travels, w = cone half angle, radians);
//         uint frame; float ao_radius; float bias; uint y0; uint shadow_samples; }.
// i0: G-buffer positions (RGBA32F), i1: G-buffer normals (RGBA32F), b2: cv_ray[],
// b3: the blue-noise mask (uint[2048], read).
#version 460
#extension GL_GOOGLE_include_directive : require
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
    uint ao_samples;
    vec4 sun;
    uint frame;
    float ao_radius;
    float bias;
    uint y0;
    uint shadow_samples;
} pc;

layout(set = 0, binding = 0, rgba32f) uniform readonly image2D gbuffer_position;
layout(set = 0, binding = 1, rgba32f) uniform readonly image2D gbuffer_normal;
layout(set = 0, binding = 2, std430) writeonly buffer Rays { Ray rays[]; };
#define BLUE_NOISE_BINDING 3
#include "render_blue_noise.glsl"

const float PI = 3.14159265358979;

// Shadow ray k's point in the sun's cone (2D, [0, 1)^2): the pixel's mask
// values offset by point frame x shadow_samples + k of the R2 sequence, so a
// pixel's rays, within a frame and over the frames, walk one low-discrepancy
// sequence (one ray a frame: the frame's point).
vec2 shadow_sample(uvec2 pixel, uint k) {
    uvec2 v = uvec2(mask(pixel, 2u), mask(pixel, 3u)) + r2(pc.frame * pc.shadow_samples + k);
    return vec2(unit(v.x), unit(v.y));
}

// The second dimension of Sobol's sequence at index i, 0.32 fixed point (the
// first is bitfieldReverse(i)): together a (0, 2)-sequence in base 2, whose
// aligned blocks of 2^m points are stratified in every dyadic box of area 2^-m.
uint sobol1(uint i) {
    uint r = 0u;
    for (uint v = 1u << 31; i != 0u; i >>= 1, v ^= v >> 1)
        if ((i & 1u) != 0u)
            r ^= v;
    return r;
}

// AO ray k of n = ao_samples: point frame x 2^b + k of Sobol's (0, 2)-sequence
// (2^b >= n: the frame's rays an aligned block, stratified in x, in y and in
// the 2x2 squares for n = 4), digitally shifted (xor, which keeps the
// stratification) by the pixel's blue-noise values: below the block's strata
// (the mask value / 2^b), so that within its stratum a ray's offset is the
// pixel's blue noise (a shift in the strata's own bits would only see the
// mask value modulo 1 / n: white noise), and for y also in the strata's bits
// (a third mask value: which x stratum pairs with which y stratum). Over the
// frames each pixel's rays are a digitally shifted Sobol sequence: they fill
// the square at the rate of frames x n points, and the mean is unbiased.
vec2 ao_sample(uvec2 pixel, uint k) {
    uint bits = pc.ao_samples > 1u ? uint(findMSB(pc.ao_samples - 1u)) + 1u : 0u;
    uint index = (pc.frame << bits) + k;
    uint strata = bits > 0u ? ~0u << (32u - bits) : 0u;
    uvec2 v = uvec2(bitfieldReverse(index), sobol1(index)) ^ (uvec2(mask(pixel, 0u), mask(pixel, 1u)) >> bits) ^
              uvec2(0u, mask(pixel, 4u) & strata);
    return vec2(unit(v.x), unit(v.y));
}

vec3 unpack_normal(float w) {
    uint code = uint(round((w - 1.0) * 4194304.0));
    vec2 e = vec2(float(code >> 11u), float(code & 2047u)) / 2047.0 * 2.0 - 1.0;
    vec3 n = vec3(e, 1.0 - abs(e.x) - abs(e.y));
    float t = max(-n.z, 0.0);
    n.xy += vec2(n.x >= 0.0 ? -t : t, n.y >= 0.0 ? -t : t);
    return normalize(n);
}

// An orthonormal basis around n (Frisvad, revised by Duff et al.).
void basis(vec3 n, out vec3 t, out vec3 b) {
    float s = n.z >= 0.0 ? 1.0 : -1.0;
    float a = -1.0 / (s + n.z);
    float c = n.x * n.y * a;
    t = vec3(1.0 + s * n.x * n.x * a, s * c, -s * n.x);
    b = vec3(c, s + n.y * n.y * a, -n.y);
}

void main() {
    uvec2 local = gl_GlobalInvocationID.xy;
    if (local.x >= pc.width || local.y >= pc.height)
        return;
    uvec2 pixel = uvec2(local.x + pc.x0, local.y + pc.y0);
    uint per_pixel = pc.shadow_samples + pc.ao_samples;
    uint first = (local.y * pc.width + local.x) * per_pixel;
    vec4 p = imageLoad(gbuffer_position, ivec2(pixel));
    if (p.w == 0.0) {
        for (uint k = 0u; k < per_pixel; k++)
            rays[first + k] = Ray(vec3(0.0), 0.0, vec3(0.0, 0.0, 1.0), 0.0);
        return;
    }
    vec3 n = imageLoad(gbuffer_normal, ivec2(pixel)).xyz;
    vec3 ng = unpack_normal(p.w);
    vec3 origin = p.xyz + ng * pc.bias;

    // Shadow rays: directions inside the cone around the direction to the sun.
    vec3 to_sun = -pc.sun.xyz, t, b;
    basis(to_sun, t, b);
    for (uint k = 0u; k < pc.shadow_samples; k++) {
        vec2 u = shadow_sample(pixel, k);
        float cos_theta = 1.0 - u.x * (1.0 - cos(pc.sun.w));
        float sin_theta = sqrt(max(0.0, 1.0 - cos_theta * cos_theta));
        float phi = 2.0 * PI * u.y;
        vec3 dir = normalize(t * (cos(phi) * sin_theta) + b * (sin(phi) * sin_theta) + to_sun * cos_theta);
        float tmax = dot(dir, n) > 0.0 && dot(dir, ng) > 0.0 ? 1e30 : -1.0;   // facing away from the sun: in shadow
        rays[first + k] = Ray(origin, 0.0, dir, tmax);
    }

    // Ambient occlusion: cosine-weighted hemisphere around n.
    basis(n, t, b);
    for (uint k = 0u; k < pc.ao_samples; k++) {
        vec2 v = ao_sample(pixel, k);
        float r = sqrt(v.x), a = 2.0 * PI * v.y;
        vec3 d = normalize(t * (r * cos(a)) + b * (r * sin(a)) + n * sqrt(max(0.0, 1.0 - v.x)));
        float below = dot(d, ng);
        if (below < 0.0)
            d = normalize(d - 2.0 * below * ng);
        rays[first + pc.shadow_samples + k] = Ray(origin, 0.0, d, pc.ao_radius);
    }
}
