/* The two-level BVH: one BLAS per mesh, concatenated, and a TLAS over the
 * instances. The TLAS is always built into fresh arrays and swapped in, so
 * a failed rebuild or refit leaves the previous state untouched. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "bvh_builder.h"
#include "bvh_layout.h"
#include "parallel.h"

typedef struct box {
    float min[3], max[3];
} box;

typedef struct tlas {
    cv_bvh_node *nodes;
    uint32_t node_count;
    cv_bvh_node2 *nodes2;
    uint32_t node2_count;
    cv_bvh_instance *instances;
    uint32_t instance_count;
} tlas;

static cv_bvh_tri mesh_tri(const cv_mesh *m, uint32_t t) {
    float v[3][3];
    for (int k = 0; k < 3; k++)
        memcpy(v[k], &m->positions[3 * m->indices[3 * t + k]], sizeof v[k]);
    return cv_bvh_tri_make(v, t, CV_BVH_INVALID);
}

static cv_result build_mesh_tree(const cv_mesh *m, uint32_t index, const cv_bvh_build_options *opt, cvs_tree *tree) {
    cvs_prim_ref *refs = malloc((size_t)m->triangle_count * sizeof(cvs_prim_ref));
    if (!refs)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "BLAS of mesh %u ('%s'): no memory for %u triangle boxes", index,
                        m->name, m->triangle_count);
    for (uint32_t t = 0; t < m->triangle_count; t++) {
        cv_bvh_tri tri = mesh_tri(m, t);
        cvs_tri_bounds(&tri, refs[t].min, refs[t].max);
        refs[t].id = t;
        refs[t].pad = 0;
    }
    cv_result r = cvs_tree_build(refs, m->triangle_count, opt, tree);
    free(refs);
    return r;
}

static void tlas_free(tlas *t) {
    free(t->nodes);
    free(t->nodes2);
    free(t->instances);
    memset(t, 0, sizeof *t);
}

/* Builds a TLAS over the scene's instances, given each mesh's BLAS root box. */
static cv_result tlas_build(const cv_scene *scene, const cv_bvh_blas_range *ranges, const box *roots,
                            const cv_bvh_build_options *opt, tlas *out) {
    memset(out, 0, sizeof *out);
    uint32_t n = cv_scene_instance_count(scene);
    if (n == 0)
        return CV_OK;
    cvs_prim_ref *refs = malloc((size_t)n * sizeof(cvs_prim_ref));
    if (!refs)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "TLAS: no memory for %u instance boxes", n);
    for (uint32_t i = 0; i < n; i++) {
        const cv_instance *inst = cv_scene_instance(scene, i);
        cvs_instance_bounds(inst->transform, roots[inst->mesh].min, roots[inst->mesh].max, refs[i].min, refs[i].max);
        refs[i].id = i;
        refs[i].pad = 0;
    }
    cvs_tree tree;
    cv_result r = cvs_tree_build(refs, n, opt, &tree);
    free(refs);
    if (r != CV_OK)
        return r;
    out->node_count = cvs_layout_node_count(&tree);
    out->node2_count = cvs_layout_node2_count(&tree);
    out->instance_count = n;
    out->nodes = malloc((size_t)out->node_count * sizeof(cv_bvh_node));
    out->nodes2 = malloc((size_t)out->node2_count * sizeof(cv_bvh_node2));
    out->instances = malloc((size_t)n * sizeof(cv_bvh_instance));
    if (!out->nodes || !out->nodes2 || !out->instances)
        r = cv_error(CV_ERROR_OUT_OF_MEMORY, "TLAS: no memory for %u nodes over %u instances", out->node_count, n);
    if (r == CV_OK)
        r = cvs_layout_emit(&tree, out->nodes, 0, out->nodes2, 0, 0);
    for (uint32_t k = 0; k < n && r == CV_OK; k++) {
        uint32_t id = tree.prim_ids[k];
        const cv_instance *inst = cv_scene_instance(scene, id);
        cv_bvh_instance *rec = &out->instances[k];
        /* Transforms were checked invertible when set on the scene. */
        cv_transform_invert(inst->transform, rec->world_to_object);
        rec->blas_root = ranges[inst->mesh].node_first;
        rec->blas_root2 = ranges[inst->mesh].node2_first;
        rec->instance = id;
        rec->mesh = inst->mesh;
    }
    cvs_tree_free(&tree);
    if (r != CV_OK)
        tlas_free(out);
    return r;
}

