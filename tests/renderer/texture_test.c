/* Textured materials (issue 11, glTF metal/roughness), on lavapipe with
 * validation on, against the CPU reference (cv_render_reference, which
 * evaluates materials with cv_material_evaluate) at 96x54. The scene is made
 * here, images included: a checker base-color image on the floor, a
 * metal/rough image on a box, a sine-bump normal image on the back wall, an
 * emissive image on a panel and an alpha-masked quad (round holes) in front
 * of the wall; every mesh has uvs. Checks:
 *  - the albedo layer (base color x (1 - metalness), textures sampled with
 *    the G-buffer's dFdx/dFdy footprint) matches the reference's (ray
 *    differentials) over covered pixels away from silhouettes;
 *  - the alpha mask: where the reference sees through a hole the GPU does, and
 *    the other way round, but at pixels next to a hole's edge;
 *  - the normal image changes the normal layer at the wall's pixels and
 *    nowhere else (bytes), and the mapped normal matches the reference's;
 *  - the emissive image shows in the radiance, as in the reference;
 *  - the normal image at reflection hits: a mirror floor's reflection of the
 *    bumped wall equals the reference's (and differs from the flat wall's);
 *  - 1 and 2 virtual GPUs give the same bytes;
 *  - assimp's BoxTextured (imported by scene/, if installed): the albedo
 *    layer matches the reference's.
 * (A scene without images renders byte for byte as before textures: checked
 * by comparing corvid-render's PNG of the default room, docs/renderer-quality.md.) */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "corvid/renderer.h"
#include "corvid/scene_import.h"
#include "corvid/vulkan.h"
#include "test_scene.h"
#include "test_render.h"

enum { W = 96, H = 54, SAMPLES = 16 };

/* A closed box [lo, hi] (24 vertices, each face's uvs 0..1). */
static cv_result add_box(cv_scene *scene, const float lo[3], const float hi[3], uint32_t material) {
    float p[72], n[72], uv[48];
    uint32_t idx[36];
    for (int f = 0; f < 6; f++) {
        int axis = f / 2, s = f % 2 ? 1 : -1, ua = (axis + 1) % 3, va = (axis + 2) % 3;
        static const float corner[4][2] = { { 0, 0 }, { 1, 0 }, { 1, 1 }, { 0, 1 } };
        for (int v = 0; v < 4; v++) {
            float *q = &p[(f * 4 + v) * 3];
            q[axis] = s > 0 ? hi[axis] : lo[axis];
            q[ua] = corner[v][0] ? hi[ua] : lo[ua];
            q[va] = corner[v][1] ? hi[va] : lo[va];
            for (int k = 0; k < 3; k++)
                n[(f * 4 + v) * 3 + k] = k == axis ? (float)s : 0.0f;
            uv[(f * 4 + v) * 2] = corner[v][0], uv[(f * 4 + v) * 2 + 1] = corner[v][1];
        }
        /* counter-clockwise seen from outside: (ua, va) is right-handed with +axis */
        static const uint32_t pos[6] = { 0, 1, 2, 0, 2, 3 }, neg[6] = { 0, 2, 1, 0, 3, 2 };
        for (int k = 0; k < 6; k++)
            idx[f * 6 + k] = (uint32_t)f * 4 + (s > 0 ? pos[k] : neg[k]);
    }
    return cv_test_add_mesh_instance(
        scene,
        &(cv_mesh_desc){
            .positions = p, .normals = n, .uvs = uv, .vertex_count = 24, .indices = idx, .triangle_count = 12 },
        material);
}

typedef void (*texel_fn)(uint32_t x, uint32_t y, uint32_t w, uint32_t h, uint8_t out[4]);

static void checker(uint32_t x, uint32_t y, uint32_t w, uint32_t h, uint8_t o[4]) {
    (void)w, (void)h;
    bool dark = ((x / 4) + (y / 4)) % 2;
    o[0] = dark ? 40 : 230, o[1] = dark ? 60 : 200, o[2] = dark ? 120 : 90, o[3] = 255;
}

