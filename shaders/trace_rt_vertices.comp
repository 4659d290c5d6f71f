// The pipeline path's BLAS input (server/vulkan/vk_trace_rt.c): the three
// vertices v0, v0 + e1, v0 + e2 of every cv_bvh_tri, as 9 floats per triangle
// in the triangle array's order (so a BLAS built from them numbers its
// primitives as the array does). The additions are `precise`: they round as C
// float additions would.
// Push constants: buffer addresses of the triangles (read) and the vertices
// (written), then { uint count; uint pad; }.
// Dispatch: 64 triangles per group, groups laid out as x + y * num_groups_x.
#version 460
#extension GL_GOOGLE_include_directive : require
#include "trace_layout.glsl"
layout(local_size_x = 64, local_size_y = 1, local_size_z = 1) in;

layout(buffer_reference, std430, buffer_reference_align = 4) writeonly buffer VertexArray { float v[]; };

layout(push_constant, std430) uniform Push {
    TriArray tris;
    VertexArray vertices;
    uint count;
    uint pad;
} pc;

void main() {
    uint i = (gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x) * gl_WorkGroupSize.x +
             gl_LocalInvocationID.x;
    if (i >= pc.count)
        return;
    Tri t = pc.tris.tris[i];
    precise vec3 v1 = t.v0 + t.e1;
    precise vec3 v2 = t.v0 + t.e2;
    uint base = 9u * i;
    for (uint k = 0u; k < 3u; k++) {
        pc.vertices.v[base + k] = t.v0[k];
        pc.vertices.v[base + 3u + k] = v1[k];
        pc.vertices.v[base + 6u + k] = v2[k];
    }
}
