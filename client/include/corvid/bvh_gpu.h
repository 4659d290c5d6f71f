/* The BVH as the GPU reads it: std430-compatible structs, shared by the CPU
 * builder (bvh.h), the CPU reference traversal (trace_cpu.h) and the GLSL
 * compute kernels, which declare the same structs member for member. A wire
 * contract: accel data crosses the API (cv_accel_write) and the node protocol
 * in these layouts, so it lives with the client's data contracts (DESIGN.md).
 *
 * Every struct below is made of 16-byte rows "vec3 + 4-byte scalar" (std430
 * packs a scalar right after a vec3), or of scalars only, so the C layout and
 * the std430 layout are identical. Offsets are in bytes; the static asserts at
 * the end pin them.
 *
 * Two node layouts describe the same tree (same leaves, same triangle ranges),
 * and both index the same triangle array:
 *
 * 1. cv_bvh_node: "skip" layout, 32 bytes (seed 001). Nodes are stored in
 *    depth-first order, left child first, so an interior node's left child is
 *    the next node and its right child follows the whole left subtree. Each
 *    node holds the index of the node to visit when its box is missed (or when
 *    it is a leaf that was processed): the first node after its subtree, or -1
 *    at the end of the tree. Stackless traversal:
 *
 *        int i = root;
 *        while (i != -1) {
 *            cv_bvh_node n = nodes[i];
 *            if (!hit_box(n.bmin, n.bmax)) { i = n.skip; continue; }
 *            if (n.info != CV_BVH_INTERIOR) { test leaf triangles; i = n.skip; }
 *            else i = i + 1;
 *        }
 *
 *      offset  0  float bmin[3]
 *      offset 12  uint  info   CV_BVH_INTERIOR (0xFFFFFFFF) for an interior node;
 *                              for a leaf: bits 0..27 first primitive index,
 *                              bits 28..31 primitive count - 1 (1..16 primitives)
 *      offset 16  float bmax[3]
 *      offset 28  int   skip   next node index on miss or after a leaf; -1 = done
 *
 * 2. cv_bvh_node2: "two-child" layout, 64 bytes, for traversal with a stack and
 *    near-child-first ordering. One node per interior node of the tree, in
 *    depth-first order (root first); each stores both children's boxes so one
 *    fetch tests two boxes. A child link with CV_BVH_LEAF_BIT set is a leaf
 *    (bits 0..30: first primitive; count: number of primitives, 0 for the empty
 *    second child of a tree that is a single leaf); otherwise it is the index of
 *    the child's cv_bvh_node2 and count is 0. Children always have larger
 *    indices than their parent (bottom-up refits run in reverse order).
 *    The reference traversal (trace_cpu.c): test both boxes; intersect a hit
 *    leaf child at once (a, then b); of the hit interior children visit the
 *    one with the smaller entry distance (a on ties) and push the other with
 *    its entry distance; pop, skipping entries farther than the current hit.
 *
 *      offset  0  float a_min[3]    offset 12  uint a_link
 *      offset 16  float a_max[3]    offset 28  uint a_count
 *      offset 32  float b_min[3]    offset 44  uint b_link
 *      offset 48  float b_max[3]    offset 60  uint b_count
 *
 * Triangles (cv_bvh_tri, 48 bytes) are stored in leaf order, so a leaf covers a
 * contiguous range [first, first + count). Each holds what the intersection
 * needs and the ids a hit reports:
 *
 *      offset  0  float v0[3]       offset 12  uint prim      triangle index in its mesh
 *      offset 16  float e1[3]       offset 28  uint instance  scene instance index
 *                                                             (CV_BVH_INVALID in a
 *                                                             two-level BLAS)
 *      offset 32  float e2[3]       offset 44  uint pad       0
 *
 *    with e1 = v1 - v0 and e2 = v2 - v0 (float subtraction), world space in a
 *    flat BVH, object space in a BLAS.
 *
 * Two-level BVHs (bvh.h, cv_scene_bvh) use the same node layouts for both
 * levels. Bottom levels (one per mesh) are concatenated into one node array
 * and one triangle array with absolute indices (skip links and leaf ranges
 * point into the concatenated arrays; each BLAS ends with skip -1). Top-level
 * leaves index instance records (cv_bvh_instance, 64 bytes) stored in leaf
 * order:
 *
 *      offset  0  float world_to_object[3][4]   row-major, rows at 0, 16, 32
 *      offset 48  uint  blas_root    root of the mesh's BLAS in the skip-layout array
 *      offset 52  uint  blas_root2   root of the mesh's BLAS in the two-child array
 *      offset 56  uint  instance     scene instance index (reported in hits)
 *      offset 60  uint  mesh         scene mesh index
 *
 *    A ray enters a BLAS transformed by world_to_object (origin as a point,
 *    direction by the 3x3 part, not renormalized), so t keeps its meaning
 *    (the world ray's parameter) and tmin/tmax carry over unchanged.
 *
 * Rays and hits (batch tracing, here so GPU kernels can share buffers):
 *
 *    cv_ray, 32 bytes:  offset 0 float origin[3], 12 float tmin,
 *                       offset 16 float dir[3],   28 float tmax
 *    cv_hit, 20 bytes (std430 array stride 20, alignment 4):
 *                       0 float t, 4 float u, 8 float v, 12 uint triangle, 16 uint instance
 *
 * Ray-triangle and ray-box rules (the GLSL side must match them):
 *  - A triangle is hit at t when tmin <= t < tmax (closest-hit tracing then
 *    lowers tmax to t, so among equal t the first triangle found is kept).
 *  - Moller-Trumbore on (v0, e1, e2): p = cross(dir, e2), det = dot(e1, p);
 *    det > 0 is a front face (counter-clockwise seen from the ray). |det| <
 *    CV_BVH_DET_EPSILON (or det < CV_BVH_DET_EPSILON with back-face culling)
 *    is a miss. Then inv = 1 / det, s = origin - v0, u = dot(s, p) * inv,
 *    q = cross(s, e1), v = dot(dir, q) * inv, t = dot(e2, q) * inv; a hit
 *    needs u >= 0, v >= 0, u + v <= 1, with no epsilon (an edge shared by two
 *    triangles may report either). Position = v0 + u * e1 + v * e2.
 *  - Ray-box: slab test with inv_dir = 1 / dir, where a direction component
 *    with |d| < CV_BVH_MIN_DIR is first replaced by copysign(CV_BVH_MIN_DIR, d)
 *    (no inf * 0 = NaN); with t0 = (bmin - origin) * inv_dir and t1 = (bmax -
 *    origin) * inv_dir per axis, tnear = max over axes of min(t0, t1) and tfar
 *    = min over axes of max(t0, t1), the box is hit when max(tnear, tmin) <=
 *    min(tfar * CV_BVH_TFAR_SCALE, tmax), tmax being the current closest hit.
 *    The scale (1 + 2 * gamma(3), Ize 2013) keeps rounding in the slab test
 *    from missing a box the ray touches.
 *  - Triangle boxes are the float bounds of v0, v0 + e1 and v0 + e2, widened
 *    by one ulp outward, so the exact triangle that the intersection sees is
 *    inside (bounds within 1e-30 of zero widen to -1e-30 / +1e-30 instead,
 *    keeping denormals out of the boxes).
 *    Instance boxes are widened by CV_BVH_INSTANCE_PAD relative to their size
 *    and position to cover rounding in the world-to-object transform. */