/* g: roughness from 0.1 to 1 across, b: metalness 0 or 1 in halves. */
static void metal_rough(uint32_t x, uint32_t y, uint32_t w, uint32_t h, uint8_t o[4]) {
    o[0] = 0, o[1] = (uint8_t)(25 + 230 * x / (w - 1)), o[2] = y < h / 2 ? 0 : 255, o[3] = 255;
}

/* Bumps: the normal of z = 0.15 sin(2 pi x / w) sin(2 pi y / h) (texel units scaled). */
static void bumps(uint32_t x, uint32_t y, uint32_t w, uint32_t h, uint8_t o[4]) {
    float fx = 6.2831853f * ((float)x + 0.5f) / (float)w, fy = 6.2831853f * ((float)y + 0.5f) / (float)h;
    float nx = -0.9f * cosf(fx) * sinf(fy), ny = -0.9f * sinf(fx) * cosf(fy), nz = 1.0f;
    float l = sqrtf(nx * nx + ny * ny + nz * nz);
    o[0] = (uint8_t)lrintf((nx / l * 0.5f + 0.5f) * 255.0f);
    o[1] = (uint8_t)lrintf((ny / l * 0.5f + 0.5f) * 255.0f);
    o[2] = (uint8_t)lrintf((nz / l * 0.5f + 0.5f) * 255.0f);
    o[3] = 255;
}

/* Stripes of colour. */
static void stripes(uint32_t x, uint32_t y, uint32_t w, uint32_t h, uint8_t o[4]) {
    (void)y, (void)h;
    uint32_t band = x * 3 / w;
    o[0] = band == 0 ? 255 : 30, o[1] = band == 1 ? 255 : 30, o[2] = band == 2 ? 255 : 30, o[3] = 255;
}

/* White with round holes (alpha 0) in a 2x2 grid of circles. */
static void holes(uint32_t x, uint32_t y, uint32_t w, uint32_t h, uint8_t o[4]) {
    float cx = fmodf(((float)x + 0.5f) / (float)w * 2.0f, 1.0f) - 0.5f,
          cy = fmodf(((float)y + 0.5f) / (float)h * 2.0f, 1.0f) - 0.5f;
    o[0] = 220, o[1] = 220, o[2] = 220, o[3] = cx * cx + cy * cy < 0.09f ? 0 : 255;
}

static cv_result add_image(cv_scene *scene, uint32_t w, uint32_t h, texel_fn fn, uint32_t *ref) {
    uint8_t *px = malloc((size_t)w * h * 4);
    if (!px)
        return CV_ERROR_OUT_OF_MEMORY;
    for (uint32_t y = 0; y < h; y++)
        for (uint32_t x = 0; x < w; x++)
            fn(x, y, w, h, &px[((size_t)y * w + x) * 4]);
    uint32_t index = 0;
    cv_result res = cv_scene_add_image(scene, &(cv_image_desc){ .width = w, .height = h, .rgba8 = px }, &index);
    free(px);
    *ref = index + 1;
    return res;
}

enum { MAT_FLOOR, MAT_WALL, MAT_BOX, MAT_PANEL, MAT_MASKED, MAT_COUNT };

typedef struct scene_options {
    bool textures;   /* false: every image reference 0 (the factors alone) */
    bool normal_map; /* the wall's normal image */
    bool mask;       /* the quad's alpha mask */
    bool mirror;     /* the floor a mirror (roughness 0, metallic, white, untextured) */
} scene_options;

