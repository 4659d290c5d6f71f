// render.filter: one edge-avoiding a-trous iteration (5x5 B3-spline kernel with
// holes of `step` pixels) over the visibility, weighted by normal and position
// similarity so shadows and AO are smoothed within surfaces, not across edges
// (the spatial part of seed 000's SVGF-like shadow filter). Run with steps 1, 2, 4.
// Push: { uint width; uint height; uint step; float position_sigma; }.
// i0: positions, i1: normals (RGBA32F), i2: input visibility, i3: output (both
// RGBA32F: r = sun, g = AO are filtered, b, a = their second moments pass through).
#version 460
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;

layout(push_constant, std430) uniform Push {
    uint width;
    uint height;
    uint step;
    float position_sigma;
} pc;

layout(set = 0, binding = 0, rgba32f) uniform readonly image2D gbuffer_position;
layout(set = 0, binding = 1, rgba32f) uniform readonly image2D gbuffer_normal;
layout(set = 0, binding = 2, rgba32f) uniform readonly image2D source;
layout(set = 0, binding = 3, rgba32f) uniform writeonly image2D target;

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = ivec2(pc.width, pc.height);
    if (p.x >= size.x || p.y >= size.y)
        return;
    vec4 centre = imageLoad(source, p);
    vec4 cp = imageLoad(gbuffer_position, p);
    if (cp.w == 0.0) {
        imageStore(target, p, centre);
        return;
    }
    vec3 cn = imageLoad(gbuffer_normal, p).xyz;
    const float kernel[3] = float[3](3.0 / 8.0, 1.0 / 4.0, 1.0 / 16.0);
    vec2 sum = vec2(0.0);
    float weight = 0.0;
    for (int dy = -2; dy <= 2; dy++) {
        for (int dx = -2; dx <= 2; dx++) {
            ivec2 q = p + ivec2(dx, dy) * int(pc.step);
            if (any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, size)))
                continue;
            vec4 qp = imageLoad(gbuffer_position, q);
            if (qp.w == 0.0)
                continue;
            vec3 qn = imageLoad(gbuffer_normal, q).xyz;
            float wn = pow(max(dot(cn, qn), 0.0), 32.0);
            vec3 d = qp.xyz - cp.xyz;
            float wp = exp(-dot(d, d) / (pc.position_sigma * pc.position_sigma));
            float w = kernel[abs(dx)] * kernel[abs(dy)] * wn * wp;
            sum += imageLoad(source, q).rg * w;
            weight += w;
        }
    }
    imageStore(target, p, weight > 0.0 ? vec4(sum / weight, centre.ba) : centre);
}
