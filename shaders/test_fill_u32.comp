// test.fill_u32: data[i] = value + i (u32, wrapping) for every i < count.
// Push constants: { uint value; uint count; }. Binding 0: storage buffer of u32.
#version 460
layout(local_size_x = 64, local_size_y = 1, local_size_z = 1) in;

layout(push_constant, std430) uniform Push {
    uint value;
    uint count;
} pc;

layout(set = 0, binding = 0, std430) writeonly buffer Data { uint data[]; };

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i < pc.count)
        data[i] = pc.value + i;
}
