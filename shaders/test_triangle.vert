// test.triangle, vertex stage: vertex pulling, no vertex input. Vertex i is
// positions[i] (a vec4 in clip space) from the storage buffer at binding 0.
#version 460

layout(set = 0, binding = 0, std430) readonly buffer Vertices { vec4 positions[]; };

void main() {
    gl_Position = positions[gl_VertexIndex];
}
