/* Ray tracing on the Vulkan backend: acceleration structures (a flat BVH in
 * the two-child layout of bvh_gpu.h, kept in two storage buffers) and the
 * compute traversal pipeline that runs the trace_rays command. */
#ifndef CORVID_VK_TRACE_H
#define CORVID_VK_TRACE_H

#include "vk_pipelines.h"
#include "vk_resources.h"

typedef struct vk_accel {
    vk_buffer *nodes;              /* node_count cv_bvh_node2 */
    vk_buffer *triangles;          /* triangle_count cv_bvh_tri */
    uint32_t node_count, triangle_count;
} vk_accel;

/* Push constants of the traversal kernel (shaders/trace_rays.comp). */
typedef struct vk_trace_push {
    uint32_t count, flags, node_count, triangle_count;
} vk_trace_push;

#define VK_TRACE_GROUP_SIZE 64u

/* CV_ERROR_LIMIT_EXCEEDED if either array exceeds the device's storage buffer range. */
cv_result vk_accel_create(cv_backend_device *bd, const cv_accel_desc *desc, vk_accel **out);
void vk_accel_destroy(cv_backend_device *bd, vk_accel *a);
cv_result vk_accel_write(cv_backend_device *bd, vk_accel *a, const void *nodes, const void *triangles);

/* The device's traversal pipeline, built on first use, released with the device. */
cv_result vk_trace_pipeline(cv_backend_device *bd, const vk_pipeline **out);
void vk_trace_finish(cv_backend_device *bd);

#endif
