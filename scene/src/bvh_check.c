/* BVH invariant checks, read from the GPU arrays alone (what a kernel would
 * trust), plus the SAH cost of the tree. The skip layout is walked first and
 * its leaves listed; the two-child layout must list the same leaves in the
 * same order. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bvh_builder.h"
#include "bvh_layout.h"

typedef void (*prim_bounds_fn)(const void *ctx, uint32_t prim, float min[3], float max[3]);

typedef struct tree_view {
    const char *what; /* "flat BVH", "BLAS of mesh 3", "TLAS" */
    const cv_bvh_node *nodes;
    uint32_t node_first, node_count; /* absolute region of the skip layout */
    const cv_bvh_node2 *nodes2;
    uint32_t node2_first, node2_count;
    uint32_t prim_first, prim_count; /* absolute range of the primitive array */
    prim_bounds_fn bounds;
    const void *ctx;
    const cv_bvh_build_options *opt;
} tree_view;

typedef struct leaf {
    uint32_t first, count;
    const float *min, *max;
} leaf;

typedef struct walk {
    leaf *leaves;
    uint32_t leaf_count;
    uint8_t *seen; /* nodes (skip walk), then reused for node2s */
    uint8_t *prim_seen;
    uint32_t *stack;
    uint32_t *depth;
} walk;

static bool inside(const float imin[3], const float imax[3], const float omin[3], const float omax[3]) {
    for (int k = 0; k < 3; k++)
        if (!(imin[k] >= omin[k] && imax[k] <= omax[k]))
            return false;
    return true;
}

static cv_result check_leaf(const tree_view *v, walk *w, uint32_t first, uint32_t count, const float *min,
                            const float *max, const char *where, uint32_t node) {
    if (count > v->opt->max_leaf_size)
        return cv_error(CV_ERROR_MALFORMED, "%s: %s %u is a leaf of %u primitives, the limit is %u", v->what, where,
                        node, count, v->opt->max_leaf_size);
    if (first < v->prim_first || (uint64_t)first + count > (uint64_t)v->prim_first + v->prim_count)
        return cv_error(CV_ERROR_MALFORMED, "%s: %s %u covers primitives [%u, %u), outside [%u, %u)", v->what, where,
                        node, first, first + count, v->prim_first, v->prim_first + v->prim_count);
    for (uint32_t p = first; p < first + count; p++) {
        if (w->prim_seen[p - v->prim_first]++)
            return cv_error(CV_ERROR_MALFORMED, "%s: primitive %u is in more than one leaf (again in %s %u)", v->what,
                            p, where, node);
        float pmin[3], pmax[3];
        v->bounds(v->ctx, p, pmin, pmax);
        if (!inside(pmin, pmax, min, max))
            return cv_error(CV_ERROR_MALFORMED, "%s: primitive %u sticks out of the box of its leaf, %s %u", v->what,
                            p, where, node);
    }
    return CV_OK;
}

