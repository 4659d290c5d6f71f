// render.raygen: rays for one band of one column partition of the G-buffer:
// columns [x0, x0 + width), rows [y0, y0 + height).
// Per pixel, 1 + ao_samples rays, pixel-major: a shadow ray toward the sun,
// jittered inside the sun's cone (soft shadows), then cosine-distributed AO rays
// of length ao_radius. Sample points are a Halton (2, 3) sequence indexed by
// frame, Cranley-Patterson rotated per pixel (seed 000, "Hybrid Rendering for
// Real-Time Ray Tracing"): white noise for the shadow, a spatially
// decorrelated rotation for AO (sample2). Pixels without geometry get empty
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
//         uint frame; float ao_radius; float bias; uint y0; }.
// i0: G-buffer positions (RGBA32F), i1: G-buffer normals (RGBA32F), b2: cv_ray[].
#version 460
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
} pc;

layout(set = 0, binding = 0, rgba32f) uniform readonly image2D gbuffer_position;
layout(set = 0, binding = 1, rgba32f) uniform readonly image2D gbuffer_normal;
layout(set = 0, binding = 2, std430) writeonly buffer Rays { Ray rays[]; };

const float PI = 3.14159265358979;

float halton(uint index, uint base) {
    float f = 1.0, r = 0.0;
    while (index > 0u) {
        f /= float(base);
        r += f * float(index % base);
        index /= base;
    }
    return r;
}

uint hash(uint x) {
    x ^= x >> 16; x *= 0x7feb352du;
    x ^= x >> 15; x *= 0x846ca68bu;
    x ^= x >> 16;
    return x;
}

// Point k of the pixel's rotated Halton sequence (k = 0: the shadow ray, 1..:
// the AO rays). The shadow's rotation is white noise (a hash of the pixel);
// the AO's is spatially decorrelated, so that neighbouring pixels' AO samples
// cover the hemisphere unlike each other and the filter averages their errors
// out: the first coordinate (the cosine of the elevation) is Roberts' R2
// dither (plastic constant), the second (the azimuth) interleaved gradient
// noise (Jimenez). Over the frames each pixel still gets a Halton sequence
// under a fixed rotation, so its mean is unbiased; the points are a function
// of (pixel, frame) only.
vec2 sample2(uvec2 pixel, uint k) {
    vec2 rotation;
    if (k == 0u) {
        uint h = hash(pixel.x * 73856093u ^ pixel.y * 19349663u);
        rotation = vec2(float(h & 0xFFFFu), float(h >> 16)) / 65536.0;
    } else {
        // In 0.32 fixed point, so that every device computes the same bits:
        // R2 = fract(0.5 + 0.7548776662 x + 0.5698402910 y),
        // IGN = fract(52.9829189 fract(0.06711056 x + 0.00583715 y)).
        uint r2 = 0x80000000u + pixel.x * 3242174889u + pixel.y * 2447445414u;
        uint g = pixel.x * 288237660u + pixel.y * 25070368u, hi, lo;
        umulExtended(g, 4221604530u, hi, lo);
        uint ign = g * 52u + hi;
        rotation = vec2(float(r2 >> 8), float(ign >> 8)) / 16777216.0;
    }
    uint index = pc.frame * (pc.ao_samples + 1u) + k + 1u;
    return fract(vec2(halton(index, 2u), halton(index, 3u)) + rotation);
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
    uint first = (local.y * pc.width + local.x) * (pc.ao_samples + 1u);
    vec4 p = imageLoad(gbuffer_position, ivec2(pixel));
    if (p.w == 0.0) {
        for (uint k = 0u; k <= pc.ao_samples; k++)
            rays[first + k] = Ray(vec3(0.0), 0.0, vec3(0.0, 0.0, 1.0), 0.0);
        return;
    }
    vec3 n = imageLoad(gbuffer_normal, ivec2(pixel)).xyz;
    vec3 ng = unpack_normal(p.w);
    vec3 origin = p.xyz + ng * pc.bias;

    // Shadow ray: a direction inside the cone around the direction to the sun.
    vec3 to_sun = -pc.sun.xyz, t, b;
    basis(to_sun, t, b);
    vec2 u = sample2(pixel, 0u);
    float cos_theta = 1.0 - u.x * (1.0 - cos(pc.sun.w));
    float sin_theta = sqrt(max(0.0, 1.0 - cos_theta * cos_theta));
    float phi = 2.0 * PI * u.y;
    vec3 dir = normalize(t * (cos(phi) * sin_theta) + b * (sin(phi) * sin_theta) + to_sun * cos_theta);
    float tmax = dot(dir, n) > 0.0 && dot(dir, ng) > 0.0 ? 1e30 : -1.0;   // facing away from the sun: in shadow
    rays[first] = Ray(origin, 0.0, dir, tmax);

    // Ambient occlusion: cosine-weighted hemisphere around n.
    basis(n, t, b);
    for (uint k = 0u; k < pc.ao_samples; k++) {
        vec2 v = sample2(pixel, k + 1u);
        float r = sqrt(v.x), a = 2.0 * PI * v.y;
        vec3 d = normalize(t * (r * cos(a)) + b * (r * sin(a)) + n * sqrt(max(0.0, 1.0 - v.x)));
        float below = dot(d, ng);
        if (below < 0.0)
            d = normalize(d - 2.0 * below * ng);
        rays[first + 1u + k] = Ray(origin, 0.0, d, pc.ao_radius);
    }
}
