/* Ray tracing on the Vulkan backend: acceleration structures and the two paths
 * that run the trace_rays command (see cv_vulkan_trace_path in vulkan.h).
 *
 *  - compute: shaders/trace_rays.comp, Corvid's traversal of the flat BVH (the
 *    two-child layout of bvh_gpu.h) kept in two buffers; every device has it.
 *  - pipeline: the driver's ray-tracing pipeline on acceleration structures it
 *    builds from the same triangle buffer (vk_trace_rt.h), where offered. They
 *    are built at the accel write unless the device is set to the compute
 *    path, else when a list first traces the accel on the pipeline path.
 *
 * The choice: the mode comes from the device options at creation or from
 * cv_vulkan_set_trace_path; in AUTO mode the adapter's measurement decides
 * (vk_trace_calibrate.h), taken at the first accel write on that adapter in
 * this process. Every kernel reads its data through buffer device addresses,
 * so the rays, hits and BVH arrays are not limited by the storage buffer range. */
#ifndef CORVID_VK_TRACE_H
#define CORVID_VK_TRACE_H

#include "vk_pipelines.h"
#include "vk_trace_job.h"

/* At device creation: the mode of the device options (CV_ERROR_INVALID_ARGUMENT
 * for an unknown value, CV_ERROR_UNSUPPORTED for PIPELINE where not offered). */
cv_result vk_trace_init(cv_backend_device *bd, cv_vulkan_trace_path mode);
/* Releases the trace pipelines (the device is idle). NULL tracer is allowed. */
void vk_trace_finish(cv_backend_device *bd);
/* The path lists compiled now would use. */
cv_vulkan_trace_path vk_trace_path_now(const cv_backend_device *bd);

/* CV_ERROR_LIMIT_EXCEEDED if the arrays do not fit in buffers of the device. */
cv_result vk_accel_create(cv_backend_device *bd, const cv_accel_desc *desc, vk_accel **out);
void vk_accel_destroy(cv_backend_device *bd, vk_accel *a);
/* Uploads the BVH, builds the driver's structures unless the device is set to
 * the compute path, and in AUTO mode measures the paths if this adapter has
 * not been measured yet. */
cv_result vk_accel_write(cv_backend_device *bd, vk_accel *a, const void *nodes, const void *triangles);

/* Before recording a list's trace_rays commands (on `accels`, repeats allowed):
 * the path to record them for, with its pipeline built and, on the pipeline
 * path, the accels' driver structures built (missing or stale ones, with an
 * immediate submission). The path is the one in use, except that in AUTO mode a
 * list tracing an accel larger than the driver's structures can hold is
 * recorded for the compute path. */
cv_result vk_trace_prepare(cv_backend_device *bd, vk_accel *const *accels, uint32_t count,
                           cv_vulkan_trace_path *path);
/* Builds the pipeline of one path (COMPUTE, or PIPELINE where offered). */
cv_result vk_trace_ready(cv_backend_device *bd, cv_vulkan_trace_path path);
/* The accel's driver structures, built now if they are missing or stale (an
 * immediate submission); CV_ERROR_LIMIT_EXCEEDED if the driver cannot hold it. */
cv_result vk_trace_prepare_accel(cv_backend_device *bd, vk_accel *a);
/* Declares the job's uses to the tracker, records the barriers and the trace.
 * It binds its own pipeline and push constants (the compute path on the compute
 * bind point, the other on the ray-tracing one). */
void vk_trace_record(cv_backend_device *bd, cv_vulkan_trace_path path, vk_tracker *tracker, VkCommandBuffer cmd,
                     const vk_trace_job *job);

#endif