#ifndef CORVID_BVH_GPU_H
#define CORVID_BVH_GPU_H

#include <stddef.h>
#include <stdint.h>

#define CV_BVH_INTERIOR 0xFFFFFFFFu
#define CV_BVH_INVALID 0xFFFFFFFFu
#define CV_BVH_LEAF_BIT 0x80000000u
#define CV_BVH_LEAF_FIRST_MASK 0x0FFFFFFFu
#define CV_BVH_LEAF_COUNT_SHIFT 28
#define CV_BVH_MAX_LEAF_SIZE 16u
#define CV_BVH_MAX_PRIMITIVES (CV_BVH_LEAF_FIRST_MASK + 1u) /* 2^28 per array */
/* Deepest leaf of any tree (root = depth 0): the builder halves by count
 * where needed to stay within it, so a traversal stack of CV_BVH_MAX_DEPTH
 * entries per level always suffices (two-level: one such stack per level). */
#define CV_BVH_MAX_DEPTH 64u

#define CV_BVH_DET_EPSILON 1e-24f
#define CV_BVH_MIN_DIR 1e-20f
#define CV_BVH_TFAR_SCALE 1.00000036f
#define CV_BVH_INSTANCE_PAD 1e-6f

typedef struct cv_bvh_node {
    float bmin[3];
    uint32_t info;
    float bmax[3];
    int32_t skip;
} cv_bvh_node;

