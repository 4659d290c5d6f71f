/* The alpha-mask rule for secondary rays (issue 11, renderer.h): shadow, AO
 * and reflection rays go through the points an alpha-masked material cuts
 * away, at most CV_RENDER_ALPHA_LAYERS of them, on lavapipe with validation
 * on, against the CPU reference (cv_render_reference, which applies the same
 * rule). The scenes are made here: a mirror floor (metal, roughness 0) under
 * two horizontal quads of masked stripes (alpha 0 / 1 in halves, the upper
 * quad's stripes across the lower's: a quarter of the light passes both), the
 * sun at 53 degrees, a camera that sees the floor under and beside the quads
 * and their mirror image. Checks:
 *  - sun visibility (hard shadows, unfiltered) per pixel equals the
 *    reference's but at stripe edges, and the lit fraction of the floor in
 *    the quads' shadow is about their open fraction, 1/4 (0 before the rule);
 *  - AO of the floor under the quads vs the reference (region mean), above
 *    the AO of the same scene with opaque quads;
 *  - the mirror's reflection plane per pixel vs the reference but at stripe
 *    edges, the sky showing through about a quarter of the quads' image;
 *  - 1 virtual GPU, and 2 tracing in bands of a few rows, give the same bytes;
 *  - the bound: 4 stacked quads cut away everywhere (alpha factor 0) let the
 *    sun through, 5 do not (the 5th cut point counts as opaque), GPU and
 *    reference alike;
 *  - a scene without masked materials runs no re-trace (stats.alpha_rays 0),
 *    the masked one does; its images are covered byte for byte by the other
 *    renderer tests and by cmp of corvid-render's room and stress images
 *    (docs/renderer-quality.md). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "corvid/renderer.h"
#include "corvid/vulkan.h"
#include "test_scene.h"
#include "test_render.h"

enum { W = 160, H = 90, SAMPLES = 16 };

static const float SUN[3] = { -0.6f, -0.8f, 0.0f }; /* the way the light travels */
static const float QUAD_LO = -0.6f, QUAD_HI = 0.6f; /* the quads' extent in x and z */
static const float QUAD_Y[2] = { 1.0f, 1.3f };      /* heights of the striped quads */
static const float CAMERA[3] = { 0.3f, 2.6f, 3.4f };
static const float UV_ONE[2] = { 1.0f, 1.0f }; /* quads' uvs: (0, 0) .. (1, 1) */

/* Stripes across u: 4 periods over the image, alpha 255 then 0 (open fraction 1/2 under bilinear filtering). */
static cv_result add_stripes(cv_scene *scene, bool across_v, uint32_t *ref) {
    enum { S = 32 };
    uint8_t px[S * S * 4];
    for (uint32_t y = 0; y < S; y++)
        for (uint32_t x = 0; x < S; x++) {
            uint8_t *o = &px[(y * S + x) * 4];
            o[0] = 200, o[1] = 180, o[2] = 60, o[3] = ((across_v ? y : x) / 4) % 2 ? 0 : 255;
        }
    uint32_t index = 0;
    cv_result res = cv_scene_add_image(scene, &(cv_image_desc){ .width = S, .height = S, .rgba8 = px }, &index);
    *ref = index + 1;
    return res;
}

static cv_result add_sun_and_camera(cv_scene *scene) {
    cv_camera cam = { { CAMERA[0], CAMERA[1], CAMERA[2] }, { -0.5f, 0.2f, 0.0f }, { 0, 1, 0 }, 1.0f };
    cv_light sun = {
        .type = CV_LIGHT_DIRECTIONAL, .direction = { SUN[0], SUN[1], SUN[2] }, .color = { 1, 1, 1 }, .intensity = 3.0f
    };
    cv_result res = cv_scene_add_camera(scene, &cam, NULL);
    if (res == CV_OK)
        res = cv_scene_add_light(scene, &sun, NULL);
    return res;
}

