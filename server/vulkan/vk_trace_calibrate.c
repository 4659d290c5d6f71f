/* Measuring the two trace paths on one accel (see vk_trace_calibrate.h). */
#include <math.h>
#include <stdlib.h>

#include "corvid/bvh_gpu.h"
#include "corvid/clock.h"
#include "vk_host_transfer.h"
#include "vk_immediate.h"
#include "vk_resources.h"
#include "vk_trace_calibrate.h"

/* Rays per query: enough to fill a GPU; on a CPU device few enough that the
 * whole measurement (both paths, both queries, all rounds) takes about 0.2 s,
 * since every process's first accel write on lavapipe pays for it. */
#define CPU_RAYS (1u << 14)
#define GPU_RAYS (1u << 20)
#define ROUNDS 3
#define GPU_BUSY_SECONDS 0.3
#define COHERENT_RUN 16u

/* Keys for the barrier tracker, unique within the measurement's recording. */
enum { KEY_ACCEL = 1, KEY_RAYS = 2, KEY_HITS = 3 };

static uint32_t hash(uint32_t x) {
    x ^= x >> 16;
    x *= 0x7feb352dU;
    x ^= x >> 15;
    x *= 0x846ca68bU;
    x ^= x >> 16;
    return x;
}

static void centroid(const cv_bvh_tri *t, float out[3]) {
    for (int k = 0; k < 3; k++)
        out[k] = t->v0[k] + (t->e1[k] + t->e2[k]) / 3.0f;
}

static void make_rays(const cv_bvh_tri *tris, uint32_t tri_count, cv_ray *rays, uint32_t count) {
    for (uint32_t k = 0; k < count; k++) {
        float from[3], to[3], d[3];
        centroid(&tris[(uint64_t)k * tri_count / count], from);
        centroid(&tris[hash(k / COHERENT_RUN) % tri_count], to);
        float len = 0.0f, extent = 1.0f;
        for (int i = 0; i < 3; i++) {
            d[i] = to[i] - from[i];
            len += d[i] * d[i];
            extent = fabsf(from[i]) > extent ? fabsf(from[i]) : extent;
        }
        len = sqrtf(len);
        cv_ray *r = &rays[k];
        for (int i = 0; i < 3; i++) {
            r->origin[i] = from[i];
            r->dir[i] = len > 0.0f && isfinite(len) ? d[i] / len : (i == 2 ? 1.0f : 0.0f);
        }
        r->tmin = extent * 1e-3f;
        r->tmax = INFINITY;
    }
}

static double host_seconds(void) { return (double)cv_now_ns() * 1e-9; }

typedef struct measurement {
    VkQueryPool pool; /* two timestamps, or VK_NULL_HANDLE: host clock */
    vk_trace_job job;
    const vk_trace_paths *paths;
} measurement;

/* One round of one path: a closest-hit and an any-hit trace of all rays. */
static cv_result run_round(cv_backend_device *bd, measurement *m, cv_vulkan_trace_path path, double *seconds) {
    VkCommandBuffer cmd;
    cv_result r = vk_immediate_begin(bd, &cmd);
    if (r != CV_OK)
        return r;
    /* The ray upload, and the previous round's hits, come before this round. */
    VkMemoryBarrier2 before = { .sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER_2,
                                .srcStageMask = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT,
                                .srcAccessMask = VK_ACCESS_2_MEMORY_WRITE_BIT,
                                .dstStageMask = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT,
                                .dstAccessMask = VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT };
    vkCmdPipelineBarrier2(cmd, &(VkDependencyInfo){ .sType = VK_STRUCTURE_TYPE_DEPENDENCY_INFO,
                                                    .memoryBarrierCount = 1,
                                                    .pMemoryBarriers = &before });
    if (m->pool) {
        vkCmdResetQueryPool(cmd, m->pool, 0, 2);
        vkCmdWriteTimestamp2(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, m->pool, 0);
    }
    vk_tracker tracker;
    vk_tracker_init(&tracker);
    const uint32_t flags[2] = { 0, CV_TRACE_ANY_HIT };
    for (int i = 0; i < 2; i++) {
        m->job.flags = flags[i];
        m->paths->record(bd, path, &tracker, cmd, &m->job);
    }
    r = vk_tracker_status(&tracker);
    vk_tracker_finish(&tracker);
    if (m->pool)
        vkCmdWriteTimestamp2(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, m->pool, 1);
    double t0 = host_seconds();
    cv_result end = vk_immediate_end(bd);
    *seconds = host_seconds() - t0;
    if (r != CV_OK || end != CV_OK)
        return r != CV_OK ? r : end;
    if (m->pool) {
        uint64_t ticks[2];
        VkResult vr = vkGetQueryPoolResults(bd->device, m->pool, 0, 2, sizeof(ticks), ticks, sizeof(ticks[0]),
                                            VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT);
        if (vr != VK_SUCCESS)
            return vk_fail(vr, "vkGetQueryPoolResults (trace path measurement)");
        uint64_t mask = bd->queues[VK_SLOT_GRAPHICS].timestamp_mask;
        *seconds = (double)((ticks[1] - ticks[0]) & mask) * bd->timestamp_period_ns * 1e-9;
    }
    return CV_OK;
}

