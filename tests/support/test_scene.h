/* Hand-built scenes for renderer tests: a mesh with one identity instance,
 * a quad (the shape most such scenes start from), and the last step, the
 * flat BVH, that either hands both over or destroys the scene.
 *
 *     cv_scene *scene = NULL;
 *     cv_result res = cv_scene_create(&scene);
 *     const float corner[3] = { -1, 0, 1 }, u[3] = { 2, 0, 0 }, v[3] = { 0, 0, -2 };
 *     if (res == CV_OK)
 *         res = cv_test_add_quad(scene, corner, u, v, NULL, 0);   // no uvs
 *     ...
 *     res = cv_test_scene_finish(scene, res, &out, &bvh);         // scene destroyed on failure
 */
#ifndef CORVID_TEST_SCENE_H
#define CORVID_TEST_SCENE_H

#include "corvid/bvh.h"
#include "corvid/scene.h"

/* Adds `mesh` and one identity instance of it with `material`. */
cv_result cv_test_add_mesh_instance(cv_scene *scene, const cv_mesh_desc *mesh, uint32_t material);

/* A quad with corner c and edges a and b (normal a x b, unit length, the same
 * at all four vertices); uv_scale NULL: no uvs, else uvs (0, 0) at c to
 * (uv_scale[0], uv_scale[1]) at c + a + b, u along a. */
cv_result cv_test_add_quad(cv_scene *scene, const float c[3], const float a[3], const float b[3],
                           const float *uv_scale, uint32_t material);

/* res: how building the scene went. CV_OK: builds its flat BVH and gives
 * both (*out, *bvh_out); on any failure the scene is destroyed and the error
 * returned. */
cv_result cv_test_scene_finish(cv_scene *scene, cv_result res, cv_scene **out, cv_bvh **bvh_out);

#endif
