// test.saxpy: y[i] = a * x[i] + y[i] for every i < count, rounded after the
// multiply and after the add (no fused multiply-add), so a CPU computing
// `y[i] = a * x[i] + y[i]` in float gets the same bits.
// Push constants: { float a; uint count; }. Bindings: 0 = x (f32), 1 = y (f32).
#version 460
layout(local_size_x = 64, local_size_y = 1, local_size_z = 1) in;

layout(push_constant, std430) uniform Push {
    float a;
    uint count;
} pc;

layout(set = 0, binding = 0, std430) readonly buffer X { float x[]; };
layout(set = 0, binding = 1, std430) buffer Y { float y[]; };

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i < pc.count) {
        precise float product = pc.a * x[i];
        precise float sum = product + y[i];
        y[i] = sum;
    }
}