/* The mirror floor and the two striped quads (masked, or the same quads opaque). */
static cv_result make_stripes_scene(bool mask, cv_scene **out, cv_bvh **bvh_out) {
    cv_scene *scene = NULL;
    cv_result res = cv_scene_create(&scene);
    uint32_t along = 0, across = 0;
    if (res == CV_OK)
        res = add_stripes(scene, false, &along);
    if (res == CV_OK)
        res = add_stripes(scene, true, &across);
    cv_material floor = cv_material_default(), quad[2] = { cv_material_default(), cv_material_default() };
    floor.base_color[0] = floor.base_color[1] = floor.base_color[2] = 0.9f;
    floor.metalness = 1.0f, floor.roughness = 0.0f;
    for (int q = 0; q < 2; q++) {
        quad[q].base_color_image = q ? across : along;
        quad[q].alpha_mode = mask ? CV_ALPHA_MASK : CV_ALPHA_OPAQUE;
    }
    if (res == CV_OK)
        res = cv_scene_add_material(scene, &floor, NULL);
    for (int q = 0; q < 2 && res == CV_OK; q++)
        res = cv_scene_add_material(scene, &quad[q], NULL);
    if (res == CV_OK)
        res = cv_test_add_quad(scene, (float[]){ -3, 0, 3 }, (float[]){ 6, 0, 0 }, (float[]){ 0, 0, -6 }, UV_ONE, 0);
    float side = QUAD_HI - QUAD_LO;
    for (uint32_t q = 0; q < 2 && res == CV_OK; q++)
        res = cv_test_add_quad(scene, (float[]){ QUAD_LO, QUAD_Y[q], QUAD_HI }, (float[]){ side, 0, 0 },
                               (float[]){ 0, 0, -side }, UV_ONE, 1 + q);
    if (res == CV_OK)
        res = add_sun_and_camera(scene);
    return cv_test_scene_finish(scene, res, out, bvh_out);
}

/* A plain floor under `layers` stacked quads 0.05 apart that the mask cuts away everywhere (alpha 0). */
static cv_result make_stack_scene(uint32_t layers, cv_scene **out, cv_bvh **bvh_out) {
    cv_scene *scene = NULL;
    cv_result res = cv_scene_create(&scene);
    cv_material floor = cv_material_default(), clear = cv_material_default();
    clear.alpha = 0.0f;
    clear.alpha_mode = CV_ALPHA_MASK;
    if (res == CV_OK)
        res = cv_scene_add_material(scene, &floor, NULL);
    if (res == CV_OK)
        res = cv_scene_add_material(scene, &clear, NULL);
    if (res == CV_OK)
        res = cv_test_add_quad(scene, (float[]){ -3, 0, 3 }, (float[]){ 6, 0, 0 }, (float[]){ 0, 0, -6 }, UV_ONE, 0);
    float side = QUAD_HI - QUAD_LO;
    for (uint32_t q = 0; q < layers && res == CV_OK; q++)
        res = cv_test_add_quad(scene, (float[]){ QUAD_LO, 1.0f + 0.05f * (float)q, QUAD_HI }, (float[]){ side, 0, 0 },
                               (float[]){ 0, 0, -side }, UV_ONE, 1);
    if (res == CV_OK)
        res = add_sun_and_camera(scene);
    return cv_test_scene_finish(scene, res, out, bvh_out);
}

/* The floor pixel's point, seen along the sun, lies inside the quads' square
 * (the lower quad's at height y), `margin` inside its edges; false off the floor. */
static bool in_shadow_of_quads(const cv_render_output *o, size_t i, float y, float margin) {
    if (o->position[i + 3] == 0.0f || fabsf(o->position[i + 1]) > 1e-3f)
        return false;
    float t = (y - o->position[i + 1]) / -SUN[1];
    float x = o->position[i] - SUN[0] * t, z = o->position[i + 2] - SUN[2] * t;
    return x > QUAD_LO + margin && x < QUAD_HI - margin && z > QUAD_LO + margin && z < QUAD_HI - margin;
}

static bool on_floor(const cv_render_output *o, size_t i) {
    return o->position[i + 3] != 0.0f && fabsf(o->position[i + 1]) < 1e-3f;
}