static cv_result make_scene(scene_options o, cv_scene **out, cv_bvh **bvh_out) {
    cv_scene *scene = NULL;
    cv_result res = cv_scene_create(&scene);
    uint32_t check = 0, mr = 0, bump = 0, stripe = 0, hole = 0;
    if (res == CV_OK)
        res = add_image(scene, 32, 32, checker, &check);
    if (res == CV_OK)
        res = add_image(scene, 16, 16, metal_rough, &mr);
    if (res == CV_OK)
        res = add_image(scene, 64, 64, bumps, &bump);
    if (res == CV_OK)
        res = add_image(scene, 24, 8, stripes, &stripe);
    if (res == CV_OK)
        res = add_image(scene, 64, 64, holes, &hole);
    cv_material m[MAT_COUNT];
    for (int i = 0; i < MAT_COUNT; i++)
        m[i] = cv_material_default();
    m[MAT_FLOOR].base_color_image = o.textures ? check : 0;
    m[MAT_FLOOR].base_color[0] = 0.9f, m[MAT_FLOOR].base_color[1] = 0.9f, m[MAT_FLOOR].base_color[2] = 0.9f;
    if (o.mirror) {
        m[MAT_FLOOR].base_color_image = 0;
        m[MAT_FLOOR].base_color[0] = m[MAT_FLOOR].base_color[1] = m[MAT_FLOOR].base_color[2] = 1.0f;
        m[MAT_FLOOR].roughness = 0.0f, m[MAT_FLOOR].metalness = 1.0f;
    }
    m[MAT_WALL].normal_image = o.textures && o.normal_map ? bump : 0;
    m[MAT_WALL].base_color[0] = 0.7f, m[MAT_WALL].base_color[1] = 0.7f, m[MAT_WALL].base_color[2] = 0.75f;
    m[MAT_BOX].metal_rough_image = o.textures ? mr : 0;
    m[MAT_BOX].base_color[0] = 0.9f, m[MAT_BOX].base_color[1] = 0.6f, m[MAT_BOX].base_color[2] = 0.3f;
    m[MAT_BOX].metalness = 1.0f, m[MAT_BOX].roughness = 1.0f;
    m[MAT_PANEL].emissive_image = o.textures ? stripe : 0;
    m[MAT_PANEL].base_color[0] = m[MAT_PANEL].base_color[1] = m[MAT_PANEL].base_color[2] = 0.0f;
    m[MAT_PANEL].emission[0] = m[MAT_PANEL].emission[1] = m[MAT_PANEL].emission[2] = 3.0f;
    m[MAT_MASKED].base_color_image = o.textures ? hole : 0;
    m[MAT_MASKED].base_color[0] = 0.3f, m[MAT_MASKED].base_color[1] = 0.8f, m[MAT_MASKED].base_color[2] = 0.4f;
    m[MAT_MASKED].alpha_mode = o.mask ? CV_ALPHA_MASK : CV_ALPHA_OPAQUE;
    for (int i = 0; i < MAT_COUNT && res == CV_OK; i++)
        res = cv_scene_add_material(scene, &m[i], NULL);
    /* floor (uvs repeat 4 times), back wall, box, emissive panel on the left, the masked quad */
    if (res == CV_OK)
        res = cv_test_add_quad(scene, (float[]){ -2, 0, 2 }, (float[]){ 4, 0, 0 }, (float[]){ 0, 0, -4 },
                               (const float[]){ 4, 4 }, MAT_FLOOR);
    if (res == CV_OK)
        res = cv_test_add_quad(scene, (float[]){ -2, 0, -2 }, (float[]){ 4, 0, 0 }, (float[]){ 0, 2.5f, 0 },
                               (const float[]){ 2, 1.25f }, MAT_WALL);
    if (res == CV_OK)
        res = add_box(scene, (float[]){ -1.4f, 0, -0.8f }, (float[]){ -0.6f, 0.8f, 0.0f }, MAT_BOX);
    if (res == CV_OK)
        res = cv_test_add_quad(scene, (float[]){ -1.9f, 1.0f, 0.2f }, (float[]){ 0, 0, -1.6f },
                               (float[]){ 0, 0.8f, 0 }, (const float[]){ 1, 1 }, MAT_PANEL);
    if (res == CV_OK)
        res = cv_test_add_quad(scene, (float[]){ 0.2f, 0.3f, -1.0f }, (float[]){ 1.4f, 0, 0 },
                               (float[]){ 0, 1.4f, 0 }, (const float[]){ 1, 1 }, MAT_MASKED);
    cv_camera cam = { { 0.0f, 1.3f, 3.2f }, { 0.0f, 0.8f, -1.0f }, { 0, 1, 0 }, 1.0f };
    if (res == CV_OK)
        res = cv_scene_add_camera(scene, &cam, NULL);
    cv_light sun = {
        .type = CV_LIGHT_DIRECTIONAL, .direction = { -0.35f, -0.8f, -0.45f }, .color = { 1, 1, 1 }, .intensity = 3.0f
    };
    if (res == CV_OK)
        res = cv_scene_add_light(scene, &sun, NULL);
    return cv_test_scene_finish(scene, res, out, bvh_out);
}