/* Skip layout: structure, containment, leaves; fills the report. */
static cv_result walk_skip(const tree_view *v, walk *w, cv_bvh_report *rep) {
    const uint32_t end = v->node_first + v->node_count;
    const cv_bvh_node *root = &v->nodes[v->node_first];
    if (root->skip != -1)
        return cv_error(CV_ERROR_MALFORMED, "%s: root node %u has skip %d, expected -1", v->what, v->node_first,
                        root->skip);
    double root_area = cvs_half_area(root->bmin, root->bmax), interior_area = 0.0, leaf_area = 0.0;
    uint32_t top = 0;
    w->stack[top] = v->node_first;
    w->depth[top++] = 0;
    w->seen[0] = 1;
    while (top > 0) {
        uint32_t i = w->stack[--top], depth = w->depth[top];
        const cv_bvh_node *n = &v->nodes[i];
        rep->node_count++;
        rep->max_depth = depth > rep->max_depth ? depth : rep->max_depth;
        if (n->info != CV_BVH_INTERIOR) {
            uint32_t first = cv_bvh_leaf_first(n->info), count = cv_bvh_leaf_count(n->info);
            int32_t next = i + 1 == end ? -1 : (int32_t)(i + 1);
            if (n->skip != next)
                return cv_error(CV_ERROR_MALFORMED, "%s: leaf node %u has skip %d, expected %d", v->what, i, n->skip,
                                next);
            cv_result r = check_leaf(v, w, first, count, n->bmin, n->bmax, "node", i);
            if (r != CV_OK)
                return r;
            w->leaves[w->leaf_count++] = (leaf){ first, count, n->bmin, n->bmax };
            rep->leaf_count++;
            rep->max_leaf_size = count > rep->max_leaf_size ? count : rep->max_leaf_size;
            leaf_area += (double)count * cvs_half_area(n->bmin, n->bmax);
            continue;
        }
        interior_area += cvs_half_area(n->bmin, n->bmax);
        uint32_t left = i + 1;
        if (left >= end)
            return cv_error(CV_ERROR_MALFORMED, "%s: interior node %u is the last node", v->what, i);
        int32_t right = v->nodes[left].skip;
        if (right < (int32_t)v->node_first || (uint32_t)right >= end)
            return cv_error(CV_ERROR_MALFORMED,
                            "%s: right child of node %u (skip of node %u) is %d, outside the tree", v->what, i, left,
                            right);
        if (v->nodes[right].skip != n->skip)
            return cv_error(CV_ERROR_MALFORMED, "%s: node %u skips to %d but its right child %d skips to %d", v->what,
                            i, n->skip, right, v->nodes[right].skip);
        const uint32_t kids[2] = { (uint32_t)right, left };
        for (int k = 0; k < 2; k++) {
            const cv_bvh_node *c = &v->nodes[kids[k]];
            if (!inside(c->bmin, c->bmax, n->bmin, n->bmax))
                return cv_error(CV_ERROR_MALFORMED, "%s: box of node %u is not inside its parent %u", v->what,
                                kids[k], i);
            if (w->seen[kids[k] - v->node_first]++)
                return cv_error(CV_ERROR_MALFORMED, "%s: node %u is reached twice", v->what, kids[k]);
            w->stack[top] = kids[k];
            w->depth[top++] = depth + 1;
        }
    }
    if (rep->node_count != v->node_count)
        return cv_error(CV_ERROR_MALFORMED, "%s: %u of %u nodes are reachable from the root", v->what,
                        rep->node_count, v->node_count);
    for (uint32_t p = 0; p < v->prim_count; p++)
        if (!w->prim_seen[p])
            return cv_error(CV_ERROR_MALFORMED, "%s: primitive %u is in no leaf", v->what, v->prim_first + p);
    rep->primitive_count = v->prim_count;
    rep->sah_cost = root_area > 0.0
                        ? (v->opt->traversal_cost * interior_area + v->opt->intersection_cost * leaf_area) / root_area
                        : 0.0;
    return CV_OK;
}

/* Items of the two-child walk: a node, or a leaf child met in order. */
#define ITEM_LEAF 0x80000000u

static cv_result walk_node2(const tree_view *v, walk *w) {
    const uint32_t end = v->node2_first + v->node2_count;
    uint32_t expected = v->node_count == 1 ? 1 : (v->node_count - 1) / 2;
    if (v->node2_count != expected)
        return cv_error(CV_ERROR_MALFORMED, "%s: %u two-child nodes for %u skip nodes, expected %u", v->what,
                        v->node2_count, v->node_count, expected);
    memset(w->seen, 0, v->node2_count);
    uint32_t top = 0, leaf_index = 0;
    w->stack[top++] = v->node2_first;
    w->seen[0] = 1;
    /* Leaf items carry (node, child) as node * 2 + child. */
    while (top > 0) {
        uint32_t item = w->stack[--top];
        if (item & ITEM_LEAF) {
            uint32_t node = (item & ~ITEM_LEAF) / 2, child = item & 1;
            const cv_bvh_node2 *n = &v->nodes2[node];
            uint32_t link = child ? n->b_link : n->a_link, count = child ? n->b_count : n->a_count;
            const float *min = child ? n->b_min : n->a_min, *max = child ? n->b_max : n->a_max;
            if (count == 0) {
                if (v->node_count != 1 || !child)
                    return cv_error(CV_ERROR_MALFORMED, "%s: two-child node %u has an empty leaf child", v->what,
                                    node);
                continue;
            }
            const leaf *l = leaf_index < w->leaf_count ? &w->leaves[leaf_index] : NULL;
            leaf_index++;
            if (!l || l->first != (link & ~CV_BVH_LEAF_BIT) || l->count != count ||
                memcmp(l->min, min, 3 * sizeof(float)) || memcmp(l->max, max, 3 * sizeof(float)))
                return cv_error(CV_ERROR_MALFORMED,
                                "%s: leaf %u of the two-child layout (node %u) differs from the "
                                "skip layout's",
                                v->what, leaf_index - 1, node);
            continue;
        }
        const cv_bvh_node2 *n = &v->nodes2[item];
        const uint32_t links[2] = { n->a_link, n->b_link };
        const float *mins[2] = { n->a_min, n->b_min }, *maxs[2] = { n->a_max, n->b_max };
        for (int c = 1; c >= 0; c--) {
            if (links[c] & CV_BVH_LEAF_BIT) {
                w->stack[top++] = ITEM_LEAF | (item * 2 + (uint32_t)c);
                continue;
            }
            uint32_t k = links[c];
            if (k < v->node2_first || k >= end || k <= item)
                return cv_error(CV_ERROR_MALFORMED, "%s: two-child node %u links to %u, outside (%u, %u)", v->what,
                                item, k, item, end);
            if (w->seen[k - v->node2_first]++)
                return cv_error(CV_ERROR_MALFORMED, "%s: two-child node %u is reached twice", v->what, k);
            const cv_bvh_node2 *kid = &v->nodes2[k];
            if (!inside(kid->a_min, kid->a_max, mins[c], maxs[c]) ||
                !inside(kid->b_min, kid->b_max, mins[c], maxs[c]))
                return cv_error(CV_ERROR_MALFORMED,
                                "%s: a child box of two-child node %u is outside its box in node "
                                "%u",
                                v->what, k, item);
            w->stack[top++] = k;
        }
    }
    if (leaf_index != w->leaf_count)
        return cv_error(CV_ERROR_MALFORMED, "%s: the two-child layout has %u leaves, the skip layout %u", v->what,
                        leaf_index, w->leaf_count);
    return CV_OK;
}

