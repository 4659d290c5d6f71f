// render.gbuffer, vertex stage. Vertex pulling from a flat list of world-space
// vertices, three per triangle (no vertex input state). Each vertex also gets
// its triangle's geometric normal (from the winding, turned to the side of the
// vertex normals) and whether the triangle's mesh is closed.
// Push: { mat4 view_proj; vec4 camera_position (w = 1 / far plane); }.
// b0: Vertex { vec3 position; uint material; vec3 normal; float closed; } (32 bytes).
#version 460

struct Vertex {
    vec3 position;
    uint material;
    vec3 normal;
    float closed;
};

layout(set = 0, binding = 0, std430) readonly buffer Vertices { Vertex vertices[]; };

layout(push_constant, std430) uniform Push {
    mat4 view_proj;
    vec4 camera_position;
} pc;

layout(location = 0) out vec3 out_position;
layout(location = 1) out vec3 out_normal;
layout(location = 2) flat out uint out_material;
layout(location = 3) flat out vec4 out_geometric;   // xyz = unit geometric normal, w = closed

void main() {
    Vertex v = vertices[gl_VertexIndex];
    int first = gl_VertexIndex - gl_VertexIndex % 3;
    vec3 a = vertices[first].position, b = vertices[first + 1].position, c = vertices[first + 2].position;
    vec3 ng = cross(b - a, c - a);
    float len = length(ng);
    ng = len > 0.0 ? ng / len : v.normal;
    if (dot(ng, vertices[first].normal + vertices[first + 1].normal + vertices[first + 2].normal) < 0.0)
        ng = -ng;
    out_position = v.position;
    out_normal = v.normal;
    out_material = v.material;
    out_geometric = vec4(ng, v.closed);
    gl_Position = pc.view_proj * vec4(v.position, 1.0);
}
