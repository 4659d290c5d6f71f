// The Vulkan backend's compute path for the trace_rays command: one ray per
// invocation against a flat BVH in the two-child layout of
// client/include/corvid/bvh_gpu.h, with a stack and the nearer child first. It
// is the loop of tris_node2() in scene/src/trace_cpu.c, statement for
// statement, with the same ray-box and ray-triangle rules; every expression is
// `precise` so no multiply-add is fused and the arithmetic rounds as C's does.
// Malformed links (an interior child not after its parent, a leaf beyond the
// triangles) are treated as empty rather than followed.
//
// Nodes and triangles are read as 64-bit words (a node is two u64vec4, a
// triangle three u64vec2) and unpacked: the same bits, in half the loads. On
// lavapipe every per-lane load is a gather, and a gather of 64-bit words moves
// twice the data of a 32-bit one for about the same cost (docs/trace-performance.md).
// Needs shaderInt64.
// Push constants: buffer addresses of the nodes, triangles, rays (read) and
// hits (written), then { uint count; uint flags; uint node_count; uint triangle_count; }.
// Dispatch: 64 rays per group, groups laid out as x + y * num_groups_x.
#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#include "trace_layout.glsl"
layout(local_size_x = 64, local_size_y = 1, local_size_z = 1) in;

layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer NodeWords { u64vec4 q[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer TriWords { u64vec2 q[]; };

layout(push_constant, std430) uniform Push {
    NodeWords nodes;
    TriWords tris;
    RayArray rays;
    HitArray hits;
    uint count;
    uint flags;
    uint node_count;
    uint triangle_count;
} pc;

const uint LEAF_BIT = 0x80000000u;
const float DET_EPSILON = 1e-24;
const float MIN_DIR = 1e-20;
const float TFAR_SCALE = 1.00000036;
const uint STACK_SIZE = 66u;   // CVS_BVH_MAX_DEPTH + 2

vec3 o, d, inv;
float tmin, tmax;
bool cull, any_hit;
uint best_tri;
float best_t, best_u, best_v;

// The two 32-bit halves of a little-endian word: its first and second member.
float lo(uint64_t w) { return uintBitsToFloat(uint(w)); }
float hi(uint64_t w) { return uintBitsToFloat(uint(w >> 32)); }
uint hi_u(uint64_t w) { return uint(w >> 32); }

Node2 load_node(uint i) {
    u64vec4 q0 = pc.nodes.q[2u * i], q1 = pc.nodes.q[2u * i + 1u];
    return Node2(vec3(lo(q0.x), hi(q0.x), lo(q0.y)), hi_u(q0.y), vec3(lo(q0.z), hi(q0.z), lo(q0.w)), hi_u(q0.w),
                 vec3(lo(q1.x), hi(q1.x), lo(q1.y)), hi_u(q1.y), vec3(lo(q1.z), hi(q1.z), lo(q1.w)), hi_u(q1.w));
}

Tri load_triangle(uint i) {
    u64vec2 w0 = pc.tris.q[3u * i], w1 = pc.tris.q[3u * i + 1u], w2 = pc.tris.q[3u * i + 2u];
    return Tri(vec3(lo(w0.x), hi(w0.x), lo(w0.y)), hi_u(w0.y), vec3(lo(w1.x), hi(w1.x), lo(w1.y)), hi_u(w1.y),
               vec3(lo(w2.x), hi(w2.x), lo(w2.y)), hi_u(w2.y));
}

// C's `a < b ? a : b` and `a > b ? a : b` (GLSL min/max differ on NaN).
float fmin_(float a, float b) { return a < b ? a : b; }
float fmax_(float a, float b) { return a > b ? a : b; }

bool box_hit(vec3 bmin, vec3 bmax, out float tnear) {
    precise float x0 = (bmin.x - o.x) * inv.x, x1 = (bmax.x - o.x) * inv.x;
    precise float y0 = (bmin.y - o.y) * inv.y, y1 = (bmax.y - o.y) * inv.y;
    precise float z0 = (bmin.z - o.z) * inv.z, z1 = (bmax.z - o.z) * inv.z;
    float tn = fmax_(fmax_(fmin_(x0, x1), fmin_(y0, y1)), fmax_(fmin_(z0, z1), tmin));
    precise float tf = fmin_(fmin_(fmax_(x0, x1), fmax_(y0, y1)), fmax_(z0, z1)) * TFAR_SCALE;
    tf = fmin_(tf, tmax);
    tnear = tn;
    return tn <= tf;
}

bool tri_hit(uint k, out float t_out, out float u_out, out float v_out) {
    Tri tri = load_triangle(k);
    vec3 v0 = tri.v0, e1 = tri.e1, e2 = tri.e2;
    precise vec3 p = vec3(d.y * e2.z - d.z * e2.y, d.z * e2.x - d.x * e2.z, d.x * e2.y - d.y * e2.x);
    precise float det = e1.x * p.x + e1.y * p.y + e1.z * p.z;
    t_out = 0.0;
    u_out = 0.0;
    v_out = 0.0;
    if (cull ? !(det >= DET_EPSILON) : !(abs(det) >= DET_EPSILON))
        return false;
    precise float inv_det = 1.0 / det;
    precise vec3 s = vec3(o.x - v0.x, o.y - v0.y, o.z - v0.z);
    precise float u = (s.x * p.x + s.y * p.y + s.z * p.z) * inv_det;
    if (!(u >= 0.0 && u <= 1.0))
        return false;
    precise vec3 q = vec3(s.y * e1.z - s.z * e1.y, s.z * e1.x - s.x * e1.z, s.x * e1.y - s.y * e1.x);
    precise float v = (d.x * q.x + d.y * q.y + d.z * q.z) * inv_det;
    precise float uv = u + v;
    if (!(v >= 0.0 && uv <= 1.0))
        return false;
    precise float t = (e2.x * q.x + e2.y * q.y + e2.z * q.z) * inv_det;
    if (!(t >= tmin && t < tmax))
        return false;
    t_out = t;
    u_out = u;
    v_out = v;
    return true;
}

// Tests a leaf's triangles; true when the search may stop (an any-hit found).
bool leaf_hit(uint first, uint count) {
    if (first >= pc.triangle_count || count > pc.triangle_count - first)
        return false;
    for (uint k = first; k < first + count; k++) {
        float t, u, v;
        if (!tri_hit(k, t, u, v))
            continue;
        tmax = t;
        best_tri = k;
        best_t = t;
        best_u = u;
        best_v = v;
        if (any_hit)
            return true;
    }
    return false;
}

// An interior child must come after its parent and exist.
bool valid_child(uint link, uint parent) { return link > parent && link < pc.node_count; }

void traverse() {
    uint stack_node[STACK_SIZE];
    float stack_tnear[STACK_SIZE];
    uint top = 0u, node = 0u;
    for (;;) {
        Node2 n = load_node(node);
        float ta, tb;
        bool ha = box_hit(n.a_min, n.a_max, ta);
        bool hb = box_hit(n.b_min, n.b_max, tb);
        if (ha && (n.a_link & LEAF_BIT) != 0u) {
            if (leaf_hit(n.a_link & ~LEAF_BIT, n.a_count))
                return;
            ha = false;
        }
        if (hb && (n.b_link & LEAF_BIT) != 0u) {
            if (leaf_hit(n.b_link & ~LEAF_BIT, n.b_count))
                return;
            hb = false;
        }
        ha = ha && valid_child(n.a_link, node);
        hb = hb && valid_child(n.b_link, node);
        if (ha && hb && top < STACK_SIZE) {
            bool a_first = ta <= tb;
            stack_node[top] = a_first ? n.b_link : n.a_link;
            stack_tnear[top] = a_first ? tb : ta;
            top++;
            node = a_first ? n.a_link : n.b_link;
            continue;
        }
        if (ha) {
            node = n.a_link;
            continue;
        }
        if (hb) {
            node = n.b_link;
            continue;
        }
        do {
            if (top == 0u)
                return;
            top--;
        } while (stack_tnear[top] > tmax);
        node = stack_node[top];
    }
}

void main() {
    uint i = (gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x) * gl_WorkGroupSize.x +
             gl_LocalInvocationID.x;
    if (i >= pc.count)
        return;
    Ray ray = pc.rays.rays[i];
    o = ray.origin;
    d = ray.dir;
    for (int k = 0; k < 3; k++) {
        bool negative = (floatBitsToUint(d[k]) & 0x80000000u) != 0u;   // copysign
        float dk = abs(d[k]) < MIN_DIR ? (negative ? -MIN_DIR : MIN_DIR) : d[k];
        precise float r = 1.0 / dk;
        inv[k] = r;
    }
    tmin = ray.tmin;
    tmax = ray.tmax;
    cull = (pc.flags & TRACE_CULL_BACK_FACES) != 0u;
    any_hit = (pc.flags & TRACE_ANY_HIT) != 0u;
    best_tri = TRACE_INVALID;
    if (pc.node_count > 0u)
        traverse();
    Hit h = trace_miss();
    if (best_tri != TRACE_INVALID) {
        Tri tri = load_triangle(best_tri);
        h = Hit(best_t, best_u, best_v, tri.prim, tri.instance);
    }
    pc.hits.hits[i] = h;
}
