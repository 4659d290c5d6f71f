/* What the trace paths of trace_rays share (vk_trace.h): the accel as the
 * device holds it and one trace_rays command as the paths record it; below
 * the tracer, its measurement and the driver's path, which all use them. */
#ifndef CORVID_VK_TRACE_JOB_H
#define CORVID_VK_TRACE_JOB_H

#include "vk_barriers.h"
#include "vk_objects.h"

typedef struct vk_rt_accel vk_rt_accel;

typedef struct vk_accel {
    vk_buffer *nodes;     /* node_count cv_bvh_node2 */
    vk_buffer *triangles; /* triangle_count cv_bvh_tri */
    uint32_t node_count, triangle_count;
    char label[CV_LABEL_MAX];
    vk_rt_accel *rt; /* the driver's structures; NULL until first needed */
    bool rt_stale;   /* rt does not hold the latest triangles */
} vk_accel;

/* One trace_rays command as the paths record it. The keys name the buffers to
 * the barrier tracker (resource handles, or any ids unique within a recording). */
typedef struct vk_trace_job {
    vk_accel *accel;
    uint64_t accel_key;
    const vk_buffer *rays, *hits;
    uint64_t rays_key, hits_key;
    uint64_t rays_offset, hits_offset;
    uint32_t count, flags;
} vk_trace_job;

/* Where the compute kernel's 2D grid of 64-ray groups, and the ray-generation
 * grid of the pipeline path, wrap (both linearise x + y * width). */
#define VK_TRACE_GROUP_SIZE 64u
#define VK_TRACE_LAUNCH_WIDTH 32768u

#endif
