/* The scene model: adding elements, counts, world-space triangles, bounds,
 * computed normals, transforms, and rejection of bad input (a failed call
 * changes nothing). */
#include <math.h>
#include <string.h>

#include "check.h"
#include "corvid/scene.h"

static const float quad_pos[] = { 0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0 };
static const uint32_t quad_idx[] = { 0, 1, 2, 0, 2, 3 };

static bool near(float a, float b) { return fabsf(a - b) <= 1e-6f * (1.0f + fabsf(b)); }

static void test_build_and_count(void) {
    cv_scene *s;
    CHECK_OK(cv_scene_create(&s));
    cv_mesh_desc quad = {
        .positions = quad_pos, .vertex_count = 4, .indices = quad_idx, .triangle_count = 2, .name = "quad"
    };
    uint32_t mesh = 99, mat = 99, inst = 99;
    CHECK_OK(cv_scene_add_mesh(s, &quad, &mesh));
    CHECK_EQ_INT(mesh, 0);
    cv_material m = cv_material_default();
    CHECK_OK(cv_scene_add_material(s, &m, &mat));
    CHECK_EQ_INT(mat, 0);
    /* Two instances: one shifted by (10, 0, 0), one scaled by 2 around the origin. */
    cv_instance a = { .mesh = 0, .material = 0 };
    cv_transform_identity(a.transform);
    a.transform[0][3] = 10.0f;
    CHECK_OK(cv_scene_add_instance(s, &a, &inst));
    CHECK_EQ_INT(inst, 0);
    cv_instance b = { .mesh = 0, .material = 0 };
    cv_transform_identity(b.transform);
    b.transform[0][0] = b.transform[1][1] = b.transform[2][2] = 2.0f;
    CHECK_OK(cv_scene_add_instance(s, &b, &inst));
    CHECK_EQ_INT(inst, 1);

    CHECK_EQ_INT(cv_scene_mesh_count(s), 1);
    CHECK_EQ_INT(cv_scene_instance_count(s), 2);
    CHECK_EQ_INT(cv_scene_triangle_count(s), 2);
    CHECK_EQ_INT(cv_scene_world_triangle_count(s), 4);

    const cv_mesh *stored = cv_scene_mesh(s, 0);
    CHECK(stored && strcmp(stored->name, "quad") == 0 && stored->uvs == NULL);
    /* Normals computed from the counter-clockwise quad: +z everywhere. */
    for (uint32_t v = 0; v < 4; v++)
        CHECK(stored->normals[3 * v] == 0.0f && stored->normals[3 * v + 1] == 0.0f &&
              stored->normals[3 * v + 2] == 1.0f);
    CHECK(cv_scene_mesh(s, 1) == NULL && cv_scene_instance(s, 2) == NULL);

    float v[3][3];
    cv_scene_world_triangle(s, 0, 1, v); /* (0,0,0) (1,1,0) (0,1,0) + (10,0,0) */
    CHECK(v[0][0] == 10.0f && v[1][0] == 11.0f && v[1][1] == 1.0f && v[2][0] == 10.0f && v[2][1] == 1.0f);
    cv_scene_world_triangle(s, 1, 0, v); /* (0,0,0) (2,0,0) (2,2,0) */
    CHECK(v[1][0] == 2.0f && v[2][0] == 2.0f && v[2][1] == 2.0f);

    float bmin[3], bmax[3];
    cv_scene_bounds(s, bmin, bmax);
    CHECK(bmin[0] == 0.0f && bmin[1] == 0.0f && bmax[0] == 11.0f && bmax[1] == 2.0f && bmax[2] == 0.0f);

    cv_camera cam = cv_scene_framing_camera(s);
    float d[3] = { cam.target[0] - cam.position[0], cam.target[1] - cam.position[1],
                   cam.target[2] - cam.position[2] };
    CHECK(near(cam.target[0], 5.5f) && near(cam.target[1], 1.0f) && d[0] < 0 && d[1] < 0 && d[2] < 0);

    /* Moving an instance and deforming a mesh. */
    float t[3][4];
    cv_transform_identity(t);
    t[1][3] = -3.0f;
    CHECK_OK(cv_scene_set_instance_transform(s, 0, t));
    cv_scene_world_triangle(s, 0, 0, v);
    CHECK(v[0][0] == 0.0f && v[0][1] == -3.0f);
    float moved[12];
    for (int i = 0; i < 12; i++)
        moved[i] = quad_pos[i] * 3.0f;
    CHECK_OK(cv_scene_set_mesh_positions(s, 0, moved, 4));
    cv_scene_world_triangle(s, 1, 0, v);
    CHECK(v[1][0] == 6.0f);
    cv_scene_destroy(s);
}

