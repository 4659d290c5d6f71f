/* BVH invariants on the room, a 10k stress scene and imported models, for
 * both builds (flat and two-level) and several options; the output is the
 * same for any thread count; top-level rebuilds and refits keep the
 * invariants; and the checker itself catches broken trees. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "corvid/bvh.h"
#include "corvid/scene_import.h"
#include "corvid/scene_procedural.h"
#include "corvid/trace_cpu.h"
#include "scene_test_util.h"

static bool same_bvh(const cv_bvh *a, const cv_bvh *b) {
    return a->node_count == b->node_count && a->node2_count == b->node2_count && a->tri_count == b->tri_count &&
           memcmp(a->nodes, b->nodes, a->node_count * sizeof(cv_bvh_node)) == 0 &&
           memcmp(a->nodes2, b->nodes2, a->node2_count * sizeof(cv_bvh_node2)) == 0 &&
           memcmp(a->tris, b->tris, a->tri_count * sizeof(cv_bvh_tri)) == 0;
}

static void check_flat(const char *name, const cv_scene *s, const cv_bvh_build_options *opt) {
    cv_bvh *b = NULL;
    CHECK_OK(cv_bvh_build_flat(s, opt, &b));
    if (!b)
        return;
    cv_bvh_report rep;
    CHECK_OK(cv_bvh_check(b, &rep));
    CHECK_EQ_INT(rep.primitive_count, cv_scene_world_triangle_count(s));
    CHECK_EQ_INT(rep.node_count, b->node_count);
    CHECK(rep.max_leaf_size <= b->options.max_leaf_size);
    CHECK(rep.max_depth <= 64);
    CHECK(rep.sah_cost > 0.0 && isfinite(rep.sah_cost));
    fprintf(stderr, "%s flat (bins %u, leaf <= %u): %u nodes, %u leaves, depth %u, SAH %.2f\n", name,
            b->options.bin_count, b->options.max_leaf_size, rep.node_count, rep.leaf_count, rep.max_depth,
            rep.sah_cost);
    cv_bvh_destroy(b);
}

static void check_two_level(const char *name, const cv_scene *s) {
    cv_scene_bvh *b = NULL;
    CHECK_OK(cv_scene_bvh_build(s, NULL, &b));
    if (!b)
        return;
    cv_bvh_report top, bottom;
    CHECK_OK(cv_scene_bvh_check(b, s, &top, &bottom));
    CHECK_EQ_INT(top.primitive_count, cv_scene_instance_count(s));
    CHECK_EQ_INT(bottom.primitive_count, cv_scene_triangle_count(s));
    CHECK_EQ_INT(b->mesh_count, cv_scene_mesh_count(s));
    fprintf(stderr, "%s two-level: TLAS %u nodes SAH %.2f, BLASes %u nodes SAH %.2f\n", name, top.node_count,
            top.sah_cost, bottom.node_count, bottom.sah_cost);
    cv_scene_bvh_destroy(b);
}

static void check_scene(const char *name, const cv_scene *s) {
    check_flat(name, s, NULL);
    check_two_level(name, s);
}

static void test_option_variants(const cv_scene *s) {
    const cv_bvh_build_options variants[] = {
        { .max_leaf_size = 1 }, { .max_leaf_size = 4 }, { .max_leaf_size = 16 },
        { .bin_count = 2 },     { .bin_count = 64 },    { .traversal_cost = 4.0f, .intersection_cost = 0.5f },
    };
    for (size_t i = 0; i < sizeof variants / sizeof variants[0]; i++)
        check_flat("stress 10k", s, &variants[i]);
    cv_bvh *b = NULL;
    const cv_bvh_build_options bad[] = { { .bin_count = 1 },
                                         { .bin_count = 65 },
                                         { .max_leaf_size = 17 },
                                         { .traversal_cost = -1.0f },
                                         { .intersection_cost = NAN } };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++)
        CHECK_RESULT(cv_bvh_build_flat(s, &bad[i], &b), CV_ERROR_INVALID_ARGUMENT);
    CHECK(b == NULL);
}

/* Same output with 1, 2 and 5 threads (the builder threads big subtrees). */
static void test_thread_independence(const cv_scene *s) {
    cv_bvh *ref = NULL, *other = NULL;
    CHECK_OK(cv_bvh_build_flat(s, &(cv_bvh_build_options){ .thread_count = 1 }, &ref));
    const uint32_t threads[] = { 2, 5 };
    for (size_t i = 0; ref && i < 2; i++) {
        CHECK_OK(cv_bvh_build_flat(s, &(cv_bvh_build_options){ .thread_count = threads[i] }, &other));
        CHECK(other && same_bvh(ref, other));
        cv_bvh_destroy(other);
        other = NULL;
    }
    cv_bvh_destroy(ref);
}

