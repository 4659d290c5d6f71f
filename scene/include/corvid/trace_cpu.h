/* CPU reference traversal over the GPU layouts of bvh_gpu.h.
 *
 * These functions read exactly the arrays a GPU kernel reads and apply the
 * ray-box and ray-triangle rules documented in bvh_gpu.h, so a kernel's hits
 * can be compared with them ray for ray. Two traversals per layout:
 *  - CV_BVH_LAYOUT_SKIP: stackless, depth-first order with skip links (seed 001);
 *  - CV_BVH_LAYOUT_NODE2: a stack, both children tested per node, the nearer
 *    child visited first.
 * Both report the same closest hit up to ties in t (equal t on two triangles:
 * the first found is kept, and the visiting order differs).
 *
 * Queries: closest hit (t, u, v, triangle, instance), or any hit (occlusion:
 * stop at the first triangle found; the hit is a valid one but not necessarily
 * the closest). Optional back-face culling (det <= epsilon is a miss). */
#ifndef CORVID_TRACE_CPU_H
#define CORVID_TRACE_CPU_H

#include <stdbool.h>
#include <stdint.h>
#include "corvid/bvh.h"
#include "corvid/types.h"

typedef enum cv_bvh_layout {
    CV_BVH_LAYOUT_SKIP = 0,
    CV_BVH_LAYOUT_NODE2 = 1,
} cv_bvh_layout;

/* Flags are the trace_rays command's (corvid/types.h): CV_TRACE_ANY_HIT,
 * CV_TRACE_CULL_BACK_FACES; CV_TRACE_CLOSEST (0) names the default. */
#define CV_TRACE_CLOSEST 0u

/* What to trace against: exactly one of flat and two_level is set. */
typedef struct cv_trace_target {
    const cv_bvh *flat;
    const cv_scene_bvh *two_level;
    cv_bvh_layout layout;
} cv_trace_target;

/* A miss: t = INFINITY, u = v = 0, triangle = instance = CV_BVH_INVALID. */
cv_hit cv_hit_miss(void);

/* One ray; returns whether it hit (hit->triangle != CV_BVH_INVALID). */
bool cv_trace_ray(const cv_trace_target *target, const cv_ray *ray, uint32_t flags, cv_hit *hit);

/* count rays into hits[count], split over thread_count threads (0 = all
 * online CPUs). Results do not depend on the thread count. */
cv_result cv_trace_batch(const cv_trace_target *target, const cv_ray *rays, uint32_t count, uint32_t flags,
                         uint32_t thread_count, cv_hit *hits);

/* The ray-triangle test itself: hit when tmin <= t < t_limit. Writes t, u, v
 * only on a hit. Brute-force references use it to match the BVH bit for bit. */
bool cv_intersect_triangle(const cv_bvh_tri *tri, const cv_ray *ray, float t_limit, bool cull_back_faces, float *t,
                           float *u, float *v);

#endif
