/* Reflections (issue 11, seed 000), on lavapipe with validation on:
 *  - a mirror floor (roughness 0, metallic 1, base color 1): at every floor
 *    pixel the GPU's reflection is the colour the CPU traces along the mirror
 *    direction from the G-buffer point (scene/'s cv_trace_ray, shaded as
 *    render.reflect_shade: base color * sun * shadow ray + emission, sky on
 *    a miss), and the radiance is that reflection (F = 1, no diffuse);
 *  - the room: the GPU's reflection plane after N frames (spatial reuse on
 *    and off) against the CPU reference (cv_render_reference) at 1024
 *    samples: RMSE and bias over covered pixels;
 *  - 2 and 3 virtual GPUs give the same reflection and radiance bytes as one;
 *  - reflections off: no reflection plane; bad reflection settings are
 *    refused with a message and change nothing. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "corvid/renderer.h"
#include "corvid/scene_procedural.h"
#include "corvid/trace_cpu.h"
#include "corvid/vulkan.h"

static const char *test_adapter(void) {
    const char *env = getenv("CORVID_TEST_ADAPTER");
    return env && env[0] ? env : "llvmpipe";
}

static cv_result render_on(uint32_t gpus, const cv_scene *scene, const cv_bvh *bvh, const cv_render_settings *s,
                           cv_render_output *out) {
    cv_context *ctx = NULL;
    cv_device *devices[4] = { 0 };
    cv_vulkan_gpu_table table;
    cv_renderer *r = NULL;
    cv_result res = cv_context_create(NULL, &ctx);
    if (res == CV_OK)
        res = cv_vulkan_gpu_table_build(&(cv_vulkan_gpu_config){ .total = gpus, .adapters = test_adapter() }, &table);
    if (res == CV_OK)
        res = cv_vulkan_create_devices(ctx, &table, true, devices);
    if (res == CV_OK)
        res = cv_renderer_create(devices, gpus, scene, bvh, &r);
    if (res == CV_OK)
        res = cv_renderer_render(r, s, out, NULL, NULL, NULL);
    cv_renderer_destroy(r);
    cv_context_destroy(ctx);
    return res;
}

/* A two-sided quad: corner c, edges a and b (normal a x b). */
static cv_result add_quad(cv_scene *scene, const float c[3], const float a[3], const float b[3], uint32_t material) {
    float n[3] = { a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0] };
    float len = sqrtf(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    float p[12], normals[12];
    for (int k = 0; k < 3; k++) {
        p[k] = c[k], p[3 + k] = c[k] + a[k], p[6 + k] = c[k] + a[k] + b[k], p[9 + k] = c[k] + b[k];
        for (int v = 0; v < 4; v++)
            normals[v * 3 + k] = n[k] / len;
    }
    static const uint32_t idx[6] = { 0, 1, 2, 0, 2, 3 };
    uint32_t mesh;
    cv_result res = cv_scene_add_mesh(
        scene,
        &(cv_mesh_desc){ .positions = p, .normals = normals, .vertex_count = 4, .indices = idx, .triangle_count = 2 },
        &mesh);
    cv_instance inst = { .mesh = mesh, .material = material };
    cv_transform_identity(inst.transform);
    if (res == CV_OK)
        res = cv_scene_add_instance(scene, &inst, NULL);
    return res;
}

static cv_result add_material(cv_scene *scene, float r, float g, float b, float rough, float metal, float emit,
                              uint32_t *out) {
    cv_material m = cv_material_default();
    m.base_color[0] = r, m.base_color[1] = g, m.base_color[2] = b;
    m.roughness = rough;
    m.metalness = metal;
    for (int k = 0; k < 3; k++)
        m.emission[k] = emit * m.base_color[k];
    return cv_scene_add_material(scene, &m, out);
}

/* A mirror floor, a red wall behind and an emissive panel in front of the
 * wall; the sun comes from behind the camera, so the panel's shadow falls on
 * the wall and shows in the mirror. */