static void test_rejections(void) {
    cv_scene *s;
    CHECK_OK(cv_scene_create(&s));
    const uint32_t bad_idx[] = { 0, 1, 4 };
    cv_mesh_desc bad = {
        .positions = quad_pos, .vertex_count = 4, .indices = bad_idx, .triangle_count = 1, .name = "broken"
    };
    CHECK_RESULT(cv_scene_add_mesh(s, &bad, NULL), CV_ERROR_INVALID_ARGUMENT);
    CHECK(strstr(cv_last_error(), "broken") && strstr(cv_last_error(), "index 2"));
    float nan_pos[12];
    memcpy(nan_pos, quad_pos, sizeof nan_pos);
    nan_pos[4] = NAN;
    cv_mesh_desc nan_mesh = { .positions = nan_pos, .vertex_count = 4, .indices = quad_idx, .triangle_count = 2 };
    CHECK_RESULT(cv_scene_add_mesh(s, &nan_mesh, NULL), CV_ERROR_INVALID_ARGUMENT);
    CHECK(strstr(cv_last_error(), "vertex 1") != NULL);
    cv_mesh_desc empty = { .positions = quad_pos, .vertex_count = 4, .indices = quad_idx, .triangle_count = 0 };
    CHECK_RESULT(cv_scene_add_mesh(s, &empty, NULL), CV_ERROR_INVALID_ARGUMENT);
    CHECK_EQ_INT(cv_scene_mesh_count(s), 0);

    cv_mesh_desc quad = { .positions = quad_pos, .vertex_count = 4, .indices = quad_idx, .triangle_count = 2 };
    CHECK_OK(cv_scene_add_mesh(s, &quad, NULL));
    cv_material m = cv_material_default();
    m.ior = 0.5f;
    CHECK_RESULT(cv_scene_add_material(s, &m, NULL), CV_ERROR_INVALID_ARGUMENT);
    m = cv_material_default();
    CHECK_OK(cv_scene_add_material(s, &m, NULL));

    cv_instance inst = { .mesh = 1, .material = 0 };
    cv_transform_identity(inst.transform);
    CHECK_RESULT(cv_scene_add_instance(s, &inst, NULL), CV_ERROR_INVALID_ARGUMENT);
    CHECK(strstr(cv_last_error(), "mesh 1") != NULL);
    inst.mesh = 0;
    inst.material = 3;
    CHECK_RESULT(cv_scene_add_instance(s, &inst, NULL), CV_ERROR_INVALID_ARGUMENT);
    inst.material = 0;
    inst.transform[2][2] = 0.0f;
    CHECK_RESULT(cv_scene_add_instance(s, &inst, NULL), CV_ERROR_INVALID_ARGUMENT);
    CHECK(strstr(cv_last_error(), "singular") != NULL);
    inst.transform[2][2] = INFINITY;
    CHECK_RESULT(cv_scene_add_instance(s, &inst, NULL), CV_ERROR_INVALID_ARGUMENT);
    CHECK_EQ_INT(cv_scene_instance_count(s), 0);

    cv_transform_identity(inst.transform);
    CHECK_OK(cv_scene_add_instance(s, &inst, NULL));
    float singular[3][4] = { { 0 } };
    CHECK_RESULT(cv_scene_set_instance_transform(s, 0, singular), CV_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(cv_scene_set_instance_transform(s, 1, inst.transform), CV_ERROR_OUT_OF_RANGE);
    CHECK(cv_scene_instance(s, 0)->transform[0][0] == 1.0f);
    CHECK_RESULT(cv_scene_set_mesh_positions(s, 0, quad_pos, 3), CV_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(cv_scene_set_mesh_positions(s, 0, nan_pos, 4), CV_ERROR_INVALID_ARGUMENT);
    CHECK(cv_scene_mesh(s, 0)->positions[4] == 0.0f);

    cv_camera cam = { .position = { 0, 0, 0 }, .target = { 0, 1, 0 }, .up = { 0, 2, 0 }, .vertical_fov = 1.0f };
    CHECK_RESULT(cv_scene_add_camera(s, &cam, NULL), CV_ERROR_INVALID_ARGUMENT);
    cam.up[0] = 1.0f;
    cam.vertical_fov = 3.2f;
    CHECK_RESULT(cv_scene_add_camera(s, &cam, NULL), CV_ERROR_INVALID_ARGUMENT);
    cam.vertical_fov = 1.0f;
    CHECK_OK(cv_scene_add_camera(s, &cam, NULL));

    cv_light sun = { .type = CV_LIGHT_DIRECTIONAL, .color = { 1, 1, 1 }, .intensity = 1 };
    CHECK_RESULT(cv_scene_add_light(s, &sun, NULL), CV_ERROR_INVALID_ARGUMENT);
    sun.direction[1] = -4.0f;
    CHECK_OK(cv_scene_add_light(s, &sun, NULL));
    CHECK(cv_scene_light(s, 0)->direction[1] == -1.0f); /* stored normalized */
    CHECK_EQ_INT(cv_scene_camera_count(s), 1);
    CHECK_EQ_INT(cv_scene_light_count(s), 1);
    cv_scene_destroy(s);
}

static void test_transforms(void) {
    const float t[3][4] = { { 0.0f, -2.0f, 0.0f, 5.0f }, { 3.0f, 0.0f, 0.0f, -1.0f }, { 0.0f, 0.0f, 0.5f, 2.0f } };
    float inv[3][4], prod[3][4];
    CHECK(cv_transform_invert(t, inv));
    cv_transform_multiply(t, inv, prod);
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 4; j++)
            CHECK(fabsf(prod[i][j] - (i == j ? 1.0f : 0.0f)) < 1e-6f);
    const float p[3] = { 1.0f, 2.0f, 3.0f };
    float q[3], back[3];
    cv_transform_point(t, p, q);
    CHECK(q[0] == 1.0f && q[1] == 2.0f && q[2] == 3.5f);
    cv_transform_point(inv, q, back);
    CHECK(near(back[0], 1.0f) && near(back[1], 2.0f) && near(back[2], 3.0f));
    const float flat[3][4] = { { 1, 0, 0, 0 }, { 0, 1, 0, 0 }, { 1, 1, 0, 0 } };
    CHECK(!cv_transform_invert(flat, inv));
}

int main(void) {
    test_build_and_count();
    test_rejections();
    test_transforms();
    return check_report("test_scene_model");
}