static const cv_render_settings settings = { .width = W, .height = H, .frames = 2 };

static int material_at(const cv_render_output *o, uint32_t x, uint32_t y) {
    size_t i = ((size_t)y * W + x) * 4;
    return o->position[i + 3] != 0.0f ? (int)o->normal[i + 3] : -1;
}

/* Interior: the pixel and its 8 neighbours show the same material in `a`, and `b` agrees at the pixel. */
static bool interior(const cv_render_output *a, const cv_render_output *b, uint32_t x, uint32_t y) {
    int m = material_at(a, x, y);
    if (m < 0 || x == 0 || y == 0 || x + 1 == W || y + 1 == H || material_at(b, x, y) != m)
        return false;
    for (int dy = -1; dy <= 1; dy++)
        for (int dx = -1; dx <= 1; dx++)
            if (material_at(a, x + dx, y + dy) != m)
                return false;
    return true;
}

/* assimp's BoxTextured (a base color image imported by scene/), if installed:
 * the albedo layer against the reference's over interior pixels. */
static void check_box_textured(void) {
    cv_scene *scene = NULL;
    cv_bvh *bvh = NULL;
    FILE *f = fopen(BOX_TEXTURED, "rb");
    if (!f) {
        printf("BoxTextured: %s not installed, not compared\n", BOX_TEXTURED);
        return;
    }
    fclose(f);
    CHECK_OK(cv_scene_import(BOX_TEXTURED, &scene));
    if (scene)
        CHECK_OK(cv_bvh_build_flat(scene, NULL, &bvh));
    cv_render_output gpu = { 0 }, ref = { 0 };
    if (bvh) {
        CHECK_OK(cv_test_render(1, scene, bvh, &settings, &gpu, NULL));
        CHECK_OK(cv_render_reference(scene, bvh, &settings, 4, 2, &ref));
    }
    if (gpu.albedo && ref.albedo) {
        uint32_t n = 0;
        double worst = 0.0, textured = 0.0;
        for (uint32_t y = 0; y < H; y++)
            for (uint32_t x = 0; x < W; x++) {
                if (!interior(&ref, &gpu, x, y))
                    continue;
                size_t i = ((size_t)y * W + x) * 4;
                for (int k = 0; k < 3; k++) {
                    worst = fmax(worst, fabs((double)gpu.albedo[i + k] - ref.albedo[i + k]));
                    textured = fmax(textured, fabs((double)ref.albedo[i + k] - ref.albedo[i + 4 + k]));
                }
                n++;
            }
        printf("BoxTextured: %u interior pixels, albedo max |gpu - ref| %.2e (neighbours differ by up to %.3f)\n", n,
               worst, textured);
        CHECK(n >= 500);
        CHECK(textured > 0.1); /* the image shows */
        CHECK(worst < 1e-3);
    }
    cv_render_output_free(&gpu);
    cv_render_output_free(&ref);
    cv_bvh_destroy(bvh);
    cv_scene_destroy(scene);
}

/* The normal image at reflection hits: a mirror floor reflects the bumped
 * wall; its reflection layer is the shading of each pixel's one mirror ray
 * (exact, no noise), on the GPU (render.reflect_shade) as in the reference,
 * so they agree beyond the RGBA16F samples' rounding, and the bumps change
 * the reflected wall against the same scene without the normal image. */
