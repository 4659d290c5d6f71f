/* The flat BVH: every instance's triangles transformed to world space and
 * built into one tree. Triangle records are computed twice (for the
 * builder's boxes, then in leaf order for the output) instead of being
 * stored in scene order: at 10M triangles that saves 480 MB. */
#include <stdlib.h>
#include <string.h>

#include "big_alloc.h"
#include "bvh_builder.h"
#include "bvh_layout.h"
#include "parallel.h"

typedef struct flat_ctx {
    const cv_scene *scene;
    uint64_t *first; /* first world triangle of each instance, plus the total */
    uint32_t instance_count;
    cvs_prim_ref *refs;
    const uint32_t *order; /* world triangle ids in leaf order */
    cv_bvh_tri *tris;
} flat_ctx;

/* Instance holding world triangle g: the last i with first[i] <= g. */
static uint32_t instance_of(const flat_ctx *c, uint64_t g) {
    uint32_t lo = 0, hi = c->instance_count;
    while (hi - lo > 1) {
        uint32_t mid = lo + (hi - lo) / 2;
        if (c->first[mid] <= g)
            lo = mid;
        else
            hi = mid;
    }
    return lo;
}

static cv_bvh_tri world_tri(const flat_ctx *c, uint32_t g) {
    uint32_t inst = instance_of(c, g);
    uint32_t tri = (uint32_t)(g - c->first[inst]);
    float v[3][3];
    cv_scene_world_triangle(c->scene, inst, tri, v);
    return cv_bvh_tri_make(v, tri, inst);
}

static void make_refs(void *ctx, size_t begin, size_t end, uint32_t worker) {
    (void)worker;
    const flat_ctx *c = ctx;
    for (size_t g = begin; g < end; g++) {
        cv_bvh_tri t = world_tri(c, (uint32_t)g);
        cvs_prim_ref *r = &c->refs[g];
        cvs_tri_bounds(&t, r->min, r->max);
        r->id = (uint32_t)g;
        r->pad = 0;
    }
}

static void make_tris(void *ctx, size_t begin, size_t end, uint32_t worker) {
    (void)worker;
    const flat_ctx *c = ctx;
    for (size_t k = begin; k < end; k++)
        c->tris[k] = world_tri(c, c->order[k]);
}

void cv_bvh_destroy(cv_bvh *bvh) {
    if (!bvh)
        return;
    free(bvh->nodes);
    free(bvh->nodes2);
    free(bvh->tris);
    free(bvh);
}

cv_result cv_bvh_build_flat(const cv_scene *scene, const cv_bvh_build_options *options, cv_bvh **out) {
    if (!scene || !out)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_bvh_build_flat: scene or out is NULL");
    cv_bvh_build_options opt;
    cv_result r = cvs_bvh_options_resolve(options, &opt);
    if (r != CV_OK)
        return r;
    uint64_t total = cv_scene_world_triangle_count(scene);
    if (total > CV_BVH_MAX_PRIMITIVES)
        return cv_error(CV_ERROR_LIMIT_EXCEEDED, "cv_bvh_build_flat: %llu world triangles, the limit is %u",
                        (unsigned long long)total, CV_BVH_MAX_PRIMITIVES);
    const uint32_t n = (uint32_t)total;
    flat_ctx c = { .scene = scene, .instance_count = cv_scene_instance_count(scene) };
    cv_bvh *bvh = calloc(1, sizeof *bvh);
    c.first = malloc(((size_t)c.instance_count + 1) * sizeof(uint64_t));
    c.refs = cvs_big_alloc((size_t)n * sizeof(cvs_prim_ref));
    if (!bvh || !c.first || !c.refs) {
        r = cv_error(CV_ERROR_OUT_OF_MEMORY, "cv_bvh_build_flat: no memory for %u triangle boxes", n);
        goto fail;
    }
    c.first[0] = 0;
    for (uint32_t i = 0; i < c.instance_count; i++)
        c.first[i + 1] = c.first[i] + cv_scene_mesh(scene, cv_scene_instance(scene, i)->mesh)->triangle_count;
    cvs_parallel_for(opt.thread_count, n, 4096, make_refs, &c);

    cvs_tree tree;
    r = cvs_tree_build(c.refs, n, &opt, &tree);
    if (r != CV_OK)
        goto fail;
    free(c.refs);
    c.refs = NULL;
    bvh->options = opt;
    bvh->node_count = cvs_layout_node_count(&tree);
    bvh->node2_count = cvs_layout_node2_count(&tree);
    bvh->tri_count = n;
    bvh->nodes = cvs_big_alloc((size_t)bvh->node_count * sizeof(cv_bvh_node));
    bvh->nodes2 = cvs_big_alloc((size_t)bvh->node2_count * sizeof(cv_bvh_node2));
    bvh->tris = cvs_big_alloc((size_t)n * sizeof(cv_bvh_tri));
    if (!bvh->nodes || !bvh->nodes2 || !bvh->tris) {
        cvs_tree_free(&tree);
        r = cv_error(CV_ERROR_OUT_OF_MEMORY, "cv_bvh_build_flat: no memory for %u nodes and %u triangles",
                     bvh->node_count, n);
        goto fail;
    }
    r = cvs_layout_emit(&tree, bvh->nodes, 0, bvh->nodes2, 0, 0);
    if (r == CV_OK) {
        c.order = tree.prim_ids;
        c.tris = bvh->tris;
        cvs_parallel_for(opt.thread_count, n, 4096, make_tris, &c);
    }
    cvs_tree_free(&tree);
    if (r != CV_OK)
        goto fail;
    free(c.first);
    *out = bvh;
    return CV_OK;

fail:
    free(c.first);
    free(c.refs);
    cv_bvh_destroy(bvh);
    return r;
}