static void tlas_install(cv_scene_bvh *bvh, tlas *t) {
    free(bvh->tlas_nodes);
    free(bvh->tlas_nodes2);
    free(bvh->instances);
    bvh->tlas_nodes = t->nodes;
    bvh->tlas_node_count = t->node_count;
    bvh->tlas_nodes2 = t->nodes2;
    bvh->tlas_node2_count = t->node2_count;
    bvh->instances = t->instances;
    bvh->instance_count = t->instance_count;
}

/* Root boxes of all BLASes, as they are now. */
static box *root_boxes(const cv_scene_bvh *bvh) {
    box *roots = malloc((size_t)bvh->mesh_count * sizeof(box) + 1);
    if (!roots)
        return NULL;
    for (uint32_t m = 0; m < bvh->mesh_count; m++) {
        const cv_bvh_node *root = &bvh->blas_nodes[bvh->meshes[m].node_first];
        memcpy(roots[m].min, root->bmin, sizeof roots[m].min);
        memcpy(roots[m].max, root->bmax, sizeof roots[m].max);
    }
    return roots;
}

typedef struct mesh_jobs {
    const cv_scene *scene;
    cv_bvh_build_options one_thread;
    cvs_tree *trees;
    cv_result *results;
} mesh_jobs;

static void build_small_meshes(void *ctx, size_t begin, size_t end, uint32_t worker) {
    (void)worker;
    mesh_jobs *j = ctx;
    for (size_t m = begin; m < end; m++) {
        const cv_mesh *mesh = cv_scene_mesh(j->scene, (uint32_t)m);
        if (mesh->triangle_count < CVS_BVH_PARALLEL_MIN)
            j->results[m] = build_mesh_tree(mesh, (uint32_t)m, &j->one_thread, &j->trees[m]);
    }
}

/* Small meshes are built side by side, one thread each; big ones one after
 * the other with all threads. Trees do not depend on either. */
static cv_result build_mesh_trees(const cv_scene *scene, const cv_bvh_build_options *opt, cvs_tree *trees) {
    uint32_t n = cv_scene_mesh_count(scene);
    mesh_jobs j = {
        .scene = scene, .one_thread = *opt, .trees = trees, .results = calloc((size_t)n + 1, sizeof(cv_result))
    };
    if (!j.results)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "two-level BVH: no memory for %u mesh builds", n);
    j.one_thread.thread_count = 1;
    cvs_parallel_for(opt->thread_count, n, 1, build_small_meshes, &j);
    cv_result r = CV_OK;
    for (uint32_t m = 0; m < n && r == CV_OK; m++) {
        const cv_mesh *mesh = cv_scene_mesh(scene, m);
        if (mesh->triangle_count >= CVS_BVH_PARALLEL_MIN)
            r = build_mesh_tree(mesh, m, opt, &trees[m]);
        else if (j.results[m] != CV_OK) /* the worker's message stayed on its thread */
            r = cv_error(j.results[m], "BLAS of mesh %u ('%s'): out of memory for %u triangles", m, mesh->name,
                         mesh->triangle_count);
    }
    free(j.results);
    return r;
}

void cv_scene_bvh_destroy(cv_scene_bvh *bvh) {
    if (!bvh)
        return;
    free(bvh->blas_nodes);
    free(bvh->blas_nodes2);
    free(bvh->blas_tris);
    free(bvh->meshes);
    free(bvh->tlas_nodes);
    free(bvh->tlas_nodes2);
    free(bvh->instances);
    free(bvh);
}

