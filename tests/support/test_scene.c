/* Hand-built scenes for renderer tests (see test_scene.h). */
#include <math.h>
#include <stddef.h>

#include "test_scene.h"

cv_result cv_test_add_mesh_instance(cv_scene *scene, const cv_mesh_desc *mesh, uint32_t material) {
    cv_instance inst = { .material = material };
    cv_transform_identity(inst.transform);
    cv_result res = cv_scene_add_mesh(scene, mesh, &inst.mesh);
    if (res == CV_OK)
        res = cv_scene_add_instance(scene, &inst, NULL);
    return res;
}

cv_result cv_test_scene_finish(cv_scene *scene, cv_result res, cv_scene **out, cv_bvh **bvh_out) {
    cv_bvh *bvh = NULL;
    if (res == CV_OK)
        res = cv_bvh_build_flat(scene, NULL, &bvh);
    if (res != CV_OK) {
        cv_scene_destroy(scene);
        return res;
    }
    *out = scene;
    *bvh_out = bvh;
    return CV_OK;
}

cv_result cv_test_add_quad(cv_scene *scene, const float c[3], const float a[3], const float b[3],
                           const float *uv_scale, uint32_t material) {
    float n[3] = { a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0] };
    float len = sqrtf(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    float su = uv_scale ? uv_scale[0] : 0.0f, sv = uv_scale ? uv_scale[1] : 0.0f;
    float p[12], normals[12], uvs[8] = { 0, 0, su, 0, su, sv, 0, sv };
    for (int k = 0; k < 3; k++) {
        p[k] = c[k], p[3 + k] = c[k] + a[k], p[6 + k] = c[k] + a[k] + b[k], p[9 + k] = c[k] + b[k];
        for (int v = 0; v < 4; v++)
            normals[v * 3 + k] = n[k] / len;
    }
    static const uint32_t idx[6] = { 0, 1, 2, 0, 2, 3 };
    return cv_test_add_mesh_instance(scene,
                                     &(cv_mesh_desc){ .positions = p,
                                                      .normals = normals,
                                                      .uvs = uv_scale ? uvs : NULL,
                                                      .vertex_count = 4,
                                                      .indices = idx,
                                                      .triangle_count = 2 },
                                     material);
}
