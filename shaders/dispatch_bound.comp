// The Vulkan backend's bound on dispatch_indirect (server/vulkan/vk_indirect.c):
// one invocation reads the three group counts the client left in its argument
// buffer and writes, into the list's own slot, either those counts or zeros
// when any exceeds the device's maxComputeWorkGroupCount. The real dispatch
// then reads the slot, so a hostile or broken argument buffer can never launch
// more groups than the same direct dispatch would have been allowed to.
// The slot also keeps the counts as read and a refused flag, for the host to
// report after the submission finished.
// Push constants: the address of the three counts (4-byte aligned), the
// address of the slot, then the limits { uint x, y, z; }.
// Dispatch: 1 x 1 x 1.
#version 460
#extension GL_EXT_buffer_reference : require
layout(local_size_x = 1, local_size_y = 1, local_size_z = 1) in;

layout(buffer_reference, std430, buffer_reference_align = 4) readonly buffer Counts { uint v[3]; };
// bounded[3] is what the dispatch reads; read_as[3] and refused are for the host.
layout(buffer_reference, std430, buffer_reference_align = 16) writeonly buffer Slot {
    uint bounded[3];
    uint refused;
    uint read_as[3];
    uint pad;
};

layout(push_constant, std430) uniform Push {
    Counts args;
    Slot slot;
    uint limit_x;
    uint limit_y;
    uint limit_z;
} pc;

void main() {
    uvec3 g = uvec3(pc.args.v[0], pc.args.v[1], pc.args.v[2]);
    bool refused = any(greaterThan(g, uvec3(pc.limit_x, pc.limit_y, pc.limit_z)));
    uvec3 bounded = refused ? uvec3(0) : g;
    pc.slot.bounded[0] = bounded.x;
    pc.slot.bounded[1] = bounded.y;
    pc.slot.bounded[2] = bounded.z;
    pc.slot.refused = refused ? 1u : 0u;
    pc.slot.read_as[0] = g.x;
    pc.slot.read_as[1] = g.y;
    pc.slot.read_as[2] = g.z;
}
