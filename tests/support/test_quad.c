/* One quad for hand-built renderer test scenes (see test_quad.h). */
#include <math.h>
#include <stddef.h>

#include "test_quad.h"

cv_result cv_test_add_quad(cv_scene *scene, const float c[3], const float a[3], const float b[3],
                           const float *uv_scale, uint32_t material) {
    float n[3] = { a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0] };
    float len = sqrtf(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    float p[12], normals[12], uvs[8] = { 0 };
    for (int k = 0; k < 3; k++) {
        p[k] = c[k], p[3 + k] = c[k] + a[k], p[6 + k] = c[k] + a[k] + b[k], p[9 + k] = c[k] + b[k];
        for (int v = 0; v < 4; v++)
            normals[v * 3 + k] = n[k] / len;
    }
    if (uv_scale) {
        float su = uv_scale[0], sv = uv_scale[1];
        float corners[8] = { 0, 0, su, 0, su, sv, 0, sv };
        for (int i = 0; i < 8; i++)
            uvs[i] = corners[i];
    }
    static const uint32_t idx[6] = { 0, 1, 2, 0, 2, 3 };
    uint32_t mesh = 0;
    cv_result res = cv_scene_add_mesh(scene,
                                      &(cv_mesh_desc){ .positions = p,
                                                       .normals = normals,
                                                       .uvs = uv_scale ? uvs : NULL,
                                                       .vertex_count = 4,
                                                       .indices = idx,
                                                       .triangle_count = 2 },
                                      &mesh);
    cv_instance inst = { .mesh = mesh, .material = material };
    cv_transform_identity(inst.transform);
    if (res == CV_OK)
        res = cv_scene_add_instance(scene, &inst, NULL);
    return res;
}
