/* From the builder's tree to the GPU layouts of bvh_gpu.h, and the box
 * rules every BVH shares: triangle boxes, instance boxes, bottom-up refits. */
#ifndef CORVID_SCENE_BVH_LAYOUT_H
#define CORVID_SCENE_BVH_LAYOUT_H

#include <stdint.h>
#include "bvh_builder.h"

/* Box of the triangle the intersection test sees (v0, v0 + e1, v0 + e2 in
 * exact arithmetic): the float corners widened by one ulp. */
void cvs_tri_bounds(const cv_bvh_tri *t, float min[3], float max[3]);

/* World box of an instance whose object-space box is (omin, omax): its eight
 * corners transformed, widened by CV_BVH_INSTANCE_PAD. */
void cvs_instance_bounds(const float object_to_world[3][4], const float omin[3], const float omax[3], float min[3],
                         float max[3]);

/* Node counts of the two layouts for a tree. */
uint32_t cvs_layout_node_count(const cvs_tree *tree);
uint32_t cvs_layout_node2_count(const cvs_tree *tree);

/* Writes the tree in both layouts: out_nodes[0 .. node_count) and
 * out_nodes2[0 .. node2_count), where links are offset by node_base /
 * node2_base (the arrays' positions in a concatenated buffer) and leaf ranges
 * by prim_base. Fails only on allocation. */
cv_result cvs_layout_emit(const cvs_tree *tree, cv_bvh_node *out_nodes, uint32_t node_base, cv_bvh_node2 *out_nodes2,
                          uint32_t node2_base, uint32_t prim_base);

/* Recomputes the boxes of one tree stored at nodes[first .. first + count)
 * and nodes2[first2 .. first2 + count2) (absolute links) from its triangles
 * tris[] (absolute leaf ranges), children before parents. */
void cvs_layout_refit(cv_bvh_node *nodes, uint32_t first, uint32_t count, cv_bvh_node2 *nodes2, uint32_t first2,
                      uint32_t count2, const cv_bvh_tri *tris);

#endif
