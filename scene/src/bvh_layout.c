/* Tree to GPU layouts. Both layouts number nodes in depth-first order, left
 * child first, computed from subtree sizes, so the output depends only on
 * the tree's shape (not on the builder's node numbering). */
#include "bvh_layout.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* The next float toward -inf / +inf (finite inputs). Within 1e-30 of zero
 * the bound moves to -1e-30 / +1e-30 instead: the next float after 0 is a
 * denormal, and denormal box coordinates make every slab test of a ray
 * starting on such a plane (a floor at y = 0) take a microcode assist,
 * ~100x slower on x86. */
static inline float ulp_down(float x) {
    if (fabsf(x) < 1e-30f)
        return -1e-30f;
    uint32_t u;
    memcpy(&u, &x, 4);
    u = x > 0.0f ? u - 1 : u + 1;
    memcpy(&x, &u, 4);
    return x;
}

static inline float ulp_up(float x) { return -ulp_down(-x); }

void cvs_tri_bounds(const cv_bvh_tri *t, float min[3], float max[3]) {
    for (int k = 0; k < 3; k++) {
        float a = t->v0[k], b = t->v0[k] + t->e1[k], c = t->v0[k] + t->e2[k];
        float lo = a < b ? a : b, hi = a > b ? a : b;
        lo = c < lo ? c : lo;
        hi = c > hi ? c : hi;
        min[k] = ulp_down(lo);
        max[k] = ulp_up(hi);
    }
}

void cvs_instance_bounds(const float m[3][4], const float omin[3], const float omax[3], float min[3], float max[3]) {
    for (int k = 0; k < 3; k++) {
        min[k] = INFINITY;
        max[k] = -INFINITY;
    }
    for (int c = 0; c < 8; c++) {
        const float p[3] = { (c & 1) ? omax[0] : omin[0], (c & 2) ? omax[1] : omin[1], (c & 4) ? omax[2] : omin[2] };
        for (int k = 0; k < 3; k++) {
            float w = m[k][0] * p[0] + m[k][1] * p[1] + m[k][2] * p[2] + m[k][3];
            min[k] = w < min[k] ? w : min[k];
            max[k] = w > max[k] ? w : max[k];
        }
    }
    for (int k = 0; k < 3; k++) {
        float pad = CV_BVH_INSTANCE_PAD * (max[k] - min[k] + fabsf(min[k]) + fabsf(max[k]));
        min[k] -= pad;
        max[k] += pad;
    }
}

uint32_t cvs_layout_node_count(const cvs_tree *tree) { return tree->node_count; }

uint32_t cvs_layout_node2_count(const cvs_tree *tree) {
    return tree->node_count <= 1 ? tree->node_count : (tree->node_count - 1) / 2;
}

/* Node count of every subtree; children have larger indices than parents,
 * so one reverse pass suffices. */
static uint32_t *subtree_sizes(const cvs_tree *tree) {
    uint32_t *size = malloc((size_t)tree->node_count * sizeof(uint32_t));
    if (!size)
        return NULL;
    for (uint32_t i = tree->node_count; i-- > 0;) {
        const cvs_tree_node *n = &tree->nodes[i];
        size[i] = n->count ? 1 : 1 + size[n->index] + size[n->index + 1];
    }
    return size;
}

typedef struct slot {
    uint32_t node, out;
} slot;

static void emit_skip(const cvs_tree *tree, const uint32_t *size, cv_bvh_node *out, uint32_t node_base,
                      uint32_t prim_base) {
    slot stack[CV_BVH_MAX_DEPTH + 2];
    uint32_t top = 0, total = size[0];
    stack[top++] = (slot){ 0, 0 };
    while (top > 0) {
        slot s = stack[--top];
        const cvs_tree_node *n = &tree->nodes[s.node];
        cv_bvh_node *o = &out[s.out];
        memcpy(o->bmin, n->min, sizeof o->bmin);
        memcpy(o->bmax, n->max, sizeof o->bmax);
        uint32_t next = s.out + size[s.node];
        o->skip = next == total ? -1 : (int32_t)(node_base + next);
        if (n->count) {
            o->info = cv_bvh_leaf_info(prim_base + n->index, n->count);
        } else {
            o->info = CV_BVH_INTERIOR;
            stack[top++] = (slot){ n->index + 1, s.out + 1 + size[n->index] };
            stack[top++] = (slot){ n->index, s.out + 1 };
        }
    }
}

/* One child of a two-child node: its box and link. */
static void emit_child(const cvs_tree_node *c, uint32_t interior_index, uint32_t prim_base, float min[3],
                       float max[3], uint32_t *link, uint32_t *count) {
    memcpy(min, c->min, 3 * sizeof(float));
    memcpy(max, c->max, 3 * sizeof(float));
    if (c->count) {
        *link = CV_BVH_LEAF_BIT | (prim_base + c->index);
        *count = c->count;
    } else {
        *link = interior_index;
        *count = 0;
    }
}

