/* Images and material evaluation (corvid/material_eval.h) on tiny images
 * whose expected values are worked out by hand in the comments: mip chain
 * bytes, bilinear filtering between texel centres, repeat wrap, level of
 * detail from a footprint (trilinear, clamped), sRGB decode, normal maps,
 * the alpha mask, the tangent frame; and the hostile inputs
 * cv_scene_add_image / cv_scene_add_material must refuse, each naming the
 * field and leaving the scene as it was. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "check.h"
#include "corvid/material_eval.h"
#include "corvid/scene.h"

#define NEAR(a, b, tol) CHECK(fabs((double)(a) - (double)(b)) <= (tol))

static bool error_mentions(const char *word) {
    bool ok = strstr(cv_last_error(), word) != NULL;
    if (!ok)
        fprintf(stderr, "error '%s' does not mention '%s'\n", cv_last_error(), word);
    return ok;
}

/* An image whose texels all have r = values[i] (g = b = 0, a = 255). */
static uint32_t add_red_image(cv_scene *s, uint32_t w, uint32_t h, const uint8_t *values) {
    uint8_t px[64 * 4];
    for (uint32_t i = 0; i < w * h; i++) {
        px[4 * i] = values[i];
        px[4 * i + 1] = px[4 * i + 2] = 0;
        px[4 * i + 3] = 255;
    }
    uint32_t index = UINT32_MAX;
    CHECK_OK(cv_scene_add_image(s, &(cv_image_desc){ .width = w, .height = h, .rgba8 = px, .name = "red" }, &index));
    return index;
}

static uint8_t texel(const cv_image *im, uint32_t level, uint32_t x, uint32_t y, int c) {
    uint32_t w = cv_image_level_side(im->width, level);
    return im->texels[4 * (im->level_offset[level] + (uint64_t)y * w + x) + c];
}

static void test_mips(void) {
    cv_scene *s;
    CHECK_OK(cv_scene_create(&s));
    /* 3x3 -> 1x1: all nine fold into one, (sum + 4) / 9. r: sum 455 -> 459 / 9 = 51
     * (50.56 rounded); g: one 5 -> 9 / 9 = 1 (0.56); b: one 4 -> 8 / 9 = 0 (0.44). */
    uint8_t px[9 * 4] = { 0 };
    const uint8_t r[9] = { 10, 20, 30, 40, 50, 60, 70, 80, 95 };
    for (int i = 0; i < 9; i++)
        px[4 * i] = r[i];
    px[4 * 8 + 1] = 5;
    px[4 * 8 + 2] = 4;
    px[4 * 4 + 3] = 255;
    CHECK_OK(cv_scene_add_image(s, &(cv_image_desc){ .width = 3, .height = 3, .rgba8 = px }, NULL));
    const cv_image *im = cv_scene_image(s, 0);
    CHECK_EQ_INT(im->levels, 2);
    CHECK_EQ_INT(im->texel_count, 10);
    CHECK_EQ_INT(im->level_offset[1], 9);
    CHECK_EQ_INT(texel(im, 1, 0, 0, 0), 51);
    CHECK_EQ_INT(texel(im, 1, 0, 0, 1), 1);
    CHECK_EQ_INT(texel(im, 1, 0, 0, 2), 0);
    CHECK_EQ_INT(texel(im, 1, 0, 0, 3), 28); /* (255 + 4) / 9 = 28 (28.3 rounded) */
    CHECK(memcmp(im->texels, px, sizeof px) == 0);

    /* 4x2 -> 2x1 -> 1x1. r rows {1, 2, 3, 4}, {5, 6, 7, 9}: level 1 is
     * (1 + 2 + 5 + 6 + 2) / 4 = 4 (3.5, half up) and (3 + 4 + 7 + 9 + 2) / 4 = 6
     * (5.75); level 2 is (4 + 6 + 1) / 2 = 5. */
    const uint8_t r42[8] = { 1, 2, 3, 4, 5, 6, 7, 9 };
    uint32_t i42 = add_red_image(s, 4, 2, r42);
    im = cv_scene_image(s, i42);
    CHECK_EQ_INT(im->levels, 3);
    CHECK_EQ_INT(im->texel_count, 8 + 2 + 1);
    CHECK_EQ_INT(im->level_offset[1], 8);
    CHECK_EQ_INT(im->level_offset[2], 10);
    CHECK_EQ_INT(texel(im, 1, 0, 0, 0), 4);
    CHECK_EQ_INT(texel(im, 1, 1, 0, 0), 6);
    CHECK_EQ_INT(texel(im, 2, 0, 0, 0), 5);
    CHECK_EQ_INT(texel(im, 2, 0, 0, 3), 255);

    /* 5x1 -> 2x1 -> 1x1: the odd side's last three columns fold into the
     * last texel: {10, 11} -> 11 (10.5 half up), {0, 0, 2} -> (2 + 1) / 3 = 1;
     * then (11 + 1 + 1) / 2 = 6. */
    const uint8_t r51[5] = { 10, 11, 0, 0, 2 };
    uint32_t i51 = add_red_image(s, 5, 1, r51);
    im = cv_scene_image(s, i51);
    CHECK_EQ_INT(im->levels, 3);
    CHECK_EQ_INT(texel(im, 1, 0, 0, 0), 11);
    CHECK_EQ_INT(texel(im, 1, 1, 0, 0), 1);
    CHECK_EQ_INT(texel(im, 2, 0, 0, 0), 6);

    /* Level sizes: 5x3 is 5x3, 2x1, 1x1. */
    uint8_t px53[15 * 4] = { 0 };
    CHECK_OK(cv_scene_add_image(s, &(cv_image_desc){ .width = 5, .height = 3, .rgba8 = px53, .name = "five" }, NULL));
    im = cv_scene_image(s, 3);
    CHECK_EQ_INT(im->levels, 3);
    CHECK_EQ_INT(im->texel_count, 15 + 2 + 1);
    CHECK(strcmp(im->name, "five") == 0);
    CHECK_EQ_INT(cv_image_level_side(5, 1), 2);
    CHECK_EQ_INT(cv_image_level_side(3, 1), 1);
    CHECK_EQ_INT(cv_image_level_side(5, 2), 1);
    CHECK_EQ_INT(cv_image_level_side(5, 40), 1);
    CHECK_EQ_INT(cv_scene_image_count(s), 4);
    CHECK(cv_scene_image(s, 4) == NULL);
    cv_scene_destroy(s);
}

