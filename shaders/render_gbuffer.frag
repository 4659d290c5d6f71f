// render.gbuffer, fragment stage: writes the G-buffer in two draws of the same
// geometry (renderer.c's pass 'gbuffer'), push mode.x saying which:
// mode.x = 0:
//   color0 (RGBA32F): world position; w = 0 where there is no geometry (the
//     clear), else the geometric normal on the camera's side, octahedral with
//     11 bits a coordinate, as w = 1 + code / 2^22 in [1, 2) (exact in float;
//     render_raygen.comp decodes it; the renderer's output says 1).
//   color1 (RGBA32F): unit shading normal on the side the camera sees (with a
//     normal image, the mapped normal), w = material index.
// mode.x = 1 (the material at the point, render_material.glsl's evaluation):
//   color0 (RGBA32F): base color rgb, roughness; color1 (RGBA32F): emission rgb, metalness.
// Both draws compute the same depth and discard the same fragments, so they
// keep the same surfaces. The material is evaluated at the interpolated uv
// with the footprint of dFdxFine/dFdyFine of the uv (taken before any discard:
// within each 2x2 quad, the difference across its pair of pixels); a
// point the alpha mask cuts away is discarded (the surface behind shows).
// The side is decided by the geometric normal, not the interpolated one. A
// back face of a closed mesh is never the visible surface: it is discarded, so
// it cannot win the depth test at silhouettes and creases (issue 11, defect 2).
// Depth is the view-space depth over the far plane, written by the shader: the
// fixed-function depth (near 1e-4 of the diagonal, LESS) puts most of its float
// steps next to the near plane; linear depth in float has a step of 2^-24 of
// the distance everywhere (the precision reversed Z would give).
// b2: Material[], b3: the image table, b4: the image pool (render_material.glsl).
#version 460
#extension GL_GOOGLE_include_directive : require
#define MATERIAL_BINDING 2
#define IMAGE_TABLE_BINDING 3
#define IMAGE_POOL_BINDING 4
#include "render_material.glsl"

layout(push_constant, std430) uniform Push {
    mat4 view_proj;
    vec4 camera_position;   // w = 1 / far plane
    uvec4 mode;             // x: 0 = position and normal, 1 = material and emission
} pc;

layout(location = 0) in vec3 in_position;
layout(location = 1) in vec3 in_normal;
layout(location = 2) flat in uint in_material;
layout(location = 3) flat in vec4 in_geometric;
layout(location = 4) in vec2 in_uv;
layout(location = 5) flat in vec4 in_tangent;
layout(location = 6) flat in vec3 in_bitangent;

layout(location = 0) out vec4 out_color0;
layout(location = 1) out vec4 out_color1;

float pack_normal(vec3 n) {
    vec2 e = n.xy / (abs(n.x) + abs(n.y) + abs(n.z));
    if (n.z < 0.0)
        e = (1.0 - abs(e.yx)) * vec2(e.x >= 0.0 ? 1.0 : -1.0, e.y >= 0.0 ? 1.0 : -1.0);
    uvec2 q = uvec2(clamp(round((e * 0.5 + 0.5) * 2047.0), 0.0, 2047.0));
    return 1.0 + float(q.x * 2048u + q.y) / 4194304.0;
}

void main() {
    vec2 dx = dFdxFine(in_uv), dy = dFdyFine(in_uv);
    vec3 n = normalize(in_normal), ng = in_geometric.xyz;
    vec3 view = pc.camera_position.xyz - in_position;
    if (dot(ng, view) < 0.0) {
        if (in_geometric.w != 0.0)
            discard;
        // Thin walls and open meshes have no inside: shade the side the camera sees.
        n = -n;
        ng = -ng;
    }
    Material m = materials[in_material];
    MaterialEval e = material_evaluate(m, in_uv, vec4(dx.x, dx.y, dy.x, dy.y));
    if (!e.present)
        discard;
    gl_FragDepth = clamp((1.0 / gl_FragCoord.w) * pc.camera_position.w, 0.0, 1.0);
    if (pc.mode.x == 0u) {
        if (m.normal_image != 0u)
            n = tangent_to_world(in_tangent.xyz, in_bitangent, in_tangent.w != 0.0, n, e.normal);
        out_color0 = vec4(in_position, pack_normal(ng));
        out_color1 = vec4(n, float(in_material));
    } else {
        out_color0 = vec4(e.base_color, e.roughness);
        out_color1 = vec4(e.emission, e.metalness);
    }
}
