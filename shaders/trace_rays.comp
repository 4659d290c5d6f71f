// The Vulkan backend's compute path for the trace_rays command: one ray per
// invocation against a flat BVH in the two-child layout of
// scene/include/corvid/bvh_gpu.h, with a stack and the nearer child first. It
// is the loop of tris_node2() in scene/src/trace_cpu.c, statement for
// statement, with the same ray-box and ray-triangle rules; every expression is
// `precise` so no multiply-add is fused and the arithmetic rounds as C's does.
// Malformed links (an interior child not after its parent, a leaf beyond the
// triangles) are treated as empty rather than followed.
// Push constants: { uint count; uint flags; uint node_count; uint triangle_count; }
// Bindings: 0 nodes, 1 triangles, 2 rays (read), 3 hits (written).
// Dispatch: 64 rays per group, groups laid out as x + y * num_groups_x.
#version 460
layout(local_size_x = 64, local_size_y = 1, local_size_z = 1) in;

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

layout(set = 0, binding = 0, std430) readonly buffer Nodes { Node2 nodes[]; };
layout(set = 0, binding = 1, std430) readonly buffer Tris { Tri tris[]; };
layout(set = 0, binding = 2, std430) readonly buffer Rays { Ray rays[]; };
layout(set = 0, binding = 3, std430) writeonly buffer Hits { Hit hits[]; };

layout(push_constant, std430) uniform Push {
    uint count;
    uint flags;
    uint node_count;
    uint triangle_count;
} pc;

const uint ANY_HIT = 1u;
const uint CULL_BACK_FACES = 2u;
const uint LEAF_BIT = 0x80000000u;
const uint INVALID = 0xFFFFFFFFu;
const float DET_EPSILON = 1e-24;
const float MIN_DIR = 1e-20;
const float TFAR_SCALE = 1.00000036;
const uint STACK_SIZE = 66u;   // CVS_BVH_MAX_DEPTH + 2

vec3 o, d, inv;
float tmin, tmax;
bool cull, any_hit;
uint best_tri;
float best_t, best_u, best_v;

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
    vec3 v0 = tris[k].v0, e1 = tris[k].e1, e2 = tris[k].e2;
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
        Node2 n = nodes[node];
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
    Ray ray = rays[i];
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
    cull = (pc.flags & CULL_BACK_FACES) != 0u;
    any_hit = (pc.flags & ANY_HIT) != 0u;
    best_tri = INVALID;
    if (pc.node_count > 0u)
        traverse();
    Hit h;
    if (best_tri == INVALID) {
        h.t = uintBitsToFloat(0x7F800000u);
        h.u = 0.0;
        h.v = 0.0;
        h.triangle = INVALID;
        h.instance = INVALID;
    } else {
        h.t = best_t;
        h.u = best_u;
        h.v = best_v;
        h.triangle = tris[best_tri].prim;
        h.instance = tris[best_tri].instance;
    }
    hits[i] = h;
}
