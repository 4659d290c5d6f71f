/* trace_rays on the Vulkan backend against the CPU reference traversal: the
 * procedural room, a flat BVH in the two-child layout, and primary, random,
 * shadow and AO rays. The kernel runs the same traversal with the same
 * rounding as scene/src/trace_cpu.c, so every hit must match bit for bit:
 * closest hits (t, u, v, triangle, instance), any-hit occlusion, and
 * back-face culling. Rays and hits sit at offsets inside larger buffers. */
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

/* Traces on the device and on the CPU; returns the number of differing hits. */
static uint32_t compare(tracer *t, const cv_ray_set *set, uint32_t flags, cv_hit *gpu_hits) {
    uint32_t n = set->count;
    cv_buffer rays = vkt_buffer(t->ctx, t->dev, RAYS_OFFSET + (uint64_t)n * sizeof(cv_ray), 0, "rays");
    cv_buffer hits = vkt_buffer(t->ctx, t->dev, HITS_OFFSET + (uint64_t)n * sizeof(cv_hit), 0, "hits");
    CHECK_OK(cv_device_write_buffer(t->dev, rays, RAYS_OFFSET, (uint64_t)n * sizeof(cv_ray), set->rays));
    cv_cmdlist list;
    cv_command_list *l;
    CHECK_OK(cv_cmdlist_create(t->ctx, &list));
    CHECK_OK(cv_cmdlist_begin(t->ctx, list, &l));
    cv_cmd_trace_rays(l, CV_QUEUE_COMPUTE, &(cv_trace_rays_args){ .accel = t->accel, .rays = rays,
                                                                .rays_offset = RAYS_OFFSET, .hits = hits,
                                                                .hits_offset = HITS_OFFSET, .count = n,
                                                                .flags = flags });
    CHECK_OK(cv_command_list_end(l));
    CHECK_OK(vkt_run(t->dev, list, NULL));
    CHECK_OK(cv_device_read_buffer(t->dev, hits, HITS_OFFSET, (uint64_t)n * sizeof(cv_hit), gpu_hits));

    cv_hit *cpu_hits = malloc((size_t)n * sizeof(cv_hit));
    cv_trace_target target = { .flat = t->bvh, .layout = CV_BVH_LAYOUT_NODE2 };
    CHECK_OK(cv_trace_batch(&target, set->rays, n, flags, 0, cpu_hits));
    uint32_t differ = 0, hit_count = 0;
    for (uint32_t i = 0; i < n; i++) {
        differ += memcmp(&gpu_hits[i], &cpu_hits[i], sizeof(cv_hit)) != 0;
        hit_count += cpu_hits[i].triangle != CV_BVH_INVALID;
    }
    printf("%-10s flags %u: %u rays, %u hits, %u differ\n", cv_ray_kind_name(set->kind), flags, n, hit_count,
           differ);
    CHECK(hit_count > 0);
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
    CHECK_OK(vkt_device(t.ctx, NULL, "trace", &t.dev));
    if (!t.dev || !bvh)
        return check_report("vk_trace");
    t.bvh = bvh;
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
