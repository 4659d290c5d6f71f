// The data of the trace_rays command as its kernels see it: the GPU layouts of
// client/include/corvid/bvh_gpu.h declared member for member (std430, so the C
// and GLSL offsets agree), reached through buffer device addresses passed in
// push constants, so no array is limited by the storage buffer range.
#extension GL_EXT_buffer_reference : require

struct Node2 {
    vec3 a_min; uint a_link;
    vec3 a_max; uint a_count;
    vec3 b_min; uint b_link;
    vec3 b_max; uint b_count;
};
struct Tri {
    vec3 v0; uint prim;
    vec3 e1; uint instance;
    vec3 e2; uint pad;
};
struct Ray {
    vec3 origin; float tmin;
    vec3 dir; float tmax;
};
struct Hit {
    float t; float u; float v;
    uint triangle; uint instance;
};

layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer NodeArray { Node2 nodes[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer TriArray { Tri tris[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer RayArray { Ray rays[]; };
layout(buffer_reference, std430, buffer_reference_align = 4) writeonly buffer HitArray { Hit hits[]; };

const uint TRACE_ANY_HIT = 1u;
const uint TRACE_CULL_BACK_FACES = 2u;
const uint TRACE_INVALID = 0xFFFFFFFFu;

// A miss as bvh_gpu.h defines it: t = +infinity, u = v = 0, invalid ids.
Hit trace_miss() {
    return Hit(uintBitsToFloat(0x7F800000u), 0.0, 0.0, TRACE_INVALID, TRACE_INVALID);
}