static void test_bilinear_and_wrap(void) {
    cv_scene *s;
    CHECK_OK(cv_scene_create(&s));
    /* 2x2, r = {0, 255; 51, 102} = {0, 1; 0.2, 0.4}. */
    const uint8_t r22[4] = { 0, 255, 51, 102 };
    const cv_image *im = cv_scene_image(s, add_red_image(s, 2, 2, r22));
    float out[4];
    cv_image_sample(im, false, 0.25f, 0.25f, NULL, out); /* texel (0, 0)'s centre */
    NEAR(out[0], 0.0, 1e-6);
    NEAR(out[3], 1.0, 1e-6);
    cv_image_sample(im, false, 0.75f, 0.75f, NULL, out); /* texel (1, 1) */
    NEAR(out[0], 0.4, 1e-6);
    cv_image_sample(im, false, 0.5f, 0.25f, NULL, out); /* halfway along the top row */
    NEAR(out[0], 0.5, 1e-6);
    cv_image_sample(im, false, 0.5f, 0.5f, NULL, out); /* all four: (0 + 1 + 0.2 + 0.4) / 4 */
    NEAR(out[0], 0.4, 1e-6);
    cv_image_sample(im, false, 0.0f, 0.25f, NULL, out); /* the left edge: half texel 1 (wrapped), half texel 0 */
    NEAR(out[0], 0.5, 1e-6);
    /* Decoded before filtering: halfway between sRGB 0 and 255 is 0.5, not srgb(128) = 0.216. */
    cv_image_sample(im, true, 0.5f, 0.25f, NULL, out);
    NEAR(out[0], 0.5, 1e-6);

    /* 3x1, r = {0, 1, 0.2}; v = 0.5 is the only row. */
    const uint8_t r31[3] = { 0, 255, 51 };
    im = cv_scene_image(s, add_red_image(s, 3, 1, r31));
    cv_image_sample(im, false, 0.999f, 0.5f, NULL, out); /* x = 2.497: 0.503 x 0.2 + 0.497 x 0 (texel 0, wrapped) */
    NEAR(out[0], 0.503 * 0.2, 1e-5);
    cv_image_sample(im, false, 1.001f, 0.5f, NULL,
                    out); /* u = 0.001, x = -0.497: 0.497 x 0.2 (texel 2) + 0.503 x 0 */
    NEAR(out[0], 0.497 * 0.2, 1e-5);
    cv_image_sample(im, false, -0.25f, 0.5f, NULL, out); /* u = 0.75, x = 1.75: 0.25 x 1 + 0.75 x 0.2 */
    NEAR(out[0], 0.4, 1e-6);
    cv_image_sample(im, false, 0.5f, 7.3f, NULL, out); /* any v: texel 1's centre */
    NEAR(out[0], 1.0, 1e-6);
    cv_image_sample(im, false, NAN, INFINITY, NULL, out); /* non-finite: (0, 0), halfway between texels 2 and 0 */
    NEAR(out[0], 0.1, 1e-6);
    cv_scene_destroy(s);
}

