// render.reflect_shadow: for each reflection ray of a band that hit a surface,
// a shadow ray from the hit point toward the centre of the sun (one ray, no
// cone: the reflected shadow is hard). The hit's triangle comes from the
// renderer's vertex list (three vertices per triangle; instance_first maps a
// hit's instance to its first triangle). The origin is offset along the
// triangle's geometric normal on the side the reflection ray came from
// (render_reflect_hit.glsl); a sun below that side or below the shading
// normal gets tmax -1: shadowed.
// Missed, lost or untraced reflection rays get empty shadow rays (tmin 1,
// tmax 0: rejected at the root).
// One invocation per pixel of the band (width x height, pixel-major records).
// Push: { uint width; uint height; float bias; uint pad; vec4 sun (xyz = unit
//         direction the light travels) }.
// b0: reflection cv_ray[], b1: their cv_hit[], b2: Vertex[],
// b3: uint instance_first[], b4: shadow cv_ray[] (written).
#version 460
#extension GL_GOOGLE_include_directive : require
#include "render_reflect_hit.glsl"
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;

layout(push_constant, std430) uniform Push {
    uint width;
    uint height;
    float bias;
    uint pad;
    vec4 sun;
} pc;

layout(set = 0, binding = 0, std430) readonly buffer Rays { Ray rays[]; };
layout(set = 0, binding = 1, std430) readonly buffer Hits { Hit hits[]; };
layout(set = 0, binding = 2, std430) readonly buffer Vertices { Vertex vertices[]; };
layout(set = 0, binding = 3, std430) readonly buffer InstanceFirst { uint instance_first[]; };
layout(set = 0, binding = 4, std430) writeonly buffer ShadowRays { Ray shadow_rays[]; };

void main() {
    uvec2 local = gl_GlobalInvocationID.xy;
    if (local.x >= pc.width || local.y >= pc.height)
        return;
    uint i = local.y * pc.width + local.x;
    Ray r = rays[i];
    Hit h = hits[i];
    if (!(r.tmax > 0.0) || h.triangle == 0xFFFFFFFFu) {
        shadow_rays[i] = Ray(vec3(0.0), 1.0, vec3(0.0, 0.0, 1.0), 0.0);
        return;
    }
    uint first = 3u * (instance_first[h.instance] + h.triangle);
    Vertex a = vertices[first], b = vertices[first + 1u], c = vertices[first + 2u];
    vec3 ng, n;
    hit_frame(a, b, c, h, r.dir, ng, n);
    vec3 x = r.origin + r.dir * h.t;
    vec3 to_sun = -pc.sun.xyz;
    bool lit_side = dot(to_sun, ng) > 0.0 && dot(to_sun, n) > 0.0;
    shadow_rays[i] = Ray(x + ng * pc.bias, 0.0, to_sun, lit_side ? 1e30 : -1.0);
}