/* The checker must reject broken copies of a good BVH. */
static void test_checker_catches(const cv_scene *s) {
    cv_bvh *b = NULL;
    CHECK_OK(cv_bvh_build_flat(s, NULL, &b));
    if (!b)
        return;
    cv_bvh copy = *b;
    copy.nodes = malloc(b->node_count * sizeof(cv_bvh_node));
    copy.nodes2 = malloc(b->node2_count * sizeof(cv_bvh_node2));
    copy.tris = malloc(b->tri_count * sizeof(cv_bvh_tri));
    enum { SHRINK_LEAF, SHRINK_NODE2, BIG_LEAF, DUP_TRI, BAD_SKIP, MOVE_TRI, CASES };
    for (int c = 0; c < CASES; c++) {
        memcpy(copy.nodes, b->nodes, b->node_count * sizeof(cv_bvh_node));
        memcpy(copy.nodes2, b->nodes2, b->node2_count * sizeof(cv_bvh_node2));
        memcpy(copy.tris, b->tris, b->tri_count * sizeof(cv_bvh_tri));
        uint32_t leaf = 0;
        while (copy.nodes[leaf].info == CV_BVH_INTERIOR)
            leaf++;
        switch (c) {
        case SHRINK_LEAF: copy.nodes[leaf].bmax[0] = copy.nodes[leaf].bmin[0]; break;
        case SHRINK_NODE2: copy.nodes2[0].a_max[1] = copy.nodes2[0].a_min[1]; break;
        case BIG_LEAF: copy.options.max_leaf_size = 1; break;
        case DUP_TRI:
            copy.nodes[leaf].info = cv_bvh_leaf_info(cv_bvh_leaf_first(copy.nodes[leaf].info) + 1,
                                                     cv_bvh_leaf_count(copy.nodes[leaf].info));
            break;
        case BAD_SKIP: copy.nodes[leaf].skip = 0; break;
        default: copy.tris[0].v0[0] += 1000.0f; break;
        }
        CHECK_RESULT(cv_bvh_check(&copy, NULL), CV_ERROR_MALFORMED);
    }
    free(copy.nodes);
    free(copy.nodes2);
    free(copy.tris);
    cv_bvh_destroy(b);
}

static void test_small_cases(void) {
    cv_scene *s;
    CHECK_OK(cv_scene_create(&s));
    cv_bvh *b = NULL;
    CHECK_OK(cv_bvh_build_flat(s, NULL, &b));
    CHECK(b && b->node_count == 0 && b->tri_count == 0);
    CHECK_OK(cv_bvh_check(b, NULL));
    cv_bvh_destroy(b);

    /* One triangle: a single leaf; the two-child layout has an empty child. */
    const float pos[] = { 0, 0, 0, 1, 0, 0, 0, 1, 0 };
    const uint32_t idx[] = { 0, 1, 2 };
    cv_mesh_desc d = { .positions = pos, .vertex_count = 3, .indices = idx, .triangle_count = 1 };
    cv_material m = cv_material_default();
    cv_instance inst = { 0 };
    cv_transform_identity(inst.transform);
    CHECK_OK(cv_scene_add_mesh(s, &d, NULL));
    CHECK_OK(cv_scene_add_material(s, &m, NULL));
    CHECK_OK(cv_scene_add_instance(s, &inst, NULL));
    CHECK_OK(cv_bvh_build_flat(s, NULL, &b));
    CHECK(b && b->node_count == 1 && b->node2_count == 1 && b->nodes2[0].b_count == 0);
    CHECK_OK(cv_bvh_check(b, NULL));
    cv_bvh_destroy(b);
    check_two_level("one triangle", s);
    cv_scene_destroy(s);
}