static void test_levels(void) {
    cv_scene *s;
    CHECK_OK(cv_scene_create(&s));
    /* 4x4 of uniform 2x2 blocks {200, 100; 40, 0}: level 1 is exactly those,
     * level 2 is (200 + 100 + 40 + 0) / 4 = 85. At (0.125, 0.125): level 0 is
     * texel (0, 0) = 200; level 1 is at (-0.25, -0.25): weights 0.75 on column
     * (row) 0 and 0.25 on column (row) 1 (wrapped): rows 175 and 30, then
     * 0.75 x 175 + 0.25 x 30 = 138.75; level 2 is 85. */
    const uint8_t r44[16] = { 200, 200, 100, 100, 200, 200, 100, 100, 40, 40, 0, 0, 40, 40, 0, 0 };
    const cv_image *im = cv_scene_image(s, add_red_image(s, 4, 4, r44));
    CHECK_EQ_INT(im->levels, 3);
    float out[4];
    const float u = 0.125f, v = 0.125f;
    cv_image_sample(im, false, u, v, NULL, out);
    NEAR(out[0], 200.0 / 255, 1e-6);
    cv_image_sample(im, false, u, v, (const float[4]){ 0.25f, 0.0f, 0.0f, 0.25f }, out); /* rho 1: lod 0 */
    NEAR(out[0], 200.0 / 255, 1e-6);
    cv_image_sample(im, false, u, v, (const float[4]){ 0.01f, 0.0f, 0.0f, 0.01f }, out); /* lod < 0: 0 */
    NEAR(out[0], 200.0 / 255, 1e-6);
    cv_image_sample(im, false, u, v, (const float[4]){ 0.0f, 0.0f, 0.0f, 0.0f }, out); /* rho 0: lod 0 */
    NEAR(out[0], 200.0 / 255, 1e-6);
    cv_image_sample(im, false, u, v, (const float[4]){ 0.0f, 0.5f, 0.25f, 0.0f }, out); /* rho 2: lod 1 */
    NEAR(out[0], 138.75 / 255, 1e-6);
    /* rho 2^1.5 (through dv/dy): lod 1.5, halfway between levels 1 and 2. */
    cv_image_sample(im, false, u, v, (const float[4]){ 0.0f, 0.0f, 0.0f, 0.70710678f }, out);
    NEAR(out[0], (0.5 * 138.75 + 0.5 * 85) / 255, 1e-5);
    cv_image_sample(im, false, u, v, (const float[4]){ 100.0f, 0.0f, 0.0f, 0.0f }, out); /* lod 8.6: clamped to 2 */
    NEAR(out[0], 85.0 / 255, 1e-6);
    cv_image_sample(im, false, u, v, (const float[4]){ INFINITY, 0.0f, 0.0f, 0.0f }, out); /* the last level */
    NEAR(out[0], 85.0 / 255, 1e-6);
    cv_scene_destroy(s);
}

static void test_srgb(void) {
    CHECK(cv_srgb_to_linear(0) == 0.0f);
    CHECK(cv_srgb_to_linear(255) == 1.0f);
    NEAR(cv_srgb_to_linear(128), 0.2158605001, 1e-7); /* ((128/255 + 0.055) / 1.055)^2.4 */
    NEAR(cv_srgb_to_linear(10), 0.0030352698, 1e-9);  /* 10/255 / 12.92, the linear segment */
    NEAR(cv_srgb_to_linear(11), 0.0033465358, 1e-9);  /* 11/255 = 0.0431 > 0.04045: the power segment */
    for (int b = 1; b < 256; b++)
        CHECK(cv_srgb_to_linear((uint8_t)b) > cv_srgb_to_linear((uint8_t)(b - 1)));
}