typedef struct cv_bvh_node2 {
    float a_min[3];
    uint32_t a_link;
    float a_max[3];
    uint32_t a_count;
    float b_min[3];
    uint32_t b_link;
    float b_max[3];
    uint32_t b_count;
} cv_bvh_node2;

typedef struct cv_bvh_tri {
    float v0[3];
    uint32_t prim;
    float e1[3];
    uint32_t instance;
    float e2[3];
    uint32_t pad;
} cv_bvh_tri;

typedef struct cv_bvh_instance {
    float world_to_object[3][4];
    uint32_t blas_root;
    uint32_t blas_root2;
    uint32_t instance;
    uint32_t mesh;
} cv_bvh_instance;

typedef struct cv_ray {
    float origin[3];
    float tmin;
    float dir[3];
    float tmax;
} cv_ray;

typedef struct cv_hit {
    float t;           /* INFINITY on a miss */
    float u, v;        /* barycentrics (0 on a miss) */
    uint32_t triangle; /* triangle index in its mesh; CV_BVH_INVALID on a miss */
    uint32_t instance; /* scene instance index; CV_BVH_INVALID on a miss */
} cv_hit;

/* Leaf info of the skip layout. */
static inline uint32_t cv_bvh_leaf_info(uint32_t first, uint32_t count) {
    return first | ((count - 1u) << CV_BVH_LEAF_COUNT_SHIFT);
}
static inline uint32_t cv_bvh_leaf_first(uint32_t info) { return info & CV_BVH_LEAF_FIRST_MASK; }
static inline uint32_t cv_bvh_leaf_count(uint32_t info) { return (info >> CV_BVH_LEAF_COUNT_SHIFT) + 1u; }

_Static_assert(sizeof(cv_bvh_node) == 32, "cv_bvh_node is 32 bytes in std430");
_Static_assert(offsetof(cv_bvh_node, info) == 12 && offsetof(cv_bvh_node, bmax) == 16 &&
                   offsetof(cv_bvh_node, skip) == 28,
               "cv_bvh_node offsets");
_Static_assert(sizeof(cv_bvh_node2) == 64, "cv_bvh_node2 is 64 bytes in std430");
_Static_assert(offsetof(cv_bvh_node2, a_link) == 12 && offsetof(cv_bvh_node2, a_count) == 28 &&
                   offsetof(cv_bvh_node2, b_min) == 32 && offsetof(cv_bvh_node2, b_link) == 44 &&
                   offsetof(cv_bvh_node2, b_max) == 48 && offsetof(cv_bvh_node2, b_count) == 60,
               "cv_bvh_node2 offsets");
_Static_assert(sizeof(cv_bvh_tri) == 48, "cv_bvh_tri is 48 bytes in std430");
_Static_assert(offsetof(cv_bvh_tri, prim) == 12 && offsetof(cv_bvh_tri, e1) == 16 &&
                   offsetof(cv_bvh_tri, instance) == 28 && offsetof(cv_bvh_tri, e2) == 32,
               "cv_bvh_tri offsets");
_Static_assert(sizeof(cv_bvh_instance) == 64, "cv_bvh_instance is 64 bytes in std430");
_Static_assert(offsetof(cv_bvh_instance, blas_root) == 48 && offsetof(cv_bvh_instance, instance) == 56,
               "cv_bvh_instance offsets");
_Static_assert(sizeof(cv_ray) == 32 && offsetof(cv_ray, tmin) == 12 && offsetof(cv_ray, dir) == 16 &&
                   offsetof(cv_ray, tmax) == 28,
               "cv_ray layout");
_Static_assert(sizeof(cv_hit) == 20 && offsetof(cv_hit, triangle) == 12 && offsetof(cv_hit, instance) == 16,
               "cv_hit layout");

#endif
