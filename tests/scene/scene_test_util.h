/* Helpers shared by the scene tests: a content hash of a scene, a
 * brute-force ray tracer over every world triangle, test-model paths, and
 * whole-file reads and writes. */
#ifndef CORVID_SCENE_TEST_UTIL_H
#define CORVID_SCENE_TEST_UTIL_H

#include <stdbool.h>
#include <stdint.h>
#include "corvid/bvh.h"
#include "corvid/scene.h"

/* FNV-1a over every byte of the scene's meshes, materials (field by field),
 * images (sizes, every level's texels, name), instances, cameras and lights,
 * in index order. */
uint64_t scene_hash(const cv_scene *scene);
uint64_t fnv1a(uint64_t h, const void *data, size_t size);

/* Every world triangle as the flat BVH stores it (cv_bvh_tri_make over
 * cv_scene_world_triangle), in scene order; *count gets the number. */
cv_bvh_tri *brute_force_triangles(const cv_scene *scene, uint32_t *count);

/* The closest (or, with CV_TRACE_ANY_HIT, the first in scene order) hit over
 * those triangles, with the traversal's own intersection test. */
bool brute_force_trace(const cv_bvh_tri *tris, uint32_t count, const cv_ray *ray, uint32_t flags, cv_hit *hit);

/* brute_force_trace over rays[0..n) on all CPUs; returns the number of hits. */
uint32_t brute_force_batch(const cv_bvh_tri *tris, uint32_t count, const cv_ray *rays, uint32_t n, uint32_t flags,
                           cv_hit *hits);

/* A file written whole (a CHECK fails if it cannot be), and read whole: NULL
 * if it cannot be read; one byte more is allocated than *size says. */
void write_whole_file(const char *path, const void *data, size_t size);
void *read_whole_file(const char *path, size_t *size);

/* Path of an assimp test model ("OBJ/spider.obj"), in a static buffer. */
const char *model_path(const char *relative);
bool file_exists(const char *path);

#endif
