// test.triangle, fragment stage: every covered pixel gets the push-constant color.
// Push constants: { vec4 color; } (16 bytes, shared by both stages).
#version 460

layout(push_constant, std430) uniform Push {
    vec4 color;
} pc;

layout(location = 0) out vec4 out_color;

void main() {
    out_color = pc.color;
}
