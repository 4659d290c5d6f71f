/* trace_rays on the Vulkan backend against the CPU reference traversal: the
 * procedural room, a flat BVH in the two-child layout, and primary, random,
 * shadow and AO rays, closest and any hit, with and without back-face culling.
 * Rays and hits sit at offsets inside larger buffers.
 *
 * On lavapipe the kernel rounds exactly as scene/src/trace_cpu.c does, so
 * every hit must match bit for bit. Other drivers may round division
 * differently (GLSL allows 2.5 ulp), so there the rule is the issue's: the same
 * triangle and instance, t within 1e-4 relative, misses agree; any-hit rays
 * agree on occlusion. Two exceptions are allowed, counted, and must stay under
 * 0.1% of the rays: a grazing hit (the ray passes within 1e-5, barycentric, of
 * a triangle edge, where a last-bit difference changes which triangle is hit)
 * and a coincident hit (another triangle that the ray really hits at the same t,
 * such as a prop's base lying on the floor: which one is "closest" is a tie). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "corvid/bvh.h"
#include "corvid/ray_sets.h"
#include "corvid/scene_procedural.h"
#include "corvid/trace_cpu.h"
#include "vk_test.h"

enum { RAYS_OFFSET = 512, HITS_OFFSET = 256 };

typedef struct tracer {
    cv_context *ctx;
    cv_device *dev;
    cv_accel accel;
    const cv_bvh *bvh;
} tracer;

/* Whether the ray passes within `slack` (barycentric) of triangle `tri`'s
 * edges at a t inside its interval: a hit that one rounding may give and
 * another may not. */
static bool grazes(const cv_bvh_tri *tri, const cv_ray *ray, float slack) {
    const float *d = ray->dir, *e1 = tri->e1, *e2 = tri->e2;
    float p[3] = { d[1] * e2[2] - d[2] * e2[1], d[2] * e2[0] - d[0] * e2[2], d[0] * e2[1] - d[1] * e2[0] };
    float det = e1[0] * p[0] + e1[1] * p[1] + e1[2] * p[2];
    if (fabsf(det) < 1e-30f)
        return false;
    float s[3] = { ray->origin[0] - tri->v0[0], ray->origin[1] - tri->v0[1], ray->origin[2] - tri->v0[2] };
    float u = (s[0] * p[0] + s[1] * p[1] + s[2] * p[2]) / det;
    float q[3] = { s[1] * e1[2] - s[2] * e1[1], s[2] * e1[0] - s[0] * e1[2], s[0] * e1[1] - s[1] * e1[0] };
    float v = (d[0] * q[0] + d[1] * q[1] + d[2] * q[2]) / det;
    float t = (e2[0] * q[0] + e2[1] * q[1] + e2[2] * q[2]) / det;
    bool inside = u >= -slack && v >= -slack && u + v <= 1.0f + slack;
    bool near_edge = fabsf(u) <= slack || fabsf(v) <= slack || fabsf(u + v - 1.0f) <= slack;
    return inside && near_edge && t >= ray->tmin * (1.0f - 1e-4f) && t <= ray->tmax * (1.0f + 1e-4f);
}

/* Whether any triangle of the scene grazes the ray (brute force; mismatches are rare). */
static bool any_graze(const cv_bvh *bvh, const cv_ray *ray) {
    for (uint32_t i = 0; i < bvh->tri_count; i++)
        if (grazes(&bvh->tris[i], ray, 1e-5f))
            return true;
    return false;
}

/* The ray hits the GPU's triangle at the CPU's t (a tie between coplanar triangles). */
static bool coincident(const cv_bvh *bvh, const cv_ray *ray, const cv_hit *g, const cv_hit *c) {
    if (g->triangle == CV_BVH_INVALID || c->triangle == CV_BVH_INVALID || fabsf(g->t - c->t) > 1e-4f * fabsf(c->t))
        return false;
    for (uint32_t i = 0; i < bvh->tri_count; i++)
        if (bvh->tris[i].prim == g->triangle && bvh->tris[i].instance == g->instance) {
            cv_ray exact = *ray;
            exact.tmin = c->t * (1.0f - 1e-4f);
            exact.tmax = c->t * (1.0f + 1e-4f);
            float ht, hu, hv;
            return grazes(&bvh->tris[i], &exact, 1e-5f) ||
                   cv_intersect_triangle(&bvh->tris[i], &exact, exact.tmax, false, &ht, &hu, &hv);
        }
    return false;
}

/* Hits agree within the tolerance (see the top of this file). */
static bool within_tolerance(const cv_hit *g, const cv_hit *c, uint32_t flags) {
    bool g_miss = g->triangle == CV_BVH_INVALID, c_miss = c->triangle == CV_BVH_INVALID;
    if (g_miss || c_miss || (flags & CV_TRACE_ANY_HIT))
        return g_miss == c_miss;
    return g->triangle == c->triangle && g->instance == c->instance && fabsf(g->t - c->t) <= 1e-4f * fabsf(c->t);
}

/* Traces on the device and on the CPU; returns the number of hits that differ
 * beyond what this adapter is allowed (bits on lavapipe, tolerance elsewhere). */
