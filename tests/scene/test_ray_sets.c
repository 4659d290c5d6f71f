/* Ray sets: determinism per seed, tile order of primary rays, and the
 * geometry of each secondary kind (directions, intervals, hemispheres). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "corvid/ray_sets.h"
#include "corvid/scene_procedural.h"
#include "corvid/trace_cpu.h"
#include "scene_test_util.h"

static float dot3(const float a[3], const float b[3]) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

static bool unit(const float d[3]) { return fabsf(dot3(d, d) - 1.0f) < 1e-5f; }

/* Facing geometric normal at a hit, as the generator computes it. */
static void facing_normal(const cv_scene *s, const cv_hit *h, const float dir[3], float n[3]) {
    float v[3][3], e1[3], e2[3];
    cv_scene_world_triangle(s, h->instance, h->triangle, v);
    for (int k = 0; k < 3; k++) {
        e1[k] = v[1][k] - v[0][k];
        e2[k] = v[2][k] - v[0][k];
    }
    n[0] = e1[1] * e2[2] - e1[2] * e2[1];
    n[1] = e1[2] * e2[0] - e1[0] * e2[2];
    n[2] = e1[0] * e2[1] - e1[1] * e2[0];
    float inv = 1.0f / sqrtf(dot3(n, n));
    for (int k = 0; k < 3; k++)
        n[k] *= inv;
    if (dot3(n, dir) > 0.0f)
        for (int k = 0; k < 3; k++)
            n[k] *= -1.0f;
}

static void test_primary(const cv_scene *s) {
    cv_ray_set a, b, c;
    cv_ray_set_desc desc = { .width = 40, .height = 30, .seed = 1 };
    CHECK_OK(cv_ray_set_make(s, CV_RAYS_PRIMARY, &desc, &a));
    CHECK_OK(cv_ray_set_make(s, CV_RAYS_PRIMARY, &desc, &b));
    desc.seed = 2;
    CHECK_OK(cv_ray_set_make(s, CV_RAYS_PRIMARY, &desc, &c));
    CHECK_EQ_INT(a.count, 1200);
    CHECK(a.kind == CV_RAYS_PRIMARY);
    CHECK(memcmp(a.rays, b.rays, a.count * sizeof(cv_ray)) == 0);
    CHECK(memcmp(a.rays, c.rays, a.count * sizeof(cv_ray)) != 0);
    const cv_camera *cam = cv_scene_camera(s, 0);
    for (uint32_t i = 0; i < a.count; i++) {
        CHECK(unit(a.rays[i].dir) && a.rays[i].tmin == 0.0f && a.rays[i].tmax == INFINITY);
        CHECK(memcmp(a.rays[i].origin, cam->position, sizeof cam->position) == 0);
    }
    /* Ray 0..15 are the first 4x4 tile: ray 3 is pixel (3, 0) and ray 4 pixel
     * (0, 1), so ray 4 points lower than ray 0 and ray 3 further right. */
    CHECK(a.rays[4].dir[1] < a.rays[0].dir[1] && a.rays[3].dir[0] > a.rays[0].dir[0]);
    /* Ray 16 starts the next tile, right of the first one. */
    CHECK(a.rays[16].dir[0] > a.rays[3].dir[0]);
    cv_ray_set_free(&a);
    cv_ray_set_free(&b);
    cv_ray_set_free(&c);

    cv_ray_set r;
    CHECK_OK(cv_ray_set_make(s, CV_RAYS_RANDOM, &(cv_ray_set_desc){ .random_count = 5000, .seed = 4 }, &r));
    CHECK_EQ_INT(r.count, 5000);
    float bmin[3], bmax[3];
    cv_scene_bounds(s, bmin, bmax);
    for (uint32_t i = 0; i < r.count; i++) {
        CHECK(unit(r.rays[i].dir));
        for (int k = 0; k < 3; k++)
            CHECK(r.rays[i].origin[k] >= bmin[k] && r.rays[i].origin[k] <= bmax[k]);
    }
    cv_ray_set_free(&r);
    CHECK_RESULT(cv_ray_set_make(s, CV_RAYS_SHADOW, NULL, &r), CV_ERROR_INVALID_ARGUMENT);
}