/* At least ROUNDS rounds; on a GPU, rounds for at least GPU_BUSY_SECONDS as
 * well, so that its clock has risen from idle (it takes 0.2-0.3 s of load). */
static cv_result measure(cv_backend_device *bd, measurement *m, vk_trace_calibration *out) {
    double best[2] = { INFINITY, INFINITY };
    const cv_vulkan_trace_path paths[2] = { CV_VULKAN_TRACE_COMPUTE, CV_VULKAN_TRACE_PIPELINE };
    double busy = bd->adapter.info.type == CV_VULKAN_ADAPTER_CPU ? 0.0 : GPU_BUSY_SECONDS;
    double start = host_seconds();
    for (int round = 0; round < ROUNDS || host_seconds() - start < busy; round++)
        for (int p = 0; p < 2; p++) {
            double seconds;
            cv_result r = run_round(bd, m, paths[p], &seconds);
            if (r != CV_OK)
                return r;
            best[p] = seconds < best[p] ? seconds : best[p];
        }
    double rays = 2.0 * m->job.count;
    out->rays = m->job.count;
    out->compute_mrays = best[0] > 0.0 ? rays / best[0] * 1e-6 : INFINITY;
    out->pipeline_mrays = best[1] > 0.0 ? rays / best[1] * 1e-6 : INFINITY;
    return CV_OK;
}

cv_result vk_trace_calibrate(cv_backend_device *bd, const vk_trace_paths *paths, vk_accel *a, const void *triangles,
                             vk_trace_calibration *out) {
    uint32_t count = bd->adapter.info.type == CV_VULKAN_ADAPTER_CPU ? CPU_RAYS : GPU_RAYS;
    cv_ray *rays = malloc((size_t)count * sizeof(*rays));
    if (!rays)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "vulkan: %u rays to measure the trace paths", count);
    make_rays(triangles, a->triangle_count, rays, count);
    measurement m = {
        .job = { .accel = a, .accel_key = KEY_ACCEL, .rays_key = KEY_RAYS, .hits_key = KEY_HITS, .count = count },
        .paths = paths,
    };
    vk_buffer *ray_buffer = NULL, *hit_buffer = NULL;
    cv_result r = vk_buffer_create(bd,
                                   &(cv_buffer_desc){ .size = (uint64_t)count * CV_RAY_BYTES,
                                                      .usage = CV_BUFFER_USAGE_STORAGE,
                                                      .label = "trace measurement rays" },
                                   &ray_buffer);
    if (r == CV_OK)
        r = vk_buffer_create(bd,
                             &(cv_buffer_desc){ .size = (uint64_t)count * CV_HIT_BYTES,
                                                .usage = CV_BUFFER_USAGE_STORAGE,
                                                .label = "trace measurement hits" },
                             &hit_buffer);
    if (r == CV_OK)
        r = vk_host_buffer_write(bd, ray_buffer, 0, ray_buffer->size, rays);
    free(rays);
    m.job.rays = ray_buffer;
    m.job.hits = hit_buffer;
    if (r == CV_OK)
        r = paths->ready(bd, CV_VULKAN_TRACE_COMPUTE);
    if (r == CV_OK)
        r = paths->ready(bd, CV_VULKAN_TRACE_PIPELINE);
    if (r == CV_OK)
        r = paths->prepare_accel(bd, a);
    if (r == CV_OK && bd->queues[VK_SLOT_GRAPHICS].timestamp_mask && bd->timestamp_period_ns > 0) {
        VkQueryPoolCreateInfo info = { .sType = VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO,
                                       .queryType = VK_QUERY_TYPE_TIMESTAMP,
                                       .queryCount = 2 };
        VkResult vr = vkCreateQueryPool(bd->device, &info, NULL, &m.pool);
        if (vr != VK_SUCCESS)
            r = vk_fail(vr, "vkCreateQueryPool (trace path measurement)");
    }
    if (r == CV_OK)
        r = measure(bd, &m, out);
    vkDestroyQueryPool(bd->device, m.pool, NULL);
    if (ray_buffer)
        vk_buffer_destroy(bd, ray_buffer);
    if (hit_buffer)
        vk_buffer_destroy(bd, hit_buffer);
    return r;
}
