// render.reflect_shade: the radiance each reflection ray of a band brings
// back, written at its pixel's full-image position: the sky on a miss; on a
// hit, base color * sun (Lambertian, the shadow ray's visibility) + emission
// (no AO, point lights or further bounces at the hit). The hit's material is
// evaluated (render_material.glsl) at the uv interpolated from the hit's
// barycentrics, at level 0 (no footprint: a ray cone's level of detail is
// future work); a normal image tilts the normal of the sun's cosine (the
// triangle's tangent frame, as the G-buffer's; the shadow ray was decided
// on the interpolated normal); the alpha mask does not apply to it (in a masked scene the
// hit is the one that stands under renderer.h's alpha-mask rule, passes
// render.alpha_continue). Stored as
// RGBA16F (it is copied back from every device each frame): rgb = radiance
// L (at most 65504, half's largest), a = the inverse hit distance 1/t (0 for
// the sky; at most 65504, i.e. t from 1.5e-5 up: half keeps 1/t to 1 part in
// 2048 over the whole range, where t itself would overflow past 65504),
// -1 where there is no sample: no geometry, or the sample was lost; -2 where
// the pixel was not traced this frame (quarter rate); rgb 0 then.
// Records are pixel-major over the band (width x height). Sample k of a
// frame's n is written at row k * height of the image below its pixel's
// (the sample texture holds n images, one above the other).
// Push: { uint x0; uint width; uint height; uint y0; vec4 sun (xyz = unit
//         direction the light travels, w = irradiance); vec4 sun_color;
//         vec4 sky (rgb radiance); uint material_count; uint row_offset (k *
//         the image height); uint pad[2]; }.
// i0: G-buffer positions, b1: reflection cv_ray[], b2: their cv_hit[],
// b3: shadow cv_ray[] (render.reflect_shadow), b4: their cv_hit[], b5: Vertex[],
// b6: uint instance_first[], b7: Material[], i8: reflection sample (RGBA16F, written),
// b9: vec2 uvs[] (per vertex, as b5), b10: the image table, b11: the image pool.
#version 460
#extension GL_GOOGLE_include_directive : require
#include "render_reflect_hit.glsl"
#define MATERIAL_BINDING 7
#define IMAGE_TABLE_BINDING 10
#define IMAGE_POOL_BINDING 11
#include "render_material.glsl"
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;

layout(push_constant, std430) uniform Push {
    uint x0;
    uint width;
    uint height;
    uint y0;
    vec4 sun;
    vec4 sun_color;
    vec4 sky;
    uint material_count;
    uint row_offset;
    uint pad1;
    uint pad2;
} pc;

layout(set = 0, binding = 0, rgba32f) uniform readonly image2D gbuffer_position;
layout(set = 0, binding = 1, std430) readonly buffer Rays { Ray rays[]; };
layout(set = 0, binding = 2, std430) readonly buffer Hits { Hit hits[]; };
layout(set = 0, binding = 3, std430) readonly buffer ShadowRays { Ray shadow_rays[]; };
layout(set = 0, binding = 4, std430) readonly buffer ShadowHits { Hit shadow_hits[]; };
layout(set = 0, binding = 5, std430) readonly buffer Vertices { Vertex vertices[]; };
layout(set = 0, binding = 6, std430) readonly buffer InstanceFirst { uint instance_first[]; };
layout(set = 0, binding = 8, rgba16f) uniform writeonly image2D sample_out;
layout(set = 0, binding = 9, std430) readonly buffer Uvs { vec2 uvs[]; };

const float PI = 3.14159265358979;
const float HALF_MAX = 65504.0; // the largest finite half float

void main() {
    uvec2 local = gl_GlobalInvocationID.xy;
    if (local.x >= pc.width || local.y >= pc.height)
        return;
    ivec2 pixel = ivec2(local.x + pc.x0, local.y + pc.y0);
    uint i = local.y * pc.width + local.x;
    Ray r = rays[i];
    vec4 result = vec4(0.0, 0.0, 0.0, -1.0);
    if (imageLoad(gbuffer_position, pixel).w != 0.0 && r.tmax == 0.0)
        result.a = -2.0;
    if (imageLoad(gbuffer_position, pixel).w != 0.0 && r.tmax > 0.0) {
        Hit h = hits[i];
        if (h.triangle == 0xFFFFFFFFu) {
            result = vec4(min(pc.sky.rgb, vec3(HALF_MAX)), 0.0);
        } else {
            uint first = 3u * (instance_first[h.instance] + h.triangle);
            Vertex a = vertices[first], b = vertices[first + 1u], c = vertices[first + 2u];
            vec3 ng, n;
            hit_frame(a, b, c, h, r.dir, ng, n);
            float w = 1.0 - h.u - h.v;
            vec2 uv = uvs[first] * w + uvs[first + 1u] * h.u + uvs[first + 2u] * h.v;
            Material mat = materials[min(a.material, pc.material_count - 1u)];
            MaterialEval m = material_evaluate(mat, uv, vec4(0.0));
            if (mat.normal_image != 0u) { /* tilts the sun's cosine (the shadow ray kept the interpolated n) */
                vec3 t, bt;
                bool frame = triangle_tangents(a.position, b.position, c.position, uvs[first], uvs[first + 1u],
                                               uvs[first + 2u], t, bt);
                n = tangent_to_world(t, bt, frame, n, m.normal);
            }
            float visible = shadow_rays[i].tmax > 0.0 && shadow_hits[i].triangle == 0xFFFFFFFFu ? 1.0 : 0.0;
            float n_dot_l = max(dot(n, -pc.sun.xyz), 0.0);
            vec3 direct = pc.sun_color.rgb * pc.sun.w * n_dot_l * visible / PI;
            result = vec4(min(m.base_color * direct + m.emission, vec3(HALF_MAX)), 1.0 / max(h.t, 1.0 / HALF_MAX));
        }
    }
    imageStore(sample_out, pixel + ivec2(0, int(pc.row_offset)), result);
}