static void check_reflected_normal_map(void) {
    cv_scene *bumped = NULL, *flat = NULL;
    cv_bvh *bumped_bvh = NULL, *flat_bvh = NULL;
    CHECK_OK(
        make_scene((scene_options){ .textures = true, .normal_map = true, .mirror = true }, &bumped, &bumped_bvh));
    CHECK_OK(make_scene((scene_options){ .textures = true, .normal_map = false, .mirror = true }, &flat, &flat_bvh));
    cv_render_settings s = { .width = W, .height = H, .frames = 1 };
    cv_render_output gpu = { 0 }, ref = { 0 }, gpu_flat = { 0 };
    if (bumped && flat) {
        CHECK_OK(cv_test_render(1, bumped, bumped_bvh, &s, &gpu, NULL));
        CHECK_OK(cv_render_reference(bumped, bumped_bvh, &s, 1, 2, &ref));
        CHECK_OK(cv_test_render(1, flat, flat_bvh, &s, &gpu_flat, NULL));
    }
    if (gpu.reflection && ref.reflection && gpu_flat.reflection) {
        uint32_t floor = 0, changed = 0, off = 0;
        double worst = 0.0;
        for (uint32_t y = 0; y < H; y++)
            for (uint32_t x = 0; x < W; x++) {
                if (!interior(&ref, &gpu, x, y) || material_at(&ref, x, y) != MAT_FLOOR)
                    continue;
                size_t i = ((size_t)y * W + x) * 4;
                floor++;
                double e = 0.0, d = 0.0;
                for (int k = 0; k < 3; k++) {
                    e = fmax(e, fabs((double)gpu.reflection[i + k] - ref.reflection[i + k]) -
                                    ldexp(fabs(ref.reflection[i + k]), -11));
                    d = fmax(d, fabs((double)gpu.reflection[i + k] - gpu_flat.reflection[i + k]));
                }
                worst = fmax(worst, e);
                off += e > 1e-3;
                changed += d > 0.01;
            }
        printf(
            "reflected normal image: %u mirror floor pixels, %u changed by the wall's bumps; vs reference: %u off "
            "by > 1e-3, worst %.2e\n",
            floor, changed, off, worst);
        CHECK(floor >= 200);
        CHECK(changed >= 50);
        /* Measured: lavapipe 0 off (worst 3.6e-4); the H200 3 of 1089 (worst 2.3e-3: its hit points, and so the
         * bump texels read, differ in the last bits). Allowed: 1% of the pixels off, none by 0.01 (the bumps
         * change the reflection by up to 0.33). */
        CHECK(off * 100 <= floor);
        CHECK(worst < 0.01);
    }
    cv_render_output_free(&gpu);
    cv_render_output_free(&ref);
    cv_render_output_free(&gpu_flat);
    cv_bvh_destroy(bumped_bvh);
    cv_bvh_destroy(flat_bvh);
    cv_scene_destroy(bumped);
    cv_scene_destroy(flat);
}