/* The floor pixel's mirror ray (the camera's ray reflected at y = 0) meets both quads, `margin` inside their edges. */
static bool mirrors_both_quads(const cv_render_output *o, size_t i, float margin) {
    if (!on_floor(o, i))
        return false;
    float d[3] = { o->position[i] - CAMERA[0], CAMERA[1] - o->position[i + 1], o->position[i + 2] - CAMERA[2] };
    for (int q = 0; q < 2; q++) {
        float t = QUAD_Y[q] / d[1], x = o->position[i] + d[0] * t, z = o->position[i + 2] + d[2] * t;
        if (!(x > QUAD_LO + margin && x < QUAD_HI - margin && z > QUAD_LO + margin && z < QUAD_HI - margin))
            return false;
    }
    return true;
}

/* The floor pixel lies under the quads (straight down), `margin` inside. */
static bool under_quads(const cv_render_output *o, size_t i, float margin) {
    if (o->position[i + 3] == 0.0f || fabsf(o->position[i + 1]) > 1e-3f)
        return false;
    float x = o->position[i], z = o->position[i + 2];
    return x > QUAD_LO + margin && x < QUAD_HI - margin && z > QUAD_LO + margin && z < QUAD_HI - margin;
}

/* Pixel (x, y) of plane channel c differs by more than tol from one of its 8 neighbours in `o`. */
static bool near_edge(const float *plane, uint32_t x, uint32_t y, int c, float tol) {
    float v = plane[((size_t)y * W + x) * 4 + c];
    for (int dy = -1; dy <= 1; dy++)
        for (int dx = -1; dx <= 1; dx++) {
            int nx = (int)x + dx, ny = (int)y + dy;
            if (nx >= 0 && ny >= 0 && nx < W && ny < H && fabsf(plane[((size_t)ny * W + nx) * 4 + c] - v) > tol)
                return true;
        }
    return false;
}

static const cv_render_settings settings = { .width = W,
                                             .height = H,
                                             .frames = 4,
                                             .ao_samples = 8,
                                             .ao_radius = 1.5f,
                                             .sun_cone_degrees = -1.0f,
                                             .filter_iterations = -1,
                                             .reflection_radius = -1 };

