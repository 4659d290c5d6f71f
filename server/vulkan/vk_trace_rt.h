/* The pipeline path of trace_rays: the driver's VK_KHR_ray_tracing_pipeline on
 * VK_KHR_acceleration_structure, where the adapter offers both.
 *
 * Acceleration structures (vk_rt_accel): one BLAS over the accel's triangles
 * and a TLAS holding one identity instance of it. The BLAS vertices are v0,
 * v0 + e1, v0 + e2 of each cv_bvh_tri, expanded on the GPU from the accel's
 * triangle buffer (shaders/trace_rt_vertices.comp) in the array's order, so
 * gl_PrimitiveID is the index into that array and hits report the same prim
 * and instance ids as the compute path. The geometry is opaque. Structures
 * are sized by the triangle count alone, so they are created once and rebuilt
 * in place on every build.
 *
 * The pipeline (vk_rt): trace_rt.rgen reads one cv_ray per launch index and
 * calls traceRayEXT with tmin/tmax and the command's flags (any hit: terminate
 * on the first hit; back-face culling: cull back-facing triangles, whose facing
 * Vulkan decides as bvh_gpu.h does, det > 0 being front), trace_rt.rchit
 * reports t, barycentrics and gl_PrimitiveID, trace_rt.rmiss a miss; the
 * raygen shader writes the cv_hit. The closest-hit shader also runs for any-hit
 * queries, so their hits carry a valid t and triangle like the compute path's.
 * Data is reached through buffer device addresses in push constants. */
#ifndef CORVID_VK_TRACE_RT_H
#define CORVID_VK_TRACE_RT_H

#include "vk_device_core.h"
#include "vk_trace_job.h"

typedef struct vk_rt vk_rt;
typedef struct vk_rt_accel vk_rt_accel;

#define VK_RT_EXTENSION_COUNT 3u
/* The device extensions the path needs, enabled at device creation when offered. */
extern const char *const vk_rt_extensions[VK_RT_EXTENSION_COUNT];

/* Whether the adapter offers the extensions and their features
 * (accelerationStructure, rayTracingPipeline). */
bool vk_rt_offered(VkPhysicalDevice physical);

/* Entry points and properties (bd->ray_tracing must be set). */
cv_result vk_rt_create(cv_backend_device *bd, vk_rt **out);
void vk_rt_destroy(cv_backend_device *bd, vk_rt *rt);
/* Builds the ray-tracing pipeline and its shader binding table, once. */
cv_result vk_rt_prepare(cv_backend_device *bd, vk_rt *rt);

/* Creates the structures for triangle_count triangles (label for messages). */
cv_result vk_rt_accel_create(cv_backend_device *bd, vk_rt *rt, uint32_t triangle_count, const char *label,
                             vk_rt_accel **out);
void vk_rt_accel_destroy(cv_backend_device *bd, vk_rt *rt, vk_rt_accel *a);
/* Builds BLAS and TLAS from the triangle buffer on the immediate command
 * buffer and waits for it. The structures must not be in use. */
cv_result vk_rt_accel_build(cv_backend_device *bd, vk_rt *rt, vk_rt_accel *a, const vk_buffer *triangles);

/* Records one trace (vk_rt_prepare done, the job's accel built): declares the
 * uses of the triangle (under triangles_key), ray and hit buffers, then binds,
 * pushes and traces. */
void vk_rt_record(vk_rt *rt, vk_tracker *tracker, VkCommandBuffer cmd, const vk_trace_job *job,
                  uint64_t triangles_key);

#endif
