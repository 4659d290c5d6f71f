/* Embree 3, the benchmark peer of Corvid's CPU BVH: the same world-space
 * triangles (geometry i = instance i, so geomID/primID line up with Corvid's
 * instance/triangle ids) and the same rays. */
#ifndef CORVID_BENCH_EMBREE_PEER_H
#define CORVID_BENCH_EMBREE_PEER_H

#include <stdbool.h>
#include <stdint.h>
#include "corvid/bvh_gpu.h"
#include "corvid/scene.h"

typedef struct embree_peer embree_peer;

/* An Embree device with `threads` build threads and a scene of the world
 * triangles. *commit_seconds is the time of rtcCommitScene alone (the BVH
 * build); filling the vertex buffers is not counted. NULL on failure
 * (the reason is printed). */
embree_peer *embree_peer_create(const cv_scene *scene, uint32_t threads, double *commit_seconds);
/* Builds the scene again (new scene object, same geometry); returns the commit time. */
double embree_peer_rebuild(embree_peer *peer);
void embree_peer_destroy(embree_peer *peer);

/* "3.13.5": the Embree this was built against. */
const char *embree_peer_version(void);

/* "Embree 3.13.5 (native 16-wide packets: yes)". */
const char *embree_peer_describe(const embree_peer *peer);

/* Traces rays with rtcIntersect1 / rtcOccluded1 (width 1) or rtcIntersect16 /
 * rtcOccluded16 (width 16) on `threads` threads. Closest hits are written as
 * cv_hit (instance = geomID, triangle = primID); occlusion writes t = 0 and
 * ids 0 for an occluded ray, a miss (cv_hit_miss) otherwise. */
void embree_peer_trace(embree_peer *peer, const cv_ray *rays, uint32_t count, bool occlusion, int width,
                       uint32_t threads, cv_hit *hits);

#endif