static uint32_t add_1x1(cv_scene *s, uint8_t r, uint8_t g, uint8_t b, uint8_t a) {
    uint8_t px[4] = { r, g, b, a };
    uint32_t index = UINT32_MAX;
    CHECK_OK(cv_scene_add_image(s, &(cv_image_desc){ .width = 1, .height = 1, .rgba8 = px }, &index));
    return index;
}

static void test_material(void) {
    cv_scene *s;
    CHECK_OK(cv_scene_create(&s));
    cv_material_eval e;

    /* Factors alone. */
    cv_material m = cv_material_default();
    CHECK(m.alpha == 1.0f && m.alpha_mode == CV_ALPHA_OPAQUE && m.alpha_cutoff == 0.5f && m.normal_scale == 1.0f);
    CHECK(m.base_color_image == CV_NO_IMAGE && m.metal_rough_image == CV_NO_IMAGE && m.normal_image == CV_NO_IMAGE &&
          m.emissive_image == CV_NO_IMAGE);
    m.base_color[0] = 0.2f, m.base_color[1] = 0.4f, m.base_color[2] = 0.6f;
    m.roughness = 0.3f, m.metalness = 0.7f;
    m.emission[0] = 1.0f, m.emission[1] = 2.0f, m.emission[2] = 3.0f;
    cv_material_evaluate(s, &m, 0.3f, 0.7f, NULL, &e);
    CHECK(e.base_color[0] == 0.2f && e.base_color[1] == 0.4f && e.base_color[2] == 0.6f);
    CHECK(e.roughness == 0.3f && e.metalness == 0.7f && e.alpha == 1.0f && e.present);
    CHECK(e.emission[0] == 1.0f && e.emission[1] == 2.0f && e.emission[2] == 3.0f);
    CHECK(e.normal[0] == 0.0f && e.normal[1] == 0.0f && e.normal[2] == 1.0f);

    /* With images (1x1, so every (u, v) and level is that texel):
     * base (255, 128, 0) sRGB x (0.5, 1, 1) = (0.5, 0.2158605, 0), alpha 255 -> 1;
     * metal/rough g 51 -> 0.2 x 0.3 = 0.06, b 102 -> 0.4 x 0.7 = 0.28 (r, a ignored);
     * emissive 128 sRGB x (1, 2, 3); normal (255, 0, 255) -> (1, -1, 1), scale
     * 0.5 -> (0.5, -0.5, 1) / sqrt(1.5). */
    m.base_color[0] = 0.5f, m.base_color[1] = 1.0f, m.base_color[2] = 1.0f;
    m.base_color_image = 1 + add_1x1(s, 255, 128, 0, 255);
    m.metal_rough_image = 1 + add_1x1(s, 77, 51, 102, 0);
    m.emissive_image = 1 + add_1x1(s, 128, 128, 128, 0);
    m.normal_image = 1 + add_1x1(s, 255, 0, 255, 0);
    m.normal_scale = 0.5f;
    CHECK_OK(cv_scene_add_material(s, &m, NULL));
    cv_material_evaluate(s, &m, -3.3f, 12.1f, (const float[4]){ 0.3f, 0.1f, 0.0f, 0.2f }, &e);
    NEAR(e.base_color[0], 0.5, 1e-6);
    NEAR(e.base_color[1], 0.2158605, 1e-6);
    NEAR(e.base_color[2], 0.0, 1e-6);
    NEAR(e.alpha, 1.0, 1e-6);
    NEAR(e.roughness, 0.06, 1e-6);
    NEAR(e.metalness, 0.28, 1e-6);
    NEAR(e.emission[0], 0.2158605, 1e-6);
    NEAR(e.emission[1], 2 * 0.2158605, 1e-6);
    NEAR(e.emission[2], 3 * 0.2158605, 1e-6);
    NEAR(e.normal[0], 0.40824829, 1e-6);
    NEAR(e.normal[1], -0.40824829, 1e-6);
    NEAR(e.normal[2], 0.81649658, 1e-6);
    CHECK(e.present);

    /* A normal pointing into the surface (b = 0: z = -1) falls back to (0, 0, 1). */
    m.normal_image = 1 + add_1x1(s, 200, 30, 0, 0);
    cv_material_evaluate(s, &m, 0.5f, 0.5f, NULL, &e);
    CHECK(e.normal[0] == 0.0f && e.normal[1] == 0.0f && e.normal[2] == 1.0f);
    /* Flat (128, 128, 255): (1/255, 1/255, 1) normalised: z = 1 / sqrt(1 + 2 / 255^2). */
    m.normal_image = 1 + add_1x1(s, 128, 128, 255, 0);
    m.normal_scale = 1.0f;
    cv_material_evaluate(s, &m, 0.5f, 0.5f, NULL, &e);
    NEAR(e.normal[0], 0.0039215084, 1e-7);
    NEAR(e.normal[2], 0.9999846212, 1e-6);

    /* Alpha mask: image alpha 128 (0.50196) x factor 1 against cutoff 0.5: present;
     * x factor 0.99 = 0.49694: cut; exactly at the cutoff (255 x 0.5 = 0.5): present. */
    cv_material a = cv_material_default();
    a.alpha_mode = CV_ALPHA_MASK;
    a.base_color_image = 1 + add_1x1(s, 255, 255, 255, 128);
    cv_material_evaluate(s, &a, 0.5f, 0.5f, NULL, &e);
    NEAR(e.alpha, 128.0 / 255, 1e-6);
    CHECK(e.present);
    a.alpha = 0.99f;
    cv_material_evaluate(s, &a, 0.5f, 0.5f, NULL, &e);
    CHECK(!e.present);
    a.alpha = 0.5f;
    a.base_color_image = 1 + add_1x1(s, 255, 255, 255, 255);
    cv_material_evaluate(s, &a, 0.5f, 0.5f, NULL, &e);
    CHECK(e.alpha == 0.5f && e.present);
    a.alpha_cutoff = 0.50001f;
    cv_material_evaluate(s, &a, 0.5f, 0.5f, NULL, &e);
    CHECK(!e.present);
    a.alpha_mode = CV_ALPHA_OPAQUE; /* alpha ignored */
    a.alpha = 0.0f;
    cv_material_evaluate(s, &a, 0.5f, 0.5f, NULL, &e);
    CHECK(e.present);
    cv_scene_destroy(s);
}

