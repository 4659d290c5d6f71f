/* The CPU traversal (both layouts, flat and two-level) against brute force
 * over every world triangle: 100,000 random rays, random ray intervals,
 * closest hit, any hit and back-face culling; plus the exact ray-interval
 * and culling rules on one triangle, and thread-count independence. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "corvid/ray_sets.h"
#include "corvid/scene_procedural.h"
#include "corvid/trace_cpu.h"
#include "scene_test_util.h"

typedef struct mismatch_count {
    int hit_miss; /* one hit, the other missed */
    int closest;  /* different triangle and t not within 1e-4 relative */
    int grazing;  /* two-level only: hit/miss disagreement at a triangle edge */
} mismatch_count;

/* Within 1e-5 of an edge, in barycentric terms. */
static bool grazes(const cv_hit *h) { return h->u < 1e-5f || h->v < 1e-5f || 1.0f - h->u - h->v < 1e-5f; }

static void compare(const cv_hit *got, const cv_hit *want, uint32_t flags, bool exact, mismatch_count *m) {
    bool g = got->triangle != CV_BVH_INVALID, w = want->triangle != CV_BVH_INVALID;
    if (g != w) {
        if (!exact && grazes(g ? got : want))
            m->grazing++;
        else
            m->hit_miss++;
        return;
    }
    if (!g || (flags & CV_TRACE_ANY_HIT))
        return;
    bool same = got->triangle == want->triangle && got->instance == want->instance;
    if (!same && fabsf(got->t - want->t) > 1e-4f * fabsf(want->t))
        m->closest++;
    if (same && exact)
        m->closest += got->t != want->t;
}

/* Rays with random intervals: half keep [0, inf), the others get a random
 * tmin and tmax inside the scene's extent. */
static void randomize_intervals(cv_ray *rays, uint32_t n, float extent) {
    uint32_t x = 99;
    for (uint32_t i = 1; i < n; i += 2) {
        x = x * 1664525u + 1013904223u;
        float a = (float)(x >> 8) * 0x1.0p-24f * extent;
        x = x * 1664525u + 1013904223u;
        float b = (float)(x >> 8) * 0x1.0p-24f * extent;
        rays[i].tmin = a < b ? a : b;
        rays[i].tmax = a < b ? b : a;
    }
}

static void test_against_brute_force(const char *name, const cv_scene *s, uint32_t ray_count) {
    cv_ray_set set;
    cv_ray_set_desc desc = { .random_count = ray_count, .seed = 11 };
    CHECK_OK(cv_ray_set_make(s, CV_RAYS_RANDOM, &desc, &set));
    float bmin[3], bmax[3];
    cv_scene_bounds(s, bmin, bmax);
    randomize_intervals(set.rays, set.count, 0.5f * (bmax[0] - bmin[0] + bmax[1] - bmin[1] + bmax[2] - bmin[2]));

    cv_bvh *flat = NULL;
    cv_scene_bvh *two = NULL;
    CHECK_OK(cv_bvh_build_flat(s, NULL, &flat));
    CHECK_OK(cv_scene_bvh_build(s, NULL, &two));
    if (!flat || !two)
        return;
    const uint32_t flag_sets[] = { CV_TRACE_CLOSEST, CV_TRACE_ANY_HIT, CV_TRACE_CULL_BACK_FACES };
    cv_hit *want = malloc(set.count * sizeof(cv_hit)), *got = malloc(set.count * sizeof(cv_hit));
    uint32_t tri_count;
    cv_bvh_tri *tris = brute_force_triangles(s, &tri_count);
    CHECK(tris != NULL && tri_count == cv_scene_world_triangle_count(s));
    for (size_t f = 0; tris && f < 3; f++) {
        uint32_t flags = flag_sets[f];
        /* Any-hit answers are checked for hit or miss only: the closest
         * brute-force result (from the previous pass) is the reference. */
        uint32_t hits = 0;
        if (flags == CV_TRACE_ANY_HIT)
            for (uint32_t i = 0; i < set.count; i++)
                hits += want[i].triangle != CV_BVH_INVALID;
        else
            hits = brute_force_batch(tris, tri_count, set.rays, set.count, flags, want);
        for (int target = 0; target < 4; target++) {
            cv_trace_target tg = { .flat = target < 2 ? flat : NULL,
                                   .two_level = target < 2 ? NULL : two,
                                   .layout = (target & 1) ? CV_BVH_LAYOUT_NODE2 : CV_BVH_LAYOUT_SKIP };
            CHECK_OK(cv_trace_batch(&tg, set.rays, set.count, flags, 0, got));
            mismatch_count m = { 0 };
            for (uint32_t i = 0; i < set.count; i++)
                compare(&got[i], &want[i], flags, target < 2, &m);
            fprintf(stderr, "%s: flags %u, %s %s: %u/%u hit; mismatches: hit/miss %d, closest %d, grazing %d\n", name,
                    flags, target < 2 ? "flat" : "two-level", (target & 1) ? "node2" : "skip", hits, set.count,
                    m.hit_miss, m.closest, m.grazing);
            CHECK_EQ_INT(m.hit_miss, 0);
            CHECK_EQ_INT(m.closest, 0);
            CHECK(m.grazing * 10000 <= (int)set.count);
        }
        CHECK(hits > set.count / 10);
    }
    free(tris);
    free(want);
    free(got);
    cv_ray_set_free(&set);
    cv_bvh_destroy(flat);
    cv_scene_bvh_destroy(two);
}

