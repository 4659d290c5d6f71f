/* The stress scene: a chosen number of triangles as instanced blobs.
 *
 * BLOB_MESHES shared blob meshes of T triangles each, T growing with the total
 * (16 .. 4096), plus one smaller blob holding the remainder, so the world has
 * exactly the asked count while the scene stores at most ~40k triangles. The
 * instances fill a cube at a density where rays travel a few blobs deep. */
#include "corvid/scene_procedural.h"

#include <math.h>
#include <stddef.h>

#include "mesh_builder.h"
#include "placement.h"
#include "prng.h"

#define BLOB_MESHES 8u
#define STRESS_MATERIALS 6u
#define STRESS_MAX_TRIANGLES (1ull << 31)

static cv_result add_blob(cv_scene *s, uint32_t triangles, uint64_t seed, uint32_t *out) {
    cvs_mesh_builder b;
    cvs_mb_init(&b);
    cvs_shape_blob(&b, triangles, seed);
    cv_result r = cvs_mb_add_to_scene(&b, s, "blob", out);
    cvs_mb_free(&b);
    return r;
}

static cv_result add_materials(cv_scene *s, cvs_rng *rng) {
    cv_result r = CV_OK;
    for (uint32_t i = 0; i < STRESS_MATERIALS && r == CV_OK; i++) {
        cv_material m = cv_material_default();
        for (int k = 0; k < 3; k++)
            m.base_color[k] = cvs_rng_range(rng, 0.2f, 0.95f);
        m.roughness = cvs_rng_range(rng, 0.1f, 0.9f);
        m.metalness = (i % 3 == 0) ? 1.0f : 0.0f;
        r = cv_scene_add_material(s, &m, NULL);
    }
    return r;
}

static cv_result add_camera_and_sun(cv_scene *s, float side) {
    cv_light sun = { .type = CV_LIGHT_DIRECTIONAL,
                     .direction = { -0.4f, -1.0f, -0.3f },
                     .color = { 1.0f, 1.0f, 1.0f },
                     .intensity = 5.0f };
    cv_result r = cv_scene_add_light(s, &sun, NULL);
    if (r != CV_OK)
        return r;
    /* The cube spans [-side/2, side/2]^3; look at it from the +z side, slightly above. */
    cv_camera cam = { .position = { 0.25f * side, 0.35f * side, 1.35f * side },
                      .target = { 0.0f, 0.0f, 0.0f },
                      .up = { 0.0f, 1.0f, 0.0f },
                      .vertical_fov = 0.87266463f };
    return cv_scene_add_camera(s, &cam, NULL);
}

static cv_result build(cv_scene *s, uint32_t seed, uint64_t total) {
    cvs_rng rng = cvs_rng_make(seed, 0x57E55);
    uint64_t per = total / 256;
    uint32_t t = per < 16 ? 16u : per > 4096 ? 4096u : (uint32_t)per;
    uint64_t full = total / t;
    uint32_t remainder = (uint32_t)(total % t);
    uint64_t instances = full + (remainder ? 1 : 0);
    uint32_t meshes[BLOB_MESHES + 1];
    uint32_t kinds = full == 0 ? 0 : full < BLOB_MESHES ? (uint32_t)full : BLOB_MESHES;

    cv_result r = add_materials(s, &rng);
    for (uint32_t i = 0; i < kinds && r == CV_OK; i++)
        r = add_blob(s, t, ((uint64_t)seed << 8) + i, &meshes[i]);
    if (remainder && r == CV_OK)
        r = add_blob(s, remainder, ((uint64_t)seed << 8) + BLOB_MESHES, &meshes[BLOB_MESHES]);
    /* Blobs are ~1 m across, scaled 0.5..1.3; about 0.35 blob volumes per m^3. */
    float side = (float)cvs_cbrt((double)instances / 0.35);
    for (uint64_t i = 0; i < instances && r == CV_OK; i++) {
        cvs_rng irng = cvs_rng_make(seed, 0x1000 + i);
        cv_instance inst = { .mesh = i < full ? meshes[i % kinds] : meshes[BLOB_MESHES],
                             .material = cvs_rng_below(&irng, STRESS_MATERIALS) };
        double q[4];
        cvs_quat_random(q, &irng);
        float sc = cvs_rng_range(&irng, 0.5f, 1.3f);
        const float scale[3] = { sc, sc, sc };
        float pos[3];
        for (int k = 0; k < 3; k++)
            pos[k] = cvs_rng_range(&irng, -0.5f, 0.5f) * side;
        cvs_transform_trs(inst.transform, q, scale, pos);
        r = cv_scene_add_instance(s, &inst, NULL);
    }
    if (r == CV_OK)
        r = add_camera_and_sun(s, side);
    return r;
}

cv_result cv_scene_make_stress(uint32_t seed, uint64_t triangle_count, cv_scene **out) {
    if (!out)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_scene_make_stress: out is NULL");
    if (triangle_count == 0 || triangle_count > STRESS_MAX_TRIANGLES)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_scene_make_stress: triangle_count %llu not in 1..2^31",
                        (unsigned long long)triangle_count);
    cv_scene *s;
    cv_result r = cv_scene_create(&s);
    if (r != CV_OK)
        return r;
    r = build(s, seed, triangle_count);
    if (r != CV_OK) {
        cv_scene_destroy(s);
        return r;
    }
    *out = s;
    return CV_OK;
}