static void check_stripes(void) {
    cv_scene *scene = NULL, *opaque = NULL;
    cv_bvh *bvh = NULL, *opaque_bvh = NULL;
    CHECK_OK(make_stripes_scene(true, &scene, &bvh));
    CHECK_OK(make_stripes_scene(false, &opaque, &opaque_bvh));
    if (!scene || !opaque)
        return;
    cv_render_output gpu = { 0 }, gpu2 = { 0 }, ref = { 0 }, gpu_opaque = { 0 };
    cv_render_stats st = { 0 }, st2 = { 0 }, st_opaque = { 0 };
    /* Two devices tracing in bands (band_rays: 5 rows of the whole image): every band runs its own rounds. */
    cv_render_settings banded = settings;
    banded.band_rays = 5 * W * (1 + settings.ao_samples);
    CHECK_OK(cv_test_render(1, scene, bvh, &settings, &gpu, &st));
    CHECK_OK(cv_test_render(2, scene, bvh, &banded, &gpu2, &st2));
    CHECK_OK(cv_test_render(1, opaque, opaque_bvh, &settings, &gpu_opaque, &st_opaque));
    CHECK_OK(cv_render_reference(scene, bvh, &settings, SAMPLES, 2, &ref));
    if (gpu.visibility && gpu2.visibility && ref.visibility && gpu_opaque.visibility) {
        size_t bytes = (size_t)W * H * 4 * sizeof(float);
        /* 1 vs 2 virtual GPUs (in bands of rows): the same bytes. */
        CHECK(memcmp(gpu.radiance, gpu2.radiance, bytes) == 0);
        CHECK(memcmp(gpu.visibility, gpu2.visibility, bytes) == 0);
        CHECK(gpu.reflection && gpu2.reflection && memcmp(gpu.reflection, gpu2.reflection, bytes) == 0);
        /* Re-traces ran for the masked scene only: every ray slot per round. */
        uint64_t per_frame = (uint64_t)W * H *
                             ((1 + settings.ao_samples) * (CV_RENDER_ALPHA_LAYERS + 1) + 2 * CV_RENDER_ALPHA_LAYERS +
                              1);
        printf("alpha_rays: masked %llu (1 GPU), %llu (2 GPUs), opaque %llu\n", (unsigned long long)st.alpha_rays,
               (unsigned long long)st2.alpha_rays, (unsigned long long)st_opaque.alpha_rays);
        CHECK_EQ_INT(st.alpha_rays, per_frame * settings.frames);
        CHECK_EQ_INT(st2.alpha_rays, per_frame * settings.frames);
        CHECK_EQ_INT(st_opaque.alpha_rays, 0);

        /* Sun visibility (hard shadows: 0 or 1 a pixel): the reference's but at stripe edges. */
        uint32_t shadow = 0, lit = 0, differ = 0, differ_edge = 0;
        for (uint32_t y = 0; y < H; y++)
            for (uint32_t x = 0; x < W; x++) {
                size_t i = ((size_t)y * W + x) * 4;
                if (!in_shadow_of_quads(&ref, i, QUAD_Y[0], 0.05f) ||
                    !in_shadow_of_quads(&ref, i, QUAD_Y[1], 0.05f) ||
                    !in_shadow_of_quads(&gpu, i, QUAD_Y[0], 0.05f) || !in_shadow_of_quads(&gpu, i, QUAD_Y[1], 0.05f))
                    continue;
                shadow++;
                lit += gpu.visibility[i] > 0.5f;
                if (fabsf(gpu.visibility[i] - ref.visibility[i]) > 1e-6f)
                    *(near_edge(ref.visibility, x, y, 0, 0.5f) ? &differ_edge : &differ) += 1;
            }
        double lit_fraction = shadow ? (double)lit / shadow : 0.0;
        printf(
            "sun: %u floor pixels in the quads' shadow, lit fraction %.3f (open fraction 0.25); vs reference %u "
            "differ at stripe edges, %u elsewhere\n",
            shadow, lit_fraction, differ_edge, differ);
        CHECK(shadow >= 150);
        /* Both quads' stripes halve the light: 1/4 passes (0 before the rule). Pixel sampling of 4 x 4
         * stripes over a few hundred pixels: within 0.07. */
        CHECK(fabs(lit_fraction - 0.25) < 0.07);
        /* The same rule: only pixels whose ray meets a stripe edge within float rounding may differ. */
        CHECK(differ == 0);
        CHECK(differ_edge * 10 <= shadow);

        /* AO under the quads: the reference's within noise, above the opaque quads'. */
        uint32_t under = 0;
        double ao_gpu = 0.0, ao_ref = 0.0, ao_opaque = 0.0;
        for (size_t i = 0; i < (size_t)W * H * 4; i += 4) {
            if (!under_quads(&ref, i, 0.1f) || !under_quads(&gpu, i, 0.1f) || !under_quads(&gpu_opaque, i, 0.1f))
                continue;
            under++;
            ao_gpu += gpu.visibility[i + 1], ao_ref += ref.visibility[i + 1],
                ao_opaque += gpu_opaque.visibility[i + 1];
        }
        if (under) {
            ao_gpu /= under, ao_ref /= under, ao_opaque /= under;
        }
        printf("AO under the quads over %u pixels: gpu %.4f, reference %.4f, opaque quads %.4f\n", under, ao_gpu,
               ao_ref, ao_opaque);
        CHECK(under >= 200);
        /* Region means of 32 (GPU) and 128 (reference) AO rays a pixel: noise well under 0.01; 0.02 allowed. */
        CHECK(fabs(ao_gpu - ao_ref) < 0.02);
        CHECK(ao_gpu > ao_opaque + 0.05);

        /* The mirror's reflection: the reference's but at stripe edges; where the opaque quads' image is
         * (black: their undersides face away from the sun), the sky through about a quarter of it. */
        uint32_t image = 0, sky = 0, rdiffer = 0, rdiffer_edge = 0;
        for (uint32_t y = 0; y < H; y++)
            for (uint32_t x = 0; x < W; x++) {
                size_t i = ((size_t)y * W + x) * 4;
                if (!on_floor(&gpu, i) || !on_floor(&ref, i)) /* the mirror; the quads' own reflections are glossy */
                    continue;
                float e = 0.0f;
                for (int k = 0; k < 3; k++)
                    e = fmaxf(e, fabsf(gpu.reflection[i + k] - ref.reflection[i + k]));
                if (e > 0.01f)
                    *(near_edge(ref.reflection, x, y, 2, 0.05f) ? &rdiffer_edge : &rdiffer) += 1;
                float o = gpu_opaque.reflection[i] + gpu_opaque.reflection[i + 1] + gpu_opaque.reflection[i + 2];
                if (o < 1e-3f && mirrors_both_quads(&ref, i, 0.05f)) {
                    image++;
                    sky += fabsf(gpu.reflection[i + 2] - 0.2f) < 1e-3f;
                }
            }
        double sky_fraction = image ? (double)sky / image : 0.0;
        printf(
            "reflection: %u pixels of the quads' mirror image, sky through %.3f of them; vs reference %u differ "
            "at edges, %u elsewhere\n",
            image, sky_fraction, rdiffer_edge, rdiffer);
        CHECK(image >= 150);
        CHECK(fabs(sky_fraction - 0.25) < 0.08);
        CHECK(rdiffer == 0);
        CHECK(rdiffer_edge * 10 <= image);
    }
    cv_render_output_free(&gpu);
    cv_render_output_free(&gpu2);
    cv_render_output_free(&ref);
    cv_render_output_free(&gpu_opaque);
    cv_bvh_destroy(bvh);
    cv_bvh_destroy(opaque_bvh);
    cv_scene_destroy(scene);
    cv_scene_destroy(opaque);
}