static void test_tangent_frame(void) {
    /* p = (0,0,0), (2,0,0), (0,3,0) with uv (0,0), (1,0), (0,1): dp/du = (2,0,0),
     * dp/dv = (0,3,0); against n = z: T = x, B = y. */
    float p[3][3] = { { 0, 0, 0 }, { 2, 0, 0 }, { 0, 3, 0 } };
    float uv[3][2] = { { 0, 0 }, { 1, 0 }, { 0, 1 } };
    const float n[3] = { 0, 0, 1 };
    float t[3] = { 9, 9, 9 }, b[3] = { 9, 9, 9 };
    CHECK(cv_triangle_tangent_frame(p, uv, n, t, b));
    CHECK(t[0] == 1.0f && t[1] == 0.0f && t[2] == 0.0f);
    CHECK(b[0] == 0.0f && b[1] == 1.0f && b[2] == 0.0f);
    /* Mirrored u: T = -x; cross(n, T) = -y, B = +y: the sign flips it back to +y. */
    uv[1][0] = -1.0f;
    CHECK(cv_triangle_tangent_frame(p, uv, n, t, b));
    CHECK(t[0] == -1.0f && t[1] == 0.0f && t[2] == 0.0f);
    NEAR(b[0], 0.0, 1e-7);
    NEAR(b[1], 1.0, 1e-7);
    NEAR(b[2], 0.0, 1e-7);
    /* A tilted shading normal: T is made orthogonal to it. n = (0, -0.6, 0.8), T = (1, 0, 0). */
    uv[1][0] = 1.0f;
    const float n2[3] = { 0.0f, -0.6f, 0.8f };
    CHECK(cv_triangle_tangent_frame(p, uv, n2, t, b));
    NEAR(t[0], 1.0, 1e-7);
    NEAR(b[1], 0.8, 1e-6); /* cross(n2, x) = (0, 0.8, 0.6) */
    NEAR(b[2], 0.6, 1e-6);
    /* Degenerate uvs (all equal, or collinear): no frame, outputs untouched. */
    float same[3][2] = { { 0.5f, 0.5f }, { 0.5f, 0.5f }, { 0.5f, 0.5f } };
    float line[3][2] = { { 0, 0 }, { 1, 1 }, { 2, 2 } };
    t[0] = 7.0f;
    CHECK(!cv_triangle_tangent_frame(p, same, n, t, b));
    CHECK(!cv_triangle_tangent_frame(p, line, n, t, b));
    CHECK(t[0] == 7.0f);
    /* T parallel to the normal: no frame. */
    const float nx[3] = { 1, 0, 0 };
    CHECK(!cv_triangle_tangent_frame(p, uv, nx, t, b));
}

