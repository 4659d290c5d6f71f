// render.gbuffer, vertex stage. Vertex pulling from a flat list of world-space
// vertices, three per triangle (no vertex input state).
// Push: { mat4 view_proj; vec4 camera_position; }.
// b0: Vertex { vec3 position; uint material; vec3 normal; float pad; } (32 bytes).
#version 460

struct Vertex {
    vec3 position;
    uint material;
    vec3 normal;
    float pad;
};

layout(set = 0, binding = 0, std430) readonly buffer Vertices { Vertex vertices[]; };

layout(push_constant, std430) uniform Push {
    mat4 view_proj;
    vec4 camera_position;
} pc;

layout(location = 0) out vec3 out_position;
layout(location = 1) out vec3 out_normal;
layout(location = 2) flat out uint out_material;

void main() {
    Vertex v = vertices[gl_VertexIndex];
    out_position = v.position;
    out_normal = v.normal;
    out_material = v.material;
    gl_Position = pc.view_proj * vec4(v.position, 1.0);
}