/* CV_RENDER_ALPHA_LAYERS cut points pass the sun; one more blocks it. */
static void check_bound(void) {
    cv_render_settings s = settings;
    s.frames = 1, s.ao_samples = 1, s.reflections = -1;
    for (uint32_t layers = CV_RENDER_ALPHA_LAYERS; layers <= CV_RENDER_ALPHA_LAYERS + 1; layers++) {
        cv_scene *scene = NULL;
        cv_bvh *bvh = NULL;
        CHECK_OK(make_stack_scene(layers, &scene, &bvh));
        cv_render_output gpu = { 0 }, ref = { 0 };
        if (scene) {
            CHECK_OK(cv_test_render(1, scene, bvh, &s, &gpu, NULL));
            CHECK_OK(cv_render_reference(scene, bvh, &s, 1, 2, &ref));
        }
        if (gpu.visibility && ref.visibility) {
            uint32_t shadow = 0, lit_gpu = 0, lit_ref = 0;
            for (size_t i = 0; i < (size_t)W * H * 4; i += 4) {
                if (!in_shadow_of_quads(&ref, i, 1.0f + 0.05f * (float)(layers - 1), 0.05f) ||
                    !in_shadow_of_quads(&ref, i, 1.0f, 0.05f))
                    continue;
                shadow++;
                lit_gpu += gpu.visibility[i] > 0.5f;
                lit_ref += ref.visibility[i] > 0.5f;
            }
            printf("%u cut-away quads: %u floor pixels in their shadow, lit: gpu %u, reference %u\n", layers, shadow,
                   lit_gpu, lit_ref);
            CHECK(shadow >= 200);
            CHECK_EQ_INT(lit_gpu, layers <= CV_RENDER_ALPHA_LAYERS ? shadow : 0);
            CHECK_EQ_INT(lit_ref, lit_gpu);
        }
        cv_render_output_free(&gpu);
        cv_render_output_free(&ref);
        cv_bvh_destroy(bvh);
        cv_scene_destroy(scene);
    }
}

int main(void) {
    check_stripes();
    check_bound();
    CHECK_EQ_INT(cv_vulkan_validation_message_count(), 0);
    CHECK_NOTHING_LIVE();
    return check_report("renderer_alpha");
}