static void test_secondary(const cv_scene *s) {
    cv_bvh *bvh = NULL;
    CHECK_OK(cv_bvh_build_flat(s, NULL, &bvh));
    cv_ray_set primary;
    cv_ray_set_desc desc = { .width = 128, .height = 96, .seed = 3 };
    CHECK_OK(cv_ray_set_make(s, CV_RAYS_PRIMARY, &desc, &primary));
    cv_hit *hits = malloc(primary.count * sizeof(cv_hit));
    CHECK_OK(cv_trace_batch(&(cv_trace_target){ .flat = bvh }, primary.rays, primary.count, 0, 0, hits));
    uint32_t hit_count = 0;
    for (uint32_t i = 0; i < primary.count; i++)
        hit_count += hits[i].triangle != CV_BVH_INVALID;
    CHECK(hit_count > primary.count / 2);

    const float *sun = cv_scene_light(s, 0)->direction;
    for (int kind = CV_RAYS_SHADOW; kind <= CV_RAYS_REFLECTION; kind++) {
        cv_ray_set set, again;
        CHECK_OK(cv_ray_set_make_secondary(s, (cv_ray_kind)kind, &desc, &primary, hits, &set));
        CHECK_OK(cv_ray_set_make_secondary(s, (cv_ray_kind)kind, &desc, &primary, hits, &again));
        CHECK(set.count == again.count && memcmp(set.rays, again.rays, set.count * sizeof(cv_ray)) == 0);
        if (kind == CV_RAYS_SHADOW)
            CHECK(set.count > 0 && set.count < hit_count);
        else
            CHECK_EQ_INT(set.count, hit_count);
        /* Walk the hits in order to pair each secondary ray with its origin. */
        /* All shadow rays share one direction: toward the sun. */
        const float to_sun[3] = { set.rays[0].dir[0], set.rays[0].dir[1], set.rays[0].dir[2] };
        const float against_light[3] = { -sun[0], -sun[1], -sun[2] };
        if (kind == CV_RAYS_SHADOW)
            CHECK(fabsf(dot3(to_sun, against_light) - 1.0f) < 1e-6f);
        double cos_sum = 0.0;
        uint32_t k = 0;
        for (uint32_t i = 0; i < primary.count && k < set.count; i++) {
            if (hits[i].triangle == CV_BVH_INVALID)
                continue;
            const cv_ray *in = &primary.rays[i];
            float n[3], p[3];
            facing_normal(s, &hits[i], in->dir, n);
            for (int a = 0; a < 3; a++)
                p[a] = in->origin[a] + in->dir[a] * hits[i].t;
            if (kind == CV_RAYS_SHADOW && !(dot3(n, to_sun) > 0.0f))
                continue;
            const cv_ray *r = &set.rays[k++];
            CHECK(memcmp(r->origin, p, sizeof p) == 0 && unit(r->dir));
            CHECK(r->tmin == fmaxf(1.0f, sqrtf(dot3(p, p))) * 1e-3f);
            float c = dot3(r->dir, n);
            cos_sum += c;
            switch (kind) {
            case CV_RAYS_SHADOW: CHECK(memcmp(r->dir, to_sun, sizeof to_sun) == 0 && r->tmax == INFINITY); break;
            case CV_RAYS_AO_SHORT: CHECK(c >= -1e-6f && r->tmax == 0.5f); break;
            case CV_RAYS_AO_LONG:
            case CV_RAYS_DIFFUSE: CHECK(c >= -1e-6f && r->tmax == INFINITY); break;
            default: {
                /* Mirror: same angle to the normal, reversed normal component. */
                CHECK(fabsf(c + dot3(in->dir, n)) < 1e-5f && r->tmax == INFINITY);
                break;
            }
            }
        }
        CHECK_EQ_INT(k, set.count);
        /* Cosine-weighted directions: E[cos] = 2/3. */
        if (kind == CV_RAYS_AO_SHORT || kind == CV_RAYS_AO_LONG || kind == CV_RAYS_DIFFUSE)
            CHECK(fabs(cos_sum / set.count - 2.0 / 3.0) < 0.01);
        CHECK(cv_ray_kind_is_occlusion((cv_ray_kind)kind) ==
              (kind == CV_RAYS_SHADOW || kind == CV_RAYS_AO_SHORT || kind == CV_RAYS_AO_LONG));
        fprintf(stderr, "%s: %u rays from %u hits, mean cos %.4f\n", cv_ray_kind_name((cv_ray_kind)kind), set.count,
                hit_count, cos_sum / set.count);
        cv_ray_set_free(&set);
        cv_ray_set_free(&again);
    }
    cv_ray_set bad;
    CHECK_RESULT(cv_ray_set_make_secondary(s, CV_RAYS_PRIMARY, &desc, &primary, hits, &bad),
                 CV_ERROR_INVALID_ARGUMENT);
    for (uint32_t i = 0; i < primary.count; i++) {
        if (hits[i].triangle != CV_BVH_INVALID) {
            hits[i].instance = 100000;
            break;
        }
    }
    CHECK_RESULT(cv_ray_set_make_secondary(s, CV_RAYS_AO_LONG, &desc, &primary, hits, &bad),
                 CV_ERROR_INVALID_ARGUMENT);
    free(hits);
    cv_ray_set_free(&primary);
    cv_bvh_destroy(bvh);
}

int main(void) {
    cv_scene *s;
    CHECK_OK(cv_scene_make_room(1, &s));
    test_primary(s);
    test_secondary(s);
    cv_scene_destroy(s);
    return check_report("test_ray_sets");
}
