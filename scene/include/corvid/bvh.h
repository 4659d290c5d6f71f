/* BVH construction on the CPU: binned-SAH trees written straight into the GPU
 * layouts of bvh_gpu.h.
 *
 * Two shapes of acceleration structure:
 *  - cv_bvh, flat: one BVH over every world-space triangle of the scene
 *    (instances baked in). The simplest GPU path, and the one benchmarked
 *    against Embree.
 *  - cv_scene_bvh, two-level: one bottom-level BVH (BLAS) per mesh in object
 *    space, and a top-level BVH (TLAS) over the instances' world boxes. Moving
 *    instances needs only cv_scene_bvh_rebuild_top; deforming a mesh (same
 *    topology) needs cv_scene_bvh_refit_mesh.
 *
 * The builder: binned surface area heuristic (centroid bounds, bin_count bins
 * per axis, all three axes), cost = traversal_cost + intersection_cost *
 * (A_left N_left + A_right N_right) / A_parent against a leaf's
 * intersection_cost * N; leaves hold at most max_leaf_size primitives;
 * primitives whose centroids coincide, and nodes that would otherwise go
 * deeper than CV_BVH_MAX_DEPTH, are halved by count. Once a node is split its
 * two subtrees are independent tasks picked up by a pool of threads (trees
 * over fewer than 16384 primitives are built on one thread; the BLASes of
 * small meshes are built side by side). The output depends only on the input
 * and the options, never on the thread count or timing.
 *
 * The structs below are read-only views for uploaders and tracers: upload the
 * arrays as they are (bvh_gpu.h documents every byte). */
#ifndef CORVID_BVH_H
#define CORVID_BVH_H

#include <stdint.h>
#include "corvid/bvh_gpu.h"
#include "corvid/result.h"
#include "corvid/scene.h"

/* Zero fields take the defaults in brackets. */
typedef struct cv_bvh_build_options {
    uint32_t bin_count;      /* [16] 2..64 bins per axis */
    uint32_t max_leaf_size;  /* [8] 1..CV_BVH_MAX_LEAF_SIZE primitives per leaf */
    float traversal_cost;    /* [1.0] cost of visiting a node */
    float intersection_cost; /* [1.0] cost of one primitive test */
    uint32_t thread_count;   /* [all online CPUs] */
} cv_bvh_build_options;

/* Shape and quality of one tree, from cv_bvh_check / cv_scene_bvh_check. */
typedef struct cv_bvh_report {
    uint32_t node_count; /* skip-layout nodes (interior + leaves) */
    uint32_t leaf_count;
    uint32_t primitive_count;
    uint32_t max_depth;     /* root = depth 0 */
    uint32_t max_leaf_size; /* largest leaf found */
    double sah_cost;        /* expected cost of a random ray that hits the root box,
                                   with the build's traversal and intersection costs */
} cv_bvh_report;

/* Flat BVH over all world-space triangles. Triangles with zero area are kept
 * (they are never hit). */
typedef struct cv_bvh {
    cv_bvh_node *nodes; /* skip layout, root at 0 */
    uint32_t node_count;
    cv_bvh_node2 *nodes2; /* two-child layout, root at 0 */
    uint32_t node2_count;
    cv_bvh_tri *tris; /* leaf order; prim = mesh triangle, instance = scene instance */
    uint32_t tri_count;
    cv_bvh_build_options options; /* as used, defaults filled in */
} cv_bvh;

cv_result cv_bvh_build_flat(const cv_scene *scene, const cv_bvh_build_options *options, cv_bvh **out);
void cv_bvh_destroy(cv_bvh *bvh); /* NULL is allowed */

/* Where one mesh's BLAS lives in the concatenated arrays of a cv_scene_bvh. */
typedef struct cv_bvh_blas_range {
    uint32_t node_first, node_count;   /* in blas_nodes; the root is node_first */
    uint32_t node2_first, node2_count; /* in blas_nodes2; the root is node2_first */
    uint32_t tri_first, tri_count;     /* in blas_tris */
} cv_bvh_blas_range;

typedef struct cv_scene_bvh {
    cv_bvh_node *blas_nodes; /* all BLASes, skip layout, absolute indices */
    uint32_t blas_node_count;
    cv_bvh_node2 *blas_nodes2; /* all BLASes, two-child layout, absolute indices */
    uint32_t blas_node2_count;
    cv_bvh_tri *blas_tris; /* object space, instance = CV_BVH_INVALID */
    uint32_t blas_tri_count;
    cv_bvh_blas_range *meshes; /* one per scene mesh */
    uint32_t mesh_count;
    cv_bvh_node *tlas_nodes; /* skip layout over instance records, root at 0 */
    uint32_t tlas_node_count;
    cv_bvh_node2 *tlas_nodes2; /* two-child layout, root at 0 */
    uint32_t tlas_node2_count;
    cv_bvh_instance *instances; /* leaf order */
    uint32_t instance_count;
    cv_bvh_build_options options;
} cv_scene_bvh;

/* Builds every BLAS and the TLAS. A scene without instances gets an empty TLAS
 * (tlas_node_count 0: every ray misses). */
cv_result cv_scene_bvh_build(const cv_scene *scene, const cv_bvh_build_options *options, cv_scene_bvh **out);
/* Rebuilds the TLAS from the scene's current instances (their number may have
 * changed). Fails with CV_ERROR_BAD_STATE if the meshes no longer match the
 * BLASes (added meshes or changed triangle counts): build anew then. */
cv_result cv_scene_bvh_rebuild_top(cv_scene_bvh *bvh, const cv_scene *scene);
/* Refits the BLAS of `mesh` to its current positions (boxes recomputed bottom
 * up, tree unchanged), then rebuilds the TLAS. */
cv_result cv_scene_bvh_refit_mesh(cv_scene_bvh *bvh, const cv_scene *scene, uint32_t mesh);
void cv_scene_bvh_destroy(cv_scene_bvh *bvh); /* NULL is allowed */

/* Checks the invariants of both node layouts against the triangles: every
 * triangle in exactly one leaf, every triangle box inside its leaf box, every
 * child box inside its parent box, leaves no larger than the build's limit,
 * skip links and child links well formed, both layouts describing the same
 * leaves. On success fills *report (may be NULL); on failure returns
 * CV_ERROR_MALFORMED saying which node and which rule. */
cv_result cv_bvh_check(const cv_bvh *bvh, cv_bvh_report *report);
/* The same for every BLAS and for the TLAS (instance world boxes inside their
 * leaves, every instance exactly once). Reports the TLAS, and the BLASes summed
 * (sah_cost: triangle-weighted mean of the BLAS costs), either may be NULL. */
cv_result cv_scene_bvh_check(const cv_scene_bvh *bvh, const cv_scene *scene, cv_bvh_report *tlas_report,
                             cv_bvh_report *blas_report);

/* The traversal record of one triangle (e1, e2 and the bounds computed as the
 * builders do). */
cv_bvh_tri cv_bvh_tri_make(const float v[3][3], uint32_t prim, uint32_t instance);

#endif
