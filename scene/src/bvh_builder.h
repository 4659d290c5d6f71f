/* The binned-SAH tree builder shared by every BVH (flat, BLAS, TLAS): it sees
 * only primitive boxes and ids, and produces an intermediate binary tree that
 * bvh_layout.h turns into the GPU layouts.
 *
 * Tree nodes are allocated as sibling pairs by whichever thread splits their
 * parent, so node indices vary between runs; the tree's shape, its leaves and
 * the primitive order do not (each split depends only on the primitives in
 * the node), and the emitted layouts are numbered from the shape alone.
 * A child's index is always larger than its parent's. */
#ifndef CORVID_SCENE_BVH_BUILDER_H
#define CORVID_SCENE_BVH_BUILDER_H

#include <stdint.h>
#include "corvid/bvh.h"

/* Trees over fewer primitives are built on the calling thread alone. */
#define CVS_BVH_PARALLEL_MIN 16384u

typedef struct cvs_prim_ref {
    float min[3];
    uint32_t id;
    float max[3];
    uint32_t pad;
} cvs_prim_ref;

typedef struct cvs_tree_node {
    float min[3];
    uint32_t index; /* interior: left child (right = index + 1); leaf: first primitive */
    float max[3];
    uint32_t count; /* leaf: primitive count (>= 1); interior: 0 */
} cvs_tree_node;

typedef struct cvs_tree {
    cvs_tree_node *nodes; /* root at 0 */
    uint32_t node_count;
    uint32_t *prim_ids; /* ids in leaf order; a leaf covers [index, index + count) */
    uint32_t prim_count;
} cvs_tree;

/* Options with defaults filled in; CV_ERROR_INVALID_ARGUMENT for a value out of range. */
cv_result cvs_bvh_options_resolve(const cv_bvh_build_options *in, cv_bvh_build_options *out);

/* Builds a tree over refs[0..count) (reordered in place; count may be 0, giving
 * an empty tree). Fails only on allocation (CV_ERROR_OUT_OF_MEMORY). */
cv_result cvs_tree_build(cvs_prim_ref *refs, uint32_t count, const cv_bvh_build_options *opt, cvs_tree *out);
void cvs_tree_free(cvs_tree *tree);

/* Surface-area measure used by the SAH (half the box's surface area). */
static inline float cvs_half_area(const float min[3], const float max[3]) {
    float dx = max[0] - min[0], dy = max[1] - min[1], dz = max[2] - min[2];
    return dx * dy + dy * dz + dz * dx;
}

#endif