/* Lays out every mesh's tree into the concatenated BLAS arrays. */
static cv_result install_blases(cv_scene_bvh *bvh, const cv_scene *scene, const cvs_tree *trees) {
    uint64_t nodes = 0, nodes2 = 0, tris = 0;
    for (uint32_t m = 0; m < bvh->mesh_count; m++) {
        cv_bvh_blas_range *g = &bvh->meshes[m];
        g->node_first = (uint32_t)nodes;
        g->node_count = cvs_layout_node_count(&trees[m]);
        g->node2_first = (uint32_t)nodes2;
        g->node2_count = cvs_layout_node2_count(&trees[m]);
        g->tri_first = (uint32_t)tris;
        g->tri_count = trees[m].prim_count;
        nodes += g->node_count;
        nodes2 += g->node2_count;
        tris += g->tri_count;
    }
    if (tris > CV_BVH_MAX_PRIMITIVES || nodes > INT32_MAX)
        return cv_error(CV_ERROR_LIMIT_EXCEEDED, "two-level BVH: %llu BLAS triangles in %llu nodes, the limit is %u",
                        (unsigned long long)tris, (unsigned long long)nodes, CV_BVH_MAX_PRIMITIVES);
    bvh->blas_node_count = (uint32_t)nodes;
    bvh->blas_node2_count = (uint32_t)nodes2;
    bvh->blas_tri_count = (uint32_t)tris;
    bvh->blas_nodes = malloc(nodes * sizeof(cv_bvh_node) + 1);
    bvh->blas_nodes2 = malloc(nodes2 * sizeof(cv_bvh_node2) + 1);
    bvh->blas_tris = malloc(tris * sizeof(cv_bvh_tri) + 1);
    if (!bvh->blas_nodes || !bvh->blas_nodes2 || !bvh->blas_tris)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "two-level BVH: no memory for %llu BLAS nodes and %llu triangles",
                        (unsigned long long)nodes, (unsigned long long)tris);
    for (uint32_t m = 0; m < bvh->mesh_count; m++) {
        const cv_bvh_blas_range *g = &bvh->meshes[m];
        cv_result r = cvs_layout_emit(&trees[m], bvh->blas_nodes + g->node_first, g->node_first,
                                      bvh->blas_nodes2 + g->node2_first, g->node2_first, g->tri_first);
        if (r != CV_OK)
            return r;
        const cv_mesh *mesh = cv_scene_mesh(scene, m);
        for (uint32_t k = 0; k < g->tri_count; k++)
            bvh->blas_tris[g->tri_first + k] = mesh_tri(mesh, trees[m].prim_ids[k]);
    }
    return CV_OK;
}

cv_result cv_scene_bvh_build(const cv_scene *scene, const cv_bvh_build_options *options, cv_scene_bvh **out) {
    if (!scene || !out)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_scene_bvh_build: scene or out is NULL");
    cv_bvh_build_options opt;
    cv_result r = cvs_bvh_options_resolve(options, &opt);
    if (r != CV_OK)
        return r;
    uint32_t mesh_count = cv_scene_mesh_count(scene);
    cv_scene_bvh *bvh = calloc(1, sizeof *bvh);
    cvs_tree *trees = calloc((size_t)mesh_count + 1, sizeof(cvs_tree));
    if (bvh)
        bvh->meshes = calloc((size_t)mesh_count + 1, sizeof(cv_bvh_blas_range));
    if (!bvh || !trees || !bvh->meshes) {
        free(trees);
        cv_scene_bvh_destroy(bvh);
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "cv_scene_bvh_build: no memory for %u meshes", mesh_count);
    }
    bvh->mesh_count = mesh_count;
    bvh->options = opt;
    r = build_mesh_trees(scene, &opt, trees);
    if (r == CV_OK)
        r = install_blases(bvh, scene, trees);
    for (uint32_t m = 0; m < mesh_count; m++)
        cvs_tree_free(&trees[m]);
    free(trees);
    if (r == CV_OK)
        r = cv_scene_bvh_rebuild_top(bvh, scene);
    if (r != CV_OK) {
        cv_scene_bvh_destroy(bvh);
        return r;
    }
    *out = bvh;
    return CV_OK;
}