int main(void) {
    check_reflected_normal_map();
    cv_scene *scene = NULL, *flat = NULL, *opaque = NULL;
    cv_bvh *bvh = NULL, *flat_bvh = NULL, *opaque_bvh = NULL;
    CHECK_OK(make_scene((scene_options){ true, true, true }, &scene, &bvh));
    CHECK_OK(make_scene((scene_options){ true, false, true }, &flat, &flat_bvh));
    CHECK_OK(make_scene((scene_options){ true, true, false }, &opaque, &opaque_bvh));
    if (!scene || !flat || !opaque)
        return check_report("renderer_texture");
    cv_render_output gpu = { 0 }, gpu2 = { 0 }, ref = { 0 }, gpu_flat = { 0 }, ref_opaque = { 0 };
    CHECK_OK(cv_test_render(1, scene, bvh, &settings, &gpu, NULL));
    CHECK_OK(cv_test_render(2, scene, bvh, &settings, &gpu2, NULL));
    CHECK_OK(cv_render_reference(scene, bvh, &settings, SAMPLES, 2, &ref));
    CHECK_OK(cv_test_render(1, flat, flat_bvh, &settings, &gpu_flat, NULL));
    CHECK_OK(cv_render_reference(opaque, opaque_bvh, &settings, 1, 2, &ref_opaque));
    if (gpu.radiance && gpu2.radiance && ref.radiance && gpu_flat.radiance && ref_opaque.radiance) {
        size_t bytes = (size_t)W * H * 4 * sizeof(float);
        /* 1 vs 2 virtual GPUs: the same bytes. */
        CHECK(memcmp(gpu.radiance, gpu2.radiance, bytes) == 0);
        CHECK(memcmp(gpu.albedo, gpu2.albedo, bytes) == 0);
        CHECK(memcmp(gpu.normal, gpu2.normal, bytes) == 0);
        CHECK(gpu.reflection && gpu2.reflection && memcmp(gpu.reflection, gpu2.reflection, bytes) == 0);

        /* Albedo vs the reference over interior pixels, per material. */
        double err_sum[MAT_COUNT] = { 0 }, err_max[MAT_COUNT] = { 0 };
        uint32_t count[MAT_COUNT] = { 0 };
        for (uint32_t y = 0; y < H; y++)
            for (uint32_t x = 0; x < W; x++) {
                if (!interior(&ref, &gpu, x, y))
                    continue;
                int m = material_at(&ref, x, y);
                size_t i = ((size_t)y * W + x) * 4;
                double e = 0.0;
                for (int k = 0; k < 3; k++)
                    e = fmax(e, fabs((double)gpu.albedo[i + k] - ref.albedo[i + k]));
                err_sum[m] += e;
                err_max[m] = fmax(err_max[m], e);
                count[m]++;
            }
        for (int m = 0; m < MAT_COUNT; m++) {
            printf("albedo material %d: %u interior pixels, mean |gpu - ref| %.2e, max %.2e\n", m, count[m],
                   count[m] ? err_sum[m] / count[m] : 0.0, err_max[m]);
            CHECK(count[m] >= 20);
            /* Tolerance: the reference's ray differentials measure the G-buffer's dFdxFine/dFdyFine footprint
             * (the same pixel pairs), so only float rounding (uv interpolation, log2) parts them: measured at
             * most 1e-5 on lavapipe; the H200's attribute interpolation and derivatives differ more (at most
             * 1.1e-3, mean 1.6e-4). Bound: half a step of an 8-bit texel (1 / 510) a pixel, 3e-4 on average. */
            CHECK(count[m] && err_max[m] < 1.0 / 510.0);
            CHECK(count[m] && err_sum[m] / count[m] < 3e-4);
        }

        /* The alpha mask: see-through agrees but next to a hole's edge. */
        uint32_t holes_ref = 0, mismatches = 0, edge_mismatches = 0;
        for (uint32_t y = 0; y < H; y++)
            for (uint32_t x = 0; x < W; x++) {
                if (material_at(&ref_opaque, x, y) != MAT_MASKED)
                    continue; /* not behind the quad's outline */
                bool ref_through = material_at(&ref, x, y) != MAT_MASKED,
                     gpu_through = material_at(&gpu, x, y) != MAT_MASKED;
                holes_ref += ref_through;
                if (ref_through == gpu_through)
                    continue;
                bool edge = false;
                for (int dy = -1; dy <= 1; dy++)
                    for (int dx = -1; dx <= 1; dx++) {
                        int nx = (int)x + dx, ny = (int)y + dy;
                        if (nx >= 0 && ny >= 0 && nx < W && ny < H &&
                            (material_at(&ref, (uint32_t)nx, (uint32_t)ny) != MAT_MASKED) != ref_through)
                            edge = true;
                    }
                *(edge ? &edge_mismatches : &mismatches) += 1;
            }
        printf("alpha mask: %u pixels seen through holes (reference), %u disagree at hole edges, %u elsewhere\n",
               holes_ref, edge_mismatches, mismatches);
        /* Measured: no pixel disagrees (the same alpha at the same uv and footprint); edge pixels are allowed
         * to (a texel's alpha at the cutoff), at most a tenth of the holes' pixels. */
        CHECK(holes_ref >= 30);
        CHECK(mismatches == 0);
        CHECK(edge_mismatches * 10 <= holes_ref);

        /* The normal image: changes the normal layer at the wall's pixels, nowhere else; matches the reference. */
        uint32_t wall = 0, changed = 0, changed_elsewhere = 0, compared = 0;
        double angle_sum = 0.0, angle_max = 0.0;
        for (uint32_t y = 0; y < H; y++)
            for (uint32_t x = 0; x < W; x++) {
                size_t i = ((size_t)y * W + x) * 4;
                bool differs = memcmp(&gpu.normal[i], &gpu_flat.normal[i], 4 * sizeof(float)) != 0;
                if (material_at(&gpu, x, y) == MAT_WALL) {
                    wall++;
                    changed += differs;
                } else {
                    changed_elsewhere += differs;
                }
                if (interior(&ref, &gpu, x, y) && material_at(&ref, x, y) == MAT_WALL) {
                    double c = 0.0;
                    for (int k = 0; k < 3; k++)
                        c += (double)gpu.normal[i + k] * ref.normal[i + k];
                    double a = acos(fmin(1.0, c)) * 180.0 / 3.14159265358979;
                    angle_sum += a;
                    angle_max = fmax(angle_max, a);
                    compared++;
                }
            }
        printf(
            "normal image: %u wall pixels, %u changed, %u changed elsewhere; vs reference over %u: mean %.3f deg, "
            "max %.3f deg\n",
            wall, changed, changed_elsewhere, compared, compared ? angle_sum / compared : 0.0, angle_max);
        CHECK(wall >= 200);
        CHECK(changed * 10 >= wall * 9);
        CHECK(changed_elsewhere == 0);
        /* Measured: mean 0.001, max 0.02 degrees (float rounding of the same rules); 0.05 and 0.5 allowed. */
        CHECK(compared > 100 && angle_sum / compared < 0.05);
        CHECK(angle_max < 0.5);

        /* Emission: the panel's stripes in the radiance. Rendered without
         * reflections (base color 0: radiance = emission), so no noisy term
         * hides it: the panel's glossy reflection of the bumped wall differed
         * from the reference's 16 samples by up to 0.036 of (ref + 0.5). */
        cv_render_settings no_reflections = settings;
        no_reflections.reflections = -1;
        no_reflections.frames = 1;
        cv_render_output gpu_e = { 0 }, ref_e = { 0 };
        CHECK_OK(cv_test_render(1, scene, bvh, &no_reflections, &gpu_e, NULL));
        CHECK_OK(cv_render_reference(scene, bvh, &no_reflections, 1, 2, &ref_e));
        uint32_t panel = 0, bright[3] = { 0 };
        double rad_err = 0.0;
        for (uint32_t y = 0; y < H && gpu_e.radiance && ref_e.radiance; y++)
            for (uint32_t x = 0; x < W; x++) {
                if (!interior(&ref_e, &gpu_e, x, y) || material_at(&ref_e, x, y) != MAT_PANEL)
                    continue;
                size_t i = ((size_t)y * W + x) * 4;
                panel++;
                for (int k = 0; k < 3; k++) {
                    rad_err = fmax(rad_err, fabs((double)gpu_e.radiance[i + k] - ref_e.radiance[i + k]) /
                                                (ref_e.radiance[i + k] + 0.5));
                    bright[k] += gpu_e.radiance[i + k] > 2.0f;
                }
            }
        printf("emission: %u panel pixels, stripes bright in r %u g %u b %u, worst |gpu - ref| / (ref + 0.5) %.2e\n",
               panel, bright[0], bright[1], bright[2], rad_err);
        CHECK(panel >= 20);
        CHECK(bright[0] > 0 && bright[1] > 0 && bright[2] > 0);
        /* The same texels by the same rules (the G-buffer's footprint against the reference's ray differentials,
         * as the albedo check above): measured 1.7e-5 on lavapipe, 2.4e-3 on the H200 (its derivatives differ
         * more: see the albedo); half an 8-bit step of the emission strength (3 / 510) allowed, 0.03 when the check still
         * had the reflection in it. */
        CHECK(rad_err < 3.0 / 510.0);
        cv_render_output_free(&gpu_e);
        cv_render_output_free(&ref_e);
    }
    cv_render_output_free(&gpu);
    cv_render_output_free(&gpu2);
    cv_render_output_free(&ref);
    cv_render_output_free(&gpu_flat);
    cv_render_output_free(&ref_opaque);
    cv_bvh_destroy(bvh);
    cv_bvh_destroy(flat_bvh);
    cv_bvh_destroy(opaque_bvh);
    cv_scene_destroy(scene);
    cv_scene_destroy(flat);
    cv_scene_destroy(opaque);
    check_box_textured();
    CHECK_NOTHING_LIVE();
    return check_report("renderer_texture");
}
