// render.gbuffer, vertex stage. Vertex pulling from a flat list of world-space
// vertices, three per triangle (no vertex input state). Each vertex also gets
// its triangle's geometric normal (from the winding, turned to the side of the
// vertex normals) and whether the triangle's mesh is closed, its uv (b1, a
// parallel list; 0 for meshes without) and its triangle's dp/du and dp/dv
// (render_material.glsl's triangle_tangents; w = 1 where the uvs give a frame).
// Push: { mat4 view_proj; vec4 camera_position (w = 1 / far plane); uvec4 mode; }
// (mode: render_gbuffer.frag).
// b0: Vertex { vec3 position; uint material; vec3 normal; float closed; } (32 bytes),
// b1: vec2 uvs[] (one per vertex), b2..b4: render_gbuffer.frag's.
#version 460
#extension GL_GOOGLE_include_directive : require
#include "render_material.glsl"

struct Vertex {
    vec3 position;
    uint material;
    vec3 normal;
    float closed;
};

layout(set = 0, binding = 0, std430) readonly buffer Vertices { Vertex vertices[]; };
layout(set = 0, binding = 1, std430) readonly buffer Uvs { vec2 uvs[]; };

layout(push_constant, std430) uniform Push {
    mat4 view_proj;
    vec4 camera_position;
    uvec4 mode;
} pc;

layout(location = 0) out vec3 out_position;
layout(location = 1) out vec3 out_normal;
layout(location = 2) flat out uint out_material;
layout(location = 3) flat out vec4 out_geometric;   // xyz = unit geometric normal, w = closed
layout(location = 4) out vec2 out_uv;
layout(location = 5) flat out vec4 out_tangent;     // xyz = dp/du, w = 1: the triangle has a frame
layout(location = 6) flat out vec3 out_bitangent;   // dp/dv

void main() {
    Vertex v = vertices[gl_VertexIndex];
    int first = gl_VertexIndex - gl_VertexIndex % 3;
    vec3 a = vertices[first].position, b = vertices[first + 1].position, c = vertices[first + 2].position;
    vec3 ng = cross(b - a, c - a);
    float len = length(ng);
    ng = len > 0.0 ? ng / len : v.normal;
    if (dot(ng, vertices[first].normal + vertices[first + 1].normal + vertices[first + 2].normal) < 0.0)
        ng = -ng;
    vec3 t, bt;
    bool frame = triangle_tangents(a, b, c, uvs[first], uvs[first + 1], uvs[first + 2], t, bt);
    out_position = v.position;
    out_normal = v.normal;
    out_material = v.material;
    out_geometric = vec4(ng, v.closed);
    out_uv = uvs[gl_VertexIndex];
    out_tangent = vec4(t, frame ? 1.0 : 0.0);
    out_bitangent = bt;
    gl_Position = pc.view_proj * vec4(v.position, 1.0);
}