static uint32_t compare(tracer *t, const cv_ray_set *set, uint32_t flags, cv_hit *gpu_hits) {
    uint32_t n = set->count;
    cv_buffer rays = vkt_buffer(t->ctx, t->dev, RAYS_OFFSET + (uint64_t)n * sizeof(cv_ray), 0, "rays");
    cv_buffer hits = vkt_buffer(t->ctx, t->dev, HITS_OFFSET + (uint64_t)n * sizeof(cv_hit), 0, "hits");
    CHECK_OK(cv_device_write_buffer(t->dev, rays, RAYS_OFFSET, (uint64_t)n * sizeof(cv_ray), set->rays));
    cv_cmdlist list;
    cv_command_list *l;
    CHECK_OK(cv_cmdlist_create(t->ctx, &list));
    CHECK_OK(cv_cmdlist_begin(t->ctx, list, &l));
    cv_cmd_trace_rays(l, CV_QUEUE_COMPUTE,
                      &(cv_trace_rays_args){ .accel = t->accel,
                                             .rays = rays,
                                             .rays_offset = RAYS_OFFSET,
                                             .hits = hits,
                                             .hits_offset = HITS_OFFSET,
                                             .count = n,
                                             .flags = flags });
    CHECK_OK(cv_command_list_end(l));
    CHECK_OK(vkt_run(t->dev, list, NULL));
    CHECK_OK(cv_device_read_buffer(t->dev, hits, HITS_OFFSET, (uint64_t)n * sizeof(cv_hit), gpu_hits));

    cv_hit *cpu_hits = malloc((size_t)n * sizeof(cv_hit));
    cv_trace_target target = { .flat = t->bvh, .layout = CV_BVH_LAYOUT_NODE2 };
    CHECK_OK(cv_trace_batch(&target, set->rays, n, flags, 0, cpu_hits));
    uint32_t bits = 0, beyond = 0, grazing = 0, hit_count = 0;
    for (uint32_t i = 0; i < n; i++) {
        hit_count += cpu_hits[i].triangle != CV_BVH_INVALID;
        if (memcmp(&gpu_hits[i], &cpu_hits[i], sizeof(cv_hit)) == 0)
            continue;
        bits++;
        if (within_tolerance(&gpu_hits[i], &cpu_hits[i], flags))
            continue;
        if (coincident(t->bvh, &set->rays[i], &gpu_hits[i], &cpu_hits[i]) || any_graze(t->bvh, &set->rays[i]))
            grazing++;
        else
            beyond++;
    }
    printf("%-10s flags %u: %u rays, %u hits, %u differ in bits, %u grazing or coincident, %u beyond tolerance\n",
           cv_ray_kind_name(set->kind), flags, n, hit_count, bits, grazing, beyond);
    CHECK(hit_count > 0);
    CHECK(grazing * 1000u <= n);
    uint32_t differ = vkt_is_lavapipe() ? bits : beyond;
    free(cpu_hits);
    CHECK_OK(cv_cmdlist_destroy(t->ctx, list));
    CHECK_OK(cv_buffer_destroy(t->ctx, rays));
    CHECK_OK(cv_buffer_destroy(t->ctx, hits));
    return differ;
}

int main(void) {
    tracer t = { 0 };
    cv_scene *scene = NULL;
    cv_bvh *bvh = NULL;
    CHECK_OK(cv_scene_make_room(7, &scene));
    CHECK_OK(cv_bvh_build_flat(scene, &(cv_bvh_build_options){ .thread_count = 2 }, &bvh));
    CHECK_OK(cv_context_create(NULL, &t.ctx));
    CHECK_OK(vkt_device(t.ctx, vkt_adapter(), "trace", &t.dev));
    if (!t.dev || !bvh)
        return check_report("vk_trace");
    t.bvh = bvh;
    /* This test is about Corvid's own kernel; tests/trace covers both paths. */
    CHECK_OK(cv_vulkan_set_trace_path(t.dev, CV_VULKAN_TRACE_COMPUTE));
    cv_accel_desc desc = { .triangle_count = bvh->tri_count, .node_count = bvh->node2_count, .label = "room" };
    CHECK_OK(cv_accel_create(t.ctx, &desc, &t.accel));
    CHECK_OK(cv_device_load(t.dev, cv_any(t.accel)));
    CHECK_OK(cv_device_write_accel(t.dev, t.accel, bvh->nodes2, bvh->tris));

    cv_ray_set_desc rays = { .width = 96, .height = 64, .random_count = 4096, .seed = 3 };
    cv_ray_set primary = { 0 }, random = { 0 }, shadow = { 0 }, ao = { 0 };
    CHECK_OK(cv_ray_set_make(scene, CV_RAYS_PRIMARY, &rays, &primary));
    CHECK_OK(cv_ray_set_make(scene, CV_RAYS_RANDOM, &rays, &random));
    cv_hit *hits = malloc((size_t)primary.count * sizeof(cv_hit) + (size_t)random.count * sizeof(cv_hit));
    CHECK_EQ_INT(compare(&t, &primary, 0, hits), 0);
    CHECK_OK(cv_ray_set_make_secondary(scene, CV_RAYS_SHADOW, &rays, &primary, hits, &shadow));
    CHECK_OK(cv_ray_set_make_secondary(scene, CV_RAYS_AO_SHORT, &rays, &primary, hits, &ao));
    CHECK_EQ_INT(compare(&t, &random, 0, hits), 0);
    CHECK_EQ_INT(compare(&t, &random, CV_TRACE_CULL_BACK_FACES, hits), 0);
    CHECK_EQ_INT(compare(&t, &shadow, CV_TRACE_ANY_HIT, hits), 0);
    CHECK_EQ_INT(compare(&t, &ao, CV_TRACE_ANY_HIT | CV_TRACE_CULL_BACK_FACES, hits), 0);

    free(hits);
    cv_ray_set_free(&primary);
    cv_ray_set_free(&random);
    cv_ray_set_free(&shadow);
    cv_ray_set_free(&ao);
    cv_context_destroy(t.ctx);
    cv_bvh_destroy(bvh);
    cv_scene_destroy(scene);
    return vkt_report("vk_trace");
}