static cv_result check_tree(const tree_view *v, cv_bvh_report *rep) {
    memset(rep, 0, sizeof *rep);
    if (v->node_count == 0) {
        if (v->prim_count || v->node2_count)
            return cv_error(CV_ERROR_MALFORMED, "%s: no nodes but %u primitives and %u two-child nodes", v->what,
                            v->prim_count, v->node2_count);
        return CV_OK;
    }
    size_t n = (size_t)v->node_count + 2;
    walk w = {
        .leaves = malloc(n * sizeof(leaf)),
        .seen = calloc(n, 1),
        .prim_seen = calloc((size_t)v->prim_count + 1, 1),
        .stack = malloc(2 * n * sizeof(uint32_t)),
        .depth = malloc(2 * n * sizeof(uint32_t)),
    };
    cv_result r;
    if (!w.leaves || !w.seen || !w.prim_seen || !w.stack || !w.depth)
        r = cv_error(CV_ERROR_OUT_OF_MEMORY, "%s: no memory to check %u nodes", v->what, v->node_count);
    else
        r = walk_skip(v, &w, rep);
    if (r == CV_OK)
        r = walk_node2(v, &w);
    free(w.leaves);
    free(w.seen);
    free(w.prim_seen);
    free(w.stack);
    free(w.depth);
    return r;
}

static void tri_bounds(const void *ctx, uint32_t prim, float min[3], float max[3]) {
    cvs_tri_bounds(&((const cv_bvh_tri *)ctx)[prim], min, max);
}

cv_result cv_bvh_check(const cv_bvh *bvh, cv_bvh_report *report) {
    if (!bvh)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_bvh_check: bvh is NULL");
    tree_view v = {
        .what = "flat BVH",
        .nodes = bvh->nodes,
        .node_count = bvh->node_count,
        .nodes2 = bvh->nodes2,
        .node2_count = bvh->node2_count,
        .prim_count = bvh->tri_count,
        .bounds = tri_bounds,
        .ctx = bvh->tris,
        .opt = &bvh->options,
    };
    cv_bvh_report rep;
    cv_result r = check_tree(&v, &rep);
    if (r == CV_OK && report)
        *report = rep;
    return r;
}

typedef struct tlas_ctx {
    const cv_scene_bvh *bvh;
    const cv_scene *scene;
} tlas_ctx;

static void instance_bounds(const void *ctx, uint32_t prim, float min[3], float max[3]) {
    const tlas_ctx *c = ctx;
    const cv_bvh_instance *rec = &c->bvh->instances[prim];
    const cv_bvh_node *root = &c->bvh->blas_nodes[c->bvh->meshes[rec->mesh].node_first];
    cvs_instance_bounds(cv_scene_instance(c->scene, rec->instance)->transform, root->bmin, root->bmax, min, max);
}