static const float MIRROR_SUN[3] = { 0.0f, -0.5f, -1.0f };
static cv_result make_mirror_scene(cv_scene **out) {
    cv_scene *scene = NULL;
    uint32_t mirror, wall, panel;
    cv_result res = cv_scene_create(&scene);
    if (res == CV_OK)
        res = add_material(scene, 1.0f, 1.0f, 1.0f, 0.0f, 1.0f, 0.0f, &mirror);
    if (res == CV_OK)
        res = add_material(scene, 0.8f, 0.25f, 0.2f, 0.9f, 0.0f, 0.0f, &wall);
    if (res == CV_OK)
        res = add_material(scene, 1.0f, 0.8f, 0.4f, 0.9f, 0.0f, 2.0f, &panel);
    if (res == CV_OK)
        res = add_quad(scene, (float[3]){ -4, 0, -3 }, (float[3]){ 0, 0, 8 }, (float[3]){ 8, 0, 0 }, mirror);
    if (res == CV_OK)
        res = add_quad(scene, (float[3]){ -4, 0, -3 }, (float[3]){ 8, 0, 0 }, (float[3]){ 0, 3, 0 }, wall);
    if (res == CV_OK)
        res = add_quad(scene, (float[3]){ -0.6f, 1.0f, -2.0f }, (float[3]){ 1.2f, 0, 0 }, (float[3]){ 0, 0.8f, 0 },
                       panel);
    if (res == CV_OK)
        res = cv_scene_add_camera(scene, &(cv_camera){ { 0, 1.0f, 3.0f }, { 0, 0.3f, -1.0f }, { 0, 1, 0 }, 0.9f },
                                  NULL);
    cv_light sun = { .type = CV_LIGHT_DIRECTIONAL, .color = { 1.0f, 0.95f, 0.85f }, .intensity = 3.0f };
    float len = sqrtf(MIRROR_SUN[0] * MIRROR_SUN[0] + MIRROR_SUN[1] * MIRROR_SUN[1] + MIRROR_SUN[2] * MIRROR_SUN[2]);
    for (int k = 0; k < 3; k++)
        sun.direction[k] = MIRROR_SUN[k] / len;
    if (res == CV_OK)
        res = cv_scene_add_light(scene, &sun, NULL);
    if (res != CV_OK) {
        cv_scene_destroy(scene);
        scene = NULL;
    }
    *out = scene;
    return res;
}

/* What the reflection ray from o along d brings back, traced and shaded on the
 * CPU independently of the renderer (every surface of the scene is a flat quad,
 * so the shading normal is the geometric one). */