static void test_hostile(void) {
    cv_scene *s;
    CHECK_OK(cv_scene_create(&s));
    uint8_t px[16] = { 0 };
    CHECK_RESULT(cv_scene_add_image(s, &(cv_image_desc){ .width = 0, .height = 1, .rgba8 = px, .name = "zero" },
                                    NULL),
                 CV_ERROR_INVALID_ARGUMENT);
    CHECK(error_mentions("zero") && error_mentions("0x1"));
    CHECK_RESULT(cv_scene_add_image(s, &(cv_image_desc){ .width = 1, .height = CV_IMAGE_MAX_SIDE + 1, .rgba8 = px },
                                    NULL),
                 CV_ERROR_INVALID_ARGUMENT);
    CHECK(error_mentions("16385"));
    CHECK_RESULT(cv_scene_add_image(s, &(cv_image_desc){ .width = 1, .height = 1, .rgba8 = NULL, .name = "np" },
                                    NULL),
                 CV_ERROR_INVALID_ARGUMENT);
    CHECK(error_mentions("rgba8"));
    /* 16384 x 16384 with its mips is 1.33 GiB: over the budget, refused before
     * the pixels are read (so the 16-byte buffer is never overrun). */
    CHECK_RESULT(cv_scene_add_image(s,
                                    &(cv_image_desc){ .width = CV_IMAGE_MAX_SIDE,
                                                      .height = CV_IMAGE_MAX_SIDE,
                                                      .rgba8 = px,
                                                      .name = "huge" },
                                    NULL),
                 CV_ERROR_LIMIT_EXCEEDED);
    CHECK(error_mentions("huge"));
    CHECK_EQ_INT(cv_scene_image_count(s), 0);

    add_1x1(s, 1, 2, 3, 4);
    add_1x1(s, 5, 6, 7, 8);
    cv_material m = cv_material_default();
    m.base_color_image = 5;
    CHECK_RESULT(cv_scene_add_material(s, &m, NULL), CV_ERROR_INVALID_ARGUMENT);
    CHECK(error_mentions("base_color_image") && error_mentions("2 images"));
    m = cv_material_default();
    m.normal_image = 3;
    CHECK_RESULT(cv_scene_add_material(s, &m, NULL), CV_ERROR_INVALID_ARGUMENT);
    CHECK(error_mentions("normal_image"));
    m = cv_material_default();
    m.alpha = NAN;
    CHECK_RESULT(cv_scene_add_material(s, &m, NULL), CV_ERROR_INVALID_ARGUMENT);
    CHECK(error_mentions("alpha"));
    m = cv_material_default();
    m.alpha = 1.5f;
    CHECK_RESULT(cv_scene_add_material(s, &m, NULL), CV_ERROR_INVALID_ARGUMENT);
    CHECK(error_mentions("alpha"));
    m = cv_material_default();
    m.alpha_cutoff = -0.1f;
    CHECK_RESULT(cv_scene_add_material(s, &m, NULL), CV_ERROR_INVALID_ARGUMENT);
    CHECK(error_mentions("alpha_cutoff"));
    m = cv_material_default();
    m.alpha_mode = (cv_alpha_mode)7;
    CHECK_RESULT(cv_scene_add_material(s, &m, NULL), CV_ERROR_INVALID_ARGUMENT);
    CHECK(error_mentions("alpha_mode"));
    m = cv_material_default();
    m.normal_scale = INFINITY;
    CHECK_RESULT(cv_scene_add_material(s, &m, NULL), CV_ERROR_INVALID_ARGUMENT);
    CHECK(error_mentions("normal_scale"));
    CHECK_EQ_INT(cv_scene_material_count(s), 0);
    CHECK_EQ_INT(cv_scene_image_count(s), 2);
    /* The last image (reference 2) is fine, as are images used twice. */
    m = cv_material_default();
    m.emissive_image = 2;
    m.base_color_image = 2;
    CHECK_OK(cv_scene_add_material(s, &m, NULL));
    CHECK_EQ_INT(cv_scene_material_count(s), 1);
    cv_scene_destroy(s);
}

int main(void) {
    test_mips();
    test_bilinear_and_wrap();
    test_levels();
    test_srgb();
    test_material();
    test_tangent_frame();
    test_hostile();
    return check_report("test_material_eval");
}