/* One triangle in the plane z = 0, counter-clockwise seen from +z. */
static void test_rules(void) {
    cv_scene *s;
    CHECK_OK(cv_scene_create(&s));
    const float pos[] = { 0, 0, 0, 1, 0, 0, 0, 1, 0 };
    const uint32_t idx[] = { 0, 1, 2 };
    cv_mesh_desc d = { .positions = pos, .vertex_count = 3, .indices = idx, .triangle_count = 1 };
    cv_material mat = cv_material_default();
    cv_instance inst = { 0 };
    cv_transform_identity(inst.transform);
    inst.transform[2][3] = -1.0f; /* the triangle at z = -1 */
    CHECK_OK(cv_scene_add_mesh(s, &d, NULL));
    CHECK_OK(cv_scene_add_material(s, &mat, NULL));
    CHECK_OK(cv_scene_add_instance(s, &inst, NULL));
    cv_bvh *flat = NULL;
    cv_scene_bvh *two = NULL;
    CHECK_OK(cv_bvh_build_flat(s, NULL, &flat));
    CHECK_OK(cv_scene_bvh_build(s, NULL, &two));
    for (int target = 0; flat && two && target < 4; target++) {
        cv_trace_target tg = { .flat = target < 2 ? flat : NULL,
                               .two_level = target < 2 ? NULL : two,
                               .layout = (target & 1) ? CV_BVH_LAYOUT_NODE2 : CV_BVH_LAYOUT_SKIP };
        /* From (0.25, 0.5, 0) straight down: t = 1, u = 0.25, v = 0.5, front face. */
        cv_ray r = { .origin = { 0.25f, 0.5f, 0.0f }, .tmin = 0.0f, .dir = { 0, 0, -1 }, .tmax = INFINITY };
        cv_hit h;
        CHECK(cv_trace_ray(&tg, &r, 0, &h));
        CHECK(h.t == 1.0f && h.u == 0.25f && h.v == 0.5f && h.triangle == 0 && h.instance == 0);
        CHECK(cv_trace_ray(&tg, &r, CV_TRACE_CULL_BACK_FACES, &h));
        r.tmax = 1.0f; /* [tmin, tmax): t = tmax misses */
        CHECK(!cv_trace_ray(&tg, &r, 0, &h));
        CHECK(h.t == INFINITY && h.triangle == CV_BVH_INVALID && h.instance == CV_BVH_INVALID);
        r.tmax = 1.0001f;
        CHECK(cv_trace_ray(&tg, &r, CV_TRACE_ANY_HIT, &h));
        r.tmin = 1.0f; /* t = tmin hits */
        CHECK(cv_trace_ray(&tg, &r, 0, &h));
        r.tmin = 1.0001f;
        CHECK(!cv_trace_ray(&tg, &r, 0, &h));
        /* From below, going up: a back face. */
        cv_ray up = { .origin = { 0.25f, 0.25f, -2.0f }, .tmin = 0.0f, .dir = { 0, 0, 1 }, .tmax = INFINITY };
        CHECK(cv_trace_ray(&tg, &up, 0, &h) && h.t == 1.0f);
        CHECK(!cv_trace_ray(&tg, &up, CV_TRACE_CULL_BACK_FACES, &h));
        /* Parallel to the plane, and past the hypotenuse. */
        cv_ray side = { .origin = { -1.0f, 0.25f, -1.0f }, .tmin = 0.0f, .dir = { 1, 0, 0 }, .tmax = INFINITY };
        CHECK(!cv_trace_ray(&tg, &side, 0, &h));
        cv_ray outside = { .origin = { 0.6f, 0.6f, 0.0f }, .tmin = 0.0f, .dir = { 0, 0, -1 }, .tmax = INFINITY };
        CHECK(!cv_trace_ray(&tg, &outside, 0, &h));
    }
    cv_hit hits[1];
    cv_ray r = { .dir = { 0, 0, -1 }, .tmax = INFINITY };
    CHECK_RESULT(cv_trace_batch(&(cv_trace_target){ .flat = flat, .two_level = two }, &r, 1, 0, 1, hits),
                 CV_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(cv_trace_batch(&(cv_trace_target){ 0 }, &r, 1, 0, 1, hits), CV_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(cv_trace_batch(&(cv_trace_target){ .flat = flat }, &r, 1, 0x80, 1, hits), CV_ERROR_INVALID_ARGUMENT);
    cv_bvh_destroy(flat);
    cv_scene_bvh_destroy(two);
    cv_scene_destroy(s);
}

static void test_thread_independence(void) {
    cv_scene *s;
    CHECK_OK(cv_scene_make_room(3, &s));
    cv_bvh *flat = NULL;
    CHECK_OK(cv_bvh_build_flat(s, NULL, &flat));
    cv_ray_set set;
    CHECK_OK(cv_ray_set_make(s, CV_RAYS_PRIMARY, &(cv_ray_set_desc){ .width = 96, .height = 64 }, &set));
    cv_hit *a = malloc(set.count * sizeof(cv_hit)), *b = malloc(set.count * sizeof(cv_hit));
    cv_trace_target tg = { .flat = flat, .layout = CV_BVH_LAYOUT_NODE2 };
    CHECK_OK(cv_trace_batch(&tg, set.rays, set.count, 0, 1, a));
    CHECK_OK(cv_trace_batch(&tg, set.rays, set.count, 0, 3, b));
    CHECK(memcmp(a, b, set.count * sizeof(cv_hit)) == 0);
    int hits = 0;
    for (uint32_t i = 0; i < set.count; i++)
        hits += a[i].triangle != CV_BVH_INVALID;
    CHECK(hits > (int)set.count / 2); /* most of the view is the room */
    free(a);
    free(b);
    cv_ray_set_free(&set);
    cv_bvh_destroy(flat);
    cv_scene_destroy(s);
}

int main(void) {
    test_rules();
    cv_scene *s;
    CHECK_OK(cv_scene_make_stress(4, 2000, &s));
    test_against_brute_force("stress 2k", s, 100000);
    cv_scene_destroy(s);
    CHECK_OK(cv_scene_make_room(2, &s));
    test_against_brute_force("room", s, 4000);
    cv_scene_destroy(s);
    test_thread_independence();
    return check_report("test_trace_cpu");
}
