/* Hand-built scenes for renderer tests: one quad (two triangles, one
 * instance), the shape every such test starts from.
 *
 *     uint32_t mat;
 *     cv_scene_add_material(scene, &m, &mat);
 *     const float corner[3] = { -1, 0, -1 }, u[3] = { 2, 0, 0 }, v[3] = { 0, 0, 2 };
 *     CHECK_OK(cv_test_add_quad(scene, corner, u, v, NULL, mat));   // no uvs
 */
#ifndef CORVID_TEST_QUAD_H
#define CORVID_TEST_QUAD_H

#include "corvid/scene.h"

/* A quad with corner c and edges a and b (normal a x b, unit length, the same
 * at all four vertices); uv_scale NULL: no uvs, else uvs (0, 0) at c to
 * (uv_scale[0], uv_scale[1]) at c + a + b, u along a. Adds the mesh and one
 * identity instance of it with `material`. */
cv_result cv_test_add_quad(cv_scene *scene, const float c[3], const float a[3], const float b[3],
                           const float *uv_scale, uint32_t material);

#endif