static void cpu_reflected(const cv_scene *scene, const cv_bvh *bvh, float bias, const float o[3], const float d[3],
                          float out[3]) {
    cv_trace_target target = { .flat = bvh, .layout = CV_BVH_LAYOUT_NODE2 };
    cv_ray ray = { { o[0], o[1], o[2] }, 0.0f, { d[0], d[1], d[2] }, 1e30f };
    cv_hit hit;
    if (!cv_trace_ray(&target, &ray, CV_TRACE_CLOSEST, &hit)) {
        out[0] = 0.12f, out[1] = 0.15f, out[2] = 0.2f;
        return;
    }
    const cv_instance *inst = cv_scene_instance(scene, hit.instance);
    const cv_material *m = cv_scene_material(scene, inst->material);
    float tri[3][3];
    cv_scene_world_triangle(scene, hit.instance, hit.triangle, tri);
    float e1[3], e2[3], n[3], x[3];
    for (int k = 0; k < 3; k++) {
        e1[k] = tri[1][k] - tri[0][k];
        e2[k] = tri[2][k] - tri[0][k];
        x[k] = o[k] + d[k] * hit.t;
    }
    n[0] = e1[1] * e2[2] - e1[2] * e2[1], n[1] = e1[2] * e2[0] - e1[0] * e2[2], n[2] = e1[0] * e2[1] - e1[1] * e2[0];
    float len = sqrtf(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    float facing = n[0] * d[0] + n[1] * d[1] + n[2] * d[2] > 0.0f ? -1.0f : 1.0f;
    const cv_light *sun = cv_scene_light(scene, 0);
    float to_sun[3] = { -sun->direction[0], -sun->direction[1], -sun->direction[2] }, ndl = 0.0f;
    for (int k = 0; k < 3; k++) {
        n[k] *= facing / len;
        ndl += n[k] * to_sun[k];
    }
    bool lit = false;
    if (ndl > 0.0f) {
        cv_ray shadow = { { x[0] + n[0] * bias, x[1] + n[1] * bias, x[2] + n[2] * bias },
                          0.0f,
                          { to_sun[0], to_sun[1], to_sun[2] },
                          1e30f };
        cv_hit h2;
        lit = !cv_trace_ray(&target, &shadow, CV_TRACE_ANY_HIT, &h2);
    }
    for (int k = 0; k < 3; k++)
        out[k] = m->base_color[k] * sun->color[k] * sun->intensity * (lit ? ndl : 0.0f) / 3.14159265358979f +
                 m->emission[k];
}

static void check_mirror(void) {
    enum { MW = 160, MH = 90 };
    cv_scene *scene = NULL;
    cv_bvh *bvh = NULL;
    CHECK_OK(make_mirror_scene(&scene));
    if (scene)
        CHECK_OK(cv_bvh_build_flat(scene, NULL, &bvh));
    cv_render_output o = { 0 };
    cv_render_settings s = { .width = MW, .height = MH, .frames = 1, .filter_iterations = -1 };
    if (bvh)
        CHECK_OK(render_on(1, scene, bvh, &s, &o));
    if (o.reflection) {
        float lo[3], hi[3];
        cv_scene_bounds(scene, lo, hi);
        float diag = sqrtf((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                           (hi[2] - lo[2]) * (hi[2] - lo[2]));
        const cv_camera *cam = cv_scene_camera(scene, 0);
        uint32_t floor = 0, off = 0, wall = 0, panel = 0, shadowed = 0, sky = 0;
        double worst = 0.0, worst_radiance = 0.0;
        for (uint32_t i = 0; i < MW * MH; i++) {
            const float *p = &o.position[i * 4], *n = &o.normal[i * 4];
            if (p[3] == 0.0f || n[1] < 0.999f || fabsf(p[1]) > 1e-4f)
                continue; /* not the floor */
            floor++;
            /* The mirror direction of the view at the G-buffer point, from just above the floor. */
            float v[3] = { cam->position[0] - p[0], cam->position[1] - p[1], cam->position[2] - p[2] };
            float vl = sqrtf(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
            float d[3] = { -v[0] / vl, v[1] / vl, -v[2] / vl };
            float origin[3] = { p[0], p[1] + diag * 2e-5f, p[2] }, want[3];
            cpu_reflected(scene, bvh, diag * 2e-5f, origin, d, want);
            double err = 0.0, rerr = 0.0;
            for (int k = 0; k < 3; k++) {
                err = fmax(err, fabs(o.reflection[i * 4 + k] - want[k]));
                rerr = fmax(rerr, fabs(o.radiance[i * 4 + k] - o.reflection[i * 4 + k]));
            }
            if (err > 1e-3)
                off++;
            else
                worst = fmax(worst, err);
            worst_radiance = fmax(worst_radiance, rerr);
            if (want[0] == 0.12f && want[2] == 0.2f)
                sky++;
            else if (want[0] > 1.0f)
                panel++;
            else if (want[0] > 0.05f)
                wall++;
            else
                shadowed++;
        }
        fprintf(stderr,
                "mirror floor %ux%u: %u floor pixels reflect wall %u, its shadow %u, panel %u, sky %u; %u differ "
                "from the CPU by > 1e-3, the others by <= %.2g; radiance - reflection <= %.2g\n",
                MW, MH, floor, wall, shadowed, panel, sky, off, worst, worst_radiance);
        CHECK(floor > 2000);
        CHECK(wall > 200 && shadowed > 50 && panel > 50);
        CHECK(off * 100 <= floor); /* rays grazing a quad's edge may part ways: at most 1% */
        CHECK(worst <= 1e-4);
        CHECK(worst_radiance <= 1e-5); /* F = 1 (F0 = base color 1), diffuse 0 (metallic 1) */
    }
    cv_render_output_free(&o);
    cv_bvh_destroy(bvh);
    cv_scene_destroy(scene);
}

/* RMSE and bias of the reflection rgb over covered pixels. */
static void compare_reflection(const cv_render_output *gpu, const cv_render_output *ref, double *rmse, double *bias) {
    double se = 0.0, sum = 0.0;
    uint32_t n = 0;
    for (uint32_t i = 0; i < gpu->width * gpu->height; i++) {
        if (gpu->position[i * 4 + 3] == 0.0f || ref->position[i * 4 + 3] == 0.0f)
            continue;
        for (int k = 0; k < 3; k++) {
            double e = (double)gpu->reflection[i * 4 + k] - ref->reflection[i * 4 + k];
            se += e * e;
            sum += e;
            n++;
        }
    }
    *rmse = n ? sqrt(se / n) : INFINITY;
    *bias = n ? sum / n : INFINITY;
}

/* The goal of issue 11: RMSE 0.03 over covered pixels after convergence (64
 * frames), with spatial reuse (the default radius, 1) and without, and |bias|
 * 0.01 (measured: see docs/renderer-quality.md); half resolution below. The reconstruction earns its
 * place early: at 4 frames its RMSE is below 3/4 of the unreconstructed one
 * (measured 0.055 vs 0.109). */
static void check_room_against_reference(const cv_scene *scene, const cv_bvh *bvh) {
    enum { RW = 96, RH = 54, SAMPLES = 1024 };
    cv_render_settings s = { .width = RW, .height = RH, .filter_iterations = -1 };
    cv_render_output ref = { 0 };
    CHECK_OK(cv_render_reference(scene, bvh, &s, SAMPLES, 2, &ref));
    static const uint32_t frames[2] = { 4, 64 };
    static const char *modes[3] = { "without reuse", "with reuse (radius 1)", "half resolution (reuse radius 2)" };
    double rmse[2][3] = { { 0 } }, bias[2][3] = { { 0 } };
    for (int f = 0; f < 2 && ref.reflection; f++)
        for (int mode = 0; mode < 3; mode++) {
            s.frames = frames[f];
            s.reflection_radius = mode ? 0 : -1; /* 0: the default, 1 (2 at half resolution) */
            s.reflection_scale = mode == 2 ? 0.5f : 1.0f;
            cv_render_output o = { 0 };
            CHECK_OK(render_on(1, scene, bvh, &s, &o));
            if (o.reflection)
                compare_reflection(&o, &ref, &rmse[f][mode], &bias[f][mode]);
            cv_render_output_free(&o);
            fprintf(stderr,
                    "room %ux%u, reflection, GPU %u frames %s vs reference %u samples: RMSE %.4f, bias %+.4f\n", RW,
                    RH, frames[f], modes[mode], SAMPLES, rmse[f][mode], bias[f][mode]);
        }
    for (int mode = 0; mode < 2; mode++) {
        CHECK(rmse[1][mode] > 0.0 && rmse[1][mode] < 0.03);
        CHECK(fabs(bias[1][mode]) < 0.01);
    }
    /* Half resolution: 64 frames are 16 rays per pixel (full rate at 16 frames
     * measured 0.029): RMSE 0.04, |bias| 0.015 (measured 0.032, -0.009). */
    CHECK(rmse[1][2] > 0.0 && rmse[1][2] < 0.04);
    CHECK(fabs(bias[1][2]) < 0.015);
    CHECK(rmse[0][1] > 0.0 && rmse[0][1] < 0.75 * rmse[0][0]);
    cv_render_output_free(&ref);
}

static void check_multi_device(const cv_scene *scene, const cv_bvh *bvh) {
    enum { DW = 96, DH = 54 };
    cv_render_settings s = { .width = DW, .height = DH, .frames = 2, .tile = 8 };
    cv_render_output one = { 0 }, two = { 0 }, three = { 0 }, half_one = { 0 }, half_two = { 0 };
    CHECK_OK(render_on(1, scene, bvh, &s, &one));
    CHECK_OK(render_on(2, scene, bvh, &s, &two));
    CHECK_OK(render_on(3, scene, bvh, &s, &three));
    s.reflection_scale = 0.5f;
    CHECK_OK(render_on(1, scene, bvh, &s, &half_one));
    CHECK_OK(render_on(2, scene, bvh, &s, &half_two));
    size_t bytes = (size_t)DW * DH * 4 * sizeof(float);
    if (half_one.reflection && half_two.reflection) {
        CHECK(memcmp(half_one.reflection, half_two.reflection, bytes) == 0);
        CHECK(memcmp(half_one.radiance, half_two.radiance, bytes) == 0);
        CHECK(memcmp(half_one.reflection, one.reflection, bytes) != 0); /* a quarter of the rays: another image */
    }
    cv_render_output_free(&half_one);
    cv_render_output_free(&half_two);
    if (one.reflection && two.reflection && three.reflection) {
        CHECK(memcmp(one.reflection, two.reflection, bytes) == 0);
        CHECK(memcmp(one.reflection, three.reflection, bytes) == 0);
        CHECK(memcmp(one.radiance, two.radiance, bytes) == 0);
        CHECK(memcmp(one.radiance, three.radiance, bytes) == 0);
        double sum = 0.0;
        for (uint32_t i = 0; i < DW * DH; i++)
            sum += one.reflection[i * 4] + one.reflection[i * 4 + 1] + one.reflection[i * 4 + 2];
        CHECK(sum > 0.0); /* there is something to compare */
    }
    cv_render_output_free(&one);
    cv_render_output_free(&two);
    cv_render_output_free(&three);
}

static void check_settings(const cv_scene *scene, const cv_bvh *bvh) {
    cv_render_settings s = { .width = 64, .height = 36, .frames = 1, .reflections = -1 };
    cv_render_output o = { 0 };
    CHECK_OK(render_on(1, scene, bvh, &s, &o));
    CHECK(o.radiance != NULL && o.reflection == NULL);
    cv_render_output_free(&o);
    s.reflections = 2;
    CHECK_EQ_INT(render_on(1, scene, bvh, &s, &o), CV_ERROR_OUT_OF_RANGE);
    CHECK(strstr(cv_last_error(), "reflections 2") != NULL);
    CHECK(o.radiance == NULL && o.reflection == NULL);
    s.reflections = 1;
    s.reflection_radius = 9;
    CHECK_EQ_INT(render_on(1, scene, bvh, &s, &o), CV_ERROR_OUT_OF_RANGE);
    CHECK(strstr(cv_last_error(), "reflection radius 9") != NULL);
    CHECK(o.radiance == NULL);
    s.reflection_radius = 0;
    s.reflection_scale = 0.7f;
    CHECK_EQ_INT(render_on(1, scene, bvh, &s, &o), CV_ERROR_OUT_OF_RANGE);
    CHECK(strstr(cv_last_error(), "reflection scale 0.7") != NULL);
    CHECK(o.radiance == NULL);
    s.reflection_scale = 0.0f;
    s.reflection_radius = 0;
    s.reflections = 3;
    CHECK_EQ_INT(cv_render_reference(scene, bvh, &s, 1, 1, &o), CV_ERROR_OUT_OF_RANGE);
    CHECK(o.radiance == NULL);
}

int main(void) {
    check_mirror();
    cv_scene *scene = NULL;
    cv_bvh *bvh = NULL;
    CHECK_OK(cv_scene_make_room(1, &scene));
    if (scene)
        CHECK_OK(cv_bvh_build_flat(scene, NULL, &bvh));
    if (bvh) {
        check_settings(scene, bvh);
        check_multi_device(scene, bvh);
        check_room_against_reference(scene, bvh);
    }
    CHECK_EQ_INT(cv_vulkan_validation_message_count(), 0);
    cv_bvh_destroy(bvh);
    cv_scene_destroy(scene);
    CHECK_NOTHING_LIVE();
    return check_report("renderer reflections");
}