static void emit_node2(const cvs_tree *tree, const uint32_t *size, cv_bvh_node2 *out, uint32_t node2_base,
                       uint32_t prim_base) {
    const cvs_tree_node *root = &tree->nodes[0];
    if (root->count) {
        /* A single leaf: it becomes child a; child b is an empty leaf. */
        emit_child(root, 0, prim_base, out[0].a_min, out[0].a_max, &out[0].a_link, &out[0].a_count);
        memcpy(out[0].b_min, root->min, sizeof out[0].b_min);
        memcpy(out[0].b_max, root->max, sizeof out[0].b_max);
        out[0].b_link = CV_BVH_LEAF_BIT | (prim_base + root->index);
        out[0].b_count = 0;
        return;
    }
    slot stack[CV_BVH_MAX_DEPTH + 2];
    uint32_t top = 0;
    stack[top++] = (slot){ 0, 0 };
    while (top > 0) {
        slot s = stack[--top];
        const cvs_tree_node *n = &tree->nodes[s.node];
        const cvs_tree_node *l = &tree->nodes[n->index], *r = &tree->nodes[n->index + 1];
        cv_bvh_node2 *o = &out[s.out];
        uint32_t l_out = s.out + 1, r_out = s.out + 1 + (size[n->index] - 1) / 2;
        emit_child(l, node2_base + l_out, prim_base, o->a_min, o->a_max, &o->a_link, &o->a_count);
        emit_child(r, node2_base + r_out, prim_base, o->b_min, o->b_max, &o->b_link, &o->b_count);
        if (!r->count)
            stack[top++] = (slot){ n->index + 1, r_out };
        if (!l->count)
            stack[top++] = (slot){ n->index, l_out };
    }
}

cv_result cvs_layout_emit(const cvs_tree *tree, cv_bvh_node *out_nodes, uint32_t node_base, cv_bvh_node2 *out_nodes2,
                          uint32_t node2_base, uint32_t prim_base) {
    if (tree->node_count == 0)
        return CV_OK;
    uint32_t *size = subtree_sizes(tree);
    if (!size)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "BVH layout: no memory for %u subtree sizes", tree->node_count);
    emit_skip(tree, size, out_nodes, node_base, prim_base);
    emit_node2(tree, size, out_nodes2, node2_base, prim_base);
    free(size);
    return CV_OK;
}

static void tri_range_bounds(const cv_bvh_tri *tris, uint32_t first, uint32_t count, float min[3], float max[3]) {
    for (int k = 0; k < 3; k++) {
        min[k] = INFINITY;
        max[k] = -INFINITY;
    }
    for (uint32_t i = first; i < first + count; i++) {
        float tmin[3], tmax[3];
        cvs_tri_bounds(&tris[i], tmin, tmax);
        for (int k = 0; k < 3; k++) {
            min[k] = tmin[k] < min[k] ? tmin[k] : min[k];
            max[k] = tmax[k] > max[k] ? tmax[k] : max[k];
        }
    }
}

static void union_into(float min[3], float max[3], const float amin[3], const float amax[3], const float bmin[3],
                       const float bmax[3]) {
    for (int k = 0; k < 3; k++) {
        min[k] = amin[k] < bmin[k] ? amin[k] : bmin[k];
        max[k] = amax[k] > bmax[k] ? amax[k] : bmax[k];
    }
}

static void refit_child2(const cv_bvh_node2 *nodes2, const cv_bvh_tri *tris, uint32_t link, uint32_t count,
                         float min[3], float max[3]) {
    if (link & CV_BVH_LEAF_BIT) {
        if (count)
            tri_range_bounds(tris, link & ~CV_BVH_LEAF_BIT, count, min, max);
    } else {
        const cv_bvh_node2 *c = &nodes2[link];
        union_into(min, max, c->a_min, c->a_max, c->b_min, c->b_max);
    }
}

void cvs_layout_refit(cv_bvh_node *nodes, uint32_t first, uint32_t count, cv_bvh_node2 *nodes2, uint32_t first2,
                      uint32_t count2, const cv_bvh_tri *tris) {
    for (uint32_t i = first + count; i-- > first;) {
        cv_bvh_node *n = &nodes[i];
        if (n->info != CV_BVH_INTERIOR) {
            tri_range_bounds(tris, cv_bvh_leaf_first(n->info), cv_bvh_leaf_count(n->info), n->bmin, n->bmax);
        } else {
            const cv_bvh_node *l = &nodes[i + 1], *r = &nodes[l->skip];
            union_into(n->bmin, n->bmax, l->bmin, l->bmax, r->bmin, r->bmax);
        }
    }
    for (uint32_t i = first2 + count2; i-- > first2;) {
        cv_bvh_node2 *n = &nodes2[i];
        refit_child2(nodes2, tris, n->a_link, n->a_count, n->a_min, n->a_max);
        refit_child2(nodes2, tris, n->b_link, n->b_count, n->b_min, n->b_max);
        if (!(n->b_link & CV_BVH_LEAF_BIT) || n->b_count)
            continue;
        /* The empty child of a single-leaf tree keeps the leaf's box. */
        memcpy(n->b_min, n->a_min, sizeof n->b_min);
        memcpy(n->b_max, n->a_max, sizeof n->b_max);
    }
}

cv_bvh_tri cv_bvh_tri_make(const float v[3][3], uint32_t prim, uint32_t instance) {
    cv_bvh_tri t = { .prim = prim, .instance = instance, .pad = 0 };
    for (int k = 0; k < 3; k++) {
        t.v0[k] = v[0][k];
        t.e1[k] = v[1][k] - v[0][k];
        t.e2[k] = v[2][k] - v[0][k];
    }
    return t;
}