static cv_result check_meshes_match(const cv_scene_bvh *bvh, const cv_scene *scene) {
    if (cv_scene_mesh_count(scene) != bvh->mesh_count)
        return cv_error(CV_ERROR_BAD_STATE, "two-level BVH has %u BLASes, the scene now has %u meshes: build anew",
                        bvh->mesh_count, cv_scene_mesh_count(scene));
    for (uint32_t m = 0; m < bvh->mesh_count; m++)
        if (cv_scene_mesh(scene, m)->triangle_count != bvh->meshes[m].tri_count)
            return cv_error(CV_ERROR_BAD_STATE, "mesh %u now has %u triangles, its BLAS %u: build anew", m,
                            cv_scene_mesh(scene, m)->triangle_count, bvh->meshes[m].tri_count);
    return CV_OK;
}

cv_result cv_scene_bvh_rebuild_top(cv_scene_bvh *bvh, const cv_scene *scene) {
    if (!bvh || !scene)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_scene_bvh_rebuild_top: bvh or scene is NULL");
    cv_result r = check_meshes_match(bvh, scene);
    if (r != CV_OK)
        return r;
    box *roots = root_boxes(bvh);
    if (!roots)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "TLAS: no memory for %u root boxes", bvh->mesh_count);
    tlas t;
    r = tlas_build(scene, bvh->meshes, roots, &bvh->options, &t);
    free(roots);
    if (r == CV_OK)
        tlas_install(bvh, &t);
    return r;
}

cv_result cv_scene_bvh_refit_mesh(cv_scene_bvh *bvh, const cv_scene *scene, uint32_t mesh) {
    if (!bvh || !scene)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_scene_bvh_refit_mesh: bvh or scene is NULL");
    if (mesh >= bvh->mesh_count)
        return cv_error(CV_ERROR_OUT_OF_RANGE, "cv_scene_bvh_refit_mesh: mesh %u out of range (%u BLASes)", mesh,
                        bvh->mesh_count);
    cv_result r = check_meshes_match(bvh, scene);
    if (r != CV_OK)
        return r;
    const cv_bvh_blas_range *g = &bvh->meshes[mesh];
    const cv_mesh *m = cv_scene_mesh(scene, mesh);
    cv_bvh_tri *tris = malloc((size_t)g->tri_count * sizeof(cv_bvh_tri));
    box *roots = root_boxes(bvh);
    if (!tris || !roots) {
        free(tris);
        free(roots);
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "refit of mesh %u: no memory for %u triangles", mesh, g->tri_count);
    }
    /* The refitted root box is the union of the triangle boxes, so the new
     * TLAS can be built before anything is changed. */
    box *root = &roots[mesh];
    for (int k = 0; k < 3; k++) {
        root->min[k] = INFINITY;
        root->max[k] = -INFINITY;
    }
    for (uint32_t k = 0; k < g->tri_count; k++) {
        float tmin[3], tmax[3];
        tris[k] = mesh_tri(m, bvh->blas_tris[g->tri_first + k].prim);
        cvs_tri_bounds(&tris[k], tmin, tmax);
        for (int a = 0; a < 3; a++) {
            root->min[a] = tmin[a] < root->min[a] ? tmin[a] : root->min[a];
            root->max[a] = tmax[a] > root->max[a] ? tmax[a] : root->max[a];
        }
    }
    tlas t;
    r = tlas_build(scene, bvh->meshes, roots, &bvh->options, &t);
    free(roots);
    if (r == CV_OK) {
        memcpy(&bvh->blas_tris[g->tri_first], tris, (size_t)g->tri_count * sizeof(cv_bvh_tri));
        cvs_layout_refit(bvh->blas_nodes, g->node_first, g->node_count, bvh->blas_nodes2, g->node2_first,
                         g->node2_count, bvh->blas_tris);
        tlas_install(bvh, &t);
    }
    free(tris);
    return r;
}
