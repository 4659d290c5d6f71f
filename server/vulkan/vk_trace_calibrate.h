/* The measurement behind AUTO mode (vulkan.h, cv_vulkan_trace_path): both trace
 * paths on the same rays against one accel, each timed on the GPU (timestamps)
 * where the queue has them, else on the host clock.
 *
 * The rays join points of the accel's own triangles: each starts at the
 * centroid of a triangle taken in array (leaf, so spatial) order and heads for
 * the centroid of another triangle, shared by runs of 16 rays, so neighbouring
 * rays are coherent, as shadow and AO rays are, without being identical. Each
 * path traces them as closest-hit and as any-hit queries, in rounds taking
 * turns (three; on a GPU, for 0.3 s at least, since its clock rises from idle
 * only under load); the best round of each path counts. */
#ifndef CORVID_VK_TRACE_CALIBRATE_H
#define CORVID_VK_TRACE_CALIBRATE_H

#include "vk_device_core.h"
#include "vk_trace_job.h"

typedef struct vk_trace_calibration {
    uint32_t rays; /* per query */
    double compute_mrays, pipeline_mrays;
} vk_trace_calibration;

/* The tracer's calls the measurement drives (vk_trace.h's vk_trace_ready,
 * vk_trace_prepare_accel and vk_trace_record): handed in by the tracer, which
 * runs the measurement, so that this module sits below it. */
typedef struct vk_trace_paths {
    cv_result (*ready)(cv_backend_device *bd, cv_vulkan_trace_path path);
    cv_result (*prepare_accel)(cv_backend_device *bd, vk_accel *a);
    void (*record)(cv_backend_device *bd, cv_vulkan_trace_path path, vk_tracker *tracker, VkCommandBuffer cmd,
                   const vk_trace_job *job);
} vk_trace_paths;

/* `a` was written from `triangles` (its cv_bvh_tri array) and its driver
 * structures are built; both paths' pipelines are built here. */
cv_result vk_trace_calibrate(cv_backend_device *bd, const vk_trace_paths *paths, vk_accel *a, const void *triangles,
                             vk_trace_calibration *out);

#endif