/* Moving instances needs only a TLAS rebuild; deforming a mesh a refit. */
static void test_updates(void) {
    cv_scene *s;
    CHECK_OK(cv_scene_make_room(5, &s));
    cv_scene_bvh *b = NULL;
    CHECK_OK(cv_scene_bvh_build(s, NULL, &b));
    if (!b) {
        cv_scene_destroy(s);
        return;
    }
    const uint32_t moved = 20;
    float t[3][4];
    memcpy(t, cv_scene_instance(s, moved)->transform, sizeof t);
    t[1][3] += 3.0f;
    CHECK_OK(cv_scene_set_instance_transform(s, moved, t));
    CHECK_RESULT(cv_scene_bvh_check(b, s, NULL, NULL), CV_ERROR_MALFORMED); /* stale TLAS */
    CHECK_OK(cv_scene_bvh_rebuild_top(b, s));
    CHECK_OK(cv_scene_bvh_check(b, s, NULL, NULL));

    /* Grow the sphere mesh (index 2) by 1.5x. */
    const cv_mesh *m = cv_scene_mesh(s, 2);
    float *grown = malloc((size_t)m->vertex_count * 3 * sizeof(float));
    for (uint32_t i = 0; i < m->vertex_count * 3; i++)
        grown[i] = m->positions[i] * 1.5f;
    CHECK_OK(cv_scene_set_mesh_positions(s, 2, grown, m->vertex_count));
    free(grown);
    CHECK_OK(cv_scene_bvh_refit_mesh(b, s, 2));
    CHECK_OK(cv_scene_bvh_check(b, s, NULL, NULL));
    CHECK_RESULT(cv_scene_bvh_refit_mesh(b, s, 99), CV_ERROR_OUT_OF_RANGE);

    /* The refitted BVH traces like a fresh build of the changed scene. */
    cv_scene_bvh *fresh = NULL;
    CHECK_OK(cv_scene_bvh_build(s, NULL, &fresh));
    const cv_camera *cam = cv_scene_camera(s, 0);
    int differ = 0;
    for (int y = 0; fresh && y < 48; y++) {
        for (int x = 0; x < 64; x++) {
            cv_ray r = { .origin = { cam->position[0], cam->position[1], cam->position[2] },
                         .tmin = 0.0f,
                         .dir = { (x - 32) / 64.0f, (24 - y) / 64.0f - 0.1f, -1.0f },
                         .tmax = INFINITY };
            cv_hit h1, h2;
            cv_trace_ray(&(cv_trace_target){ .two_level = b, .layout = CV_BVH_LAYOUT_NODE2 }, &r, 0, &h1);
            cv_trace_ray(&(cv_trace_target){ .two_level = fresh, .layout = CV_BVH_LAYOUT_NODE2 }, &r, 0, &h2);
            differ += h1.triangle != h2.triangle || h1.instance != h2.instance || h1.t != h2.t;
        }
    }
    CHECK_EQ_INT(differ, 0);
    cv_scene_bvh_destroy(fresh);

    /* Adding a mesh invalidates the BLASes: rebuild_top refuses. */
    const float pos[] = { 0, 0, 0, 1, 0, 0, 0, 1, 0 };
    const uint32_t idx[] = { 0, 1, 2 };
    cv_mesh_desc d = { .positions = pos, .vertex_count = 3, .indices = idx, .triangle_count = 1 };
    CHECK_OK(cv_scene_add_mesh(s, &d, NULL));
    CHECK_RESULT(cv_scene_bvh_rebuild_top(b, s), CV_ERROR_BAD_STATE);
    cv_scene_bvh_destroy(b);
    cv_scene_destroy(s);
}

int main(void) {
    cv_scene *room, *stress;
    CHECK_OK(cv_scene_make_room(1, &room));
    CHECK_OK(cv_scene_make_stress(1, 10000, &stress));
    check_scene("room", room);
    check_scene("stress 10k", stress);
    test_option_variants(stress);
    test_thread_independence(room);
    test_checker_catches(stress);
    cv_scene_destroy(room);
    cv_scene_destroy(stress);

    const char *models[] = { "OBJ/spider.obj", "glTF2/2CylinderEngine-glTF-Binary/2CylinderEngine.glb" };
    for (size_t i = 0; i < 2; i++) {
        cv_scene *s = NULL;
        if (!file_exists(model_path(models[i]))) {
            fprintf(stderr, "%s not found: skipped\n", model_path(models[i]));
            continue;
        }
        CHECK_OK(cv_scene_import(model_path(models[i]), &s));
        if (s)
            check_scene(models[i], s);
        cv_scene_destroy(s);
    }
    test_small_cases();
    test_updates();
    return check_report("test_bvh_invariants");
}
