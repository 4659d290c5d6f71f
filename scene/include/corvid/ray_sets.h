/* Ray sets for tests and benchmarks: the rays of the hybrid pipeline (seed
 * 000), generated on the CPU, deterministic per seed.
 *
 * Primary rays come from a pinhole camera, one per pixel, jittered inside the
 * pixel, in 4x4 pixel tiles (16 consecutive rays are one tile, so packet
 * tracers get coherent packets). Secondary rays start at the primary hits
 * (one ray per hit, in primary order) with the seed's offset policy,
 * tmin = max(1, |p|) * 1e-3, along the geometric normal turned toward the
 * camera:
 *   SHADOW      toward the sun (against the light's direction), only from
 *               points the sun faces; tmax = infinity; occlusion;
 *   AO_SHORT    cosine-weighted hemisphere, tmax = ao_short_length; occlusion;
 *   AO_LONG     cosine-weighted hemisphere, tmax = infinity; occlusion;
 *   DIFFUSE     cosine-weighted hemisphere, closest hit;
 *   REFLECTION  mirror reflection of the primary ray, closest hit.
 * RANDOM rays are incoherent: origins uniform in the scene bounds, directions
 * uniform on the sphere, closest hit. All directions are unit length. */
#ifndef CORVID_RAY_SETS_H
#define CORVID_RAY_SETS_H

#include <stdbool.h>
#include <stdint.h>
#include "corvid/bvh_gpu.h"
#include "corvid/scene.h"

typedef enum cv_ray_kind {
    CV_RAYS_PRIMARY = 0,
    CV_RAYS_SHADOW,
    CV_RAYS_AO_SHORT,
    CV_RAYS_AO_LONG,
    CV_RAYS_DIFFUSE,
    CV_RAYS_REFLECTION,
    CV_RAYS_RANDOM,
    CV_RAY_KIND_COUNT
} cv_ray_kind;

/* "primary", "shadow", "ao_short", "ao_long", "diffuse", "reflection", "random". */
const char *cv_ray_kind_name(cv_ray_kind kind);
/* True for shadow and AO rays: traced as any-hit queries. */
bool cv_ray_kind_is_occlusion(cv_ray_kind kind);

/* Zero fields take the defaults in brackets. */
typedef struct cv_ray_set_desc {
    uint32_t width, height;  /* [256 x 256] primary rays */
    const cv_camera *camera; /* [the scene's first camera, else cv_scene_framing_camera] */
    float sun_direction[3];  /* direction sunlight travels [the scene's first
                                   directional light, else (-0.3, -1, -0.2) normalized] */
    float ao_short_length;   /* [0.5] metres */
    uint32_t random_count;   /* [65536] RANDOM rays */
    uint32_t seed;           /* jitter and sampling */
} cv_ray_set_desc;

typedef struct cv_ray_set {
    cv_ray_kind kind;
    cv_ray *rays; /* malloc'd; free with cv_ray_set_free */
    uint32_t count;
} cv_ray_set;

/* PRIMARY or RANDOM rays (need no hits). */
cv_result cv_ray_set_make(const cv_scene *scene, cv_ray_kind kind, const cv_ray_set_desc *desc, cv_ray_set *out);
/* A secondary set from primary rays and their closest hits (from any tracer
 * that reports instance and triangle ids of `scene`). */
cv_result cv_ray_set_make_secondary(const cv_scene *scene, cv_ray_kind kind, const cv_ray_set_desc *desc,
                                    const cv_ray_set *primary, const cv_hit *primary_hits, cv_ray_set *out);
void cv_ray_set_free(cv_ray_set *set);

#endif