static cv_result check_instances(const cv_scene_bvh *bvh, const cv_scene *scene) {
    uint32_t n = cv_scene_instance_count(scene);
    if (bvh->instance_count != n)
        return cv_error(CV_ERROR_MALFORMED, "TLAS: %u instance records for %u scene instances", bvh->instance_count,
                        n);
    uint8_t *seen = calloc((size_t)n + 1, 1);
    if (!seen)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "TLAS: no memory to check %u instances", n);
    cv_result r = CV_OK;
    float inverse[3][4];
    for (uint32_t k = 0; k < n && r == CV_OK; k++) {
        const cv_bvh_instance *rec = &bvh->instances[k];
        if (rec->instance >= n || seen[rec->instance]++)
            r = cv_error(CV_ERROR_MALFORMED, "TLAS: record %u names instance %u (out of range or repeated)", k,
                         rec->instance);
        else if (rec->mesh != cv_scene_instance(scene, rec->instance)->mesh || rec->mesh >= bvh->mesh_count ||
                 rec->blas_root != bvh->meshes[rec->mesh].node_first ||
                 rec->blas_root2 != bvh->meshes[rec->mesh].node2_first)
            r = cv_error(CV_ERROR_MALFORMED, "TLAS: record %u (instance %u) has the wrong mesh or BLAS roots", k,
                         rec->instance);
        else if (!cv_transform_invert(cv_scene_instance(scene, rec->instance)->transform, inverse) ||
                 memcmp(inverse, rec->world_to_object, sizeof inverse) != 0)
            r = cv_error(CV_ERROR_MALFORMED,
                         "TLAS: record %u is not the inverse of instance %u's transform "
                         "(moved since the TLAS was built?)",
                         k, rec->instance);
    }
    free(seen);
    return r;
}

cv_result cv_scene_bvh_check(const cv_scene_bvh *bvh, const cv_scene *scene, cv_bvh_report *tlas_report,
                             cv_bvh_report *blas_report) {
    if (!bvh || !scene)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_scene_bvh_check: bvh or scene is NULL");
    if (bvh->mesh_count != cv_scene_mesh_count(scene))
        return cv_error(CV_ERROR_MALFORMED, "two-level BVH: %u BLASes for %u meshes", bvh->mesh_count,
                        cv_scene_mesh_count(scene));
    cv_bvh_report blas = { 0 }, one;
    double weighted_sah = 0.0;
    cv_result r = CV_OK;
    char what[48];
    for (uint32_t m = 0; m < bvh->mesh_count && r == CV_OK; m++) {
        const cv_bvh_blas_range *g = &bvh->meshes[m];
        snprintf(what, sizeof what, "BLAS of mesh %u", m);
        tree_view v = {
            .what = what,
            .nodes = bvh->blas_nodes,
            .node_first = g->node_first,
            .node_count = g->node_count,
            .nodes2 = bvh->blas_nodes2,
            .node2_first = g->node2_first,
            .node2_count = g->node2_count,
            .prim_first = g->tri_first,
            .prim_count = g->tri_count,
            .bounds = tri_bounds,
            .ctx = bvh->blas_tris,
            .opt = &bvh->options,
        };
        r = check_tree(&v, &one);
        blas.node_count += one.node_count;
        blas.leaf_count += one.leaf_count;
        blas.primitive_count += one.primitive_count;
        blas.max_depth = one.max_depth > blas.max_depth ? one.max_depth : blas.max_depth;
        blas.max_leaf_size = one.max_leaf_size > blas.max_leaf_size ? one.max_leaf_size : blas.max_leaf_size;
        weighted_sah += one.sah_cost * one.primitive_count;
    }
    blas.sah_cost = blas.primitive_count ? weighted_sah / blas.primitive_count : 0.0;
    if (r == CV_OK)
        r = check_instances(bvh, scene);
    if (r == CV_OK) {
        tlas_ctx ctx = { bvh, scene };
        tree_view v = {
            .what = "TLAS",
            .nodes = bvh->tlas_nodes,
            .node_count = bvh->tlas_node_count,
            .nodes2 = bvh->tlas_nodes2,
            .node2_count = bvh->tlas_node2_count,
            .prim_count = bvh->instance_count,
            .bounds = instance_bounds,
            .ctx = &ctx,
            .opt = &bvh->options,
        };
        r = check_tree(&v, &one);
    }
    if (r != CV_OK)
        return r;
    if (tlas_report)
        *tlas_report = one;
    if (blas_report)
        *blas_report = blas;
    return CV_OK;
}
