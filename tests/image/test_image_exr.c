/* cv_exr_write / cv_exr_read: float channels round trip bit for bit and half
 * channels to half precision under every compression; layer and channel
 * names survive; bad descriptions, unwritable paths, garbage and truncated
 * files fail with the documented codes and leave nothing behind. */
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "check.h"
#include "corvid/image_exr.h"
#include "scratch_dir.h"

#define W 37 /* odd sizes: partial chunks for ZIP (16 rows) and PIZ (32) */
#define H 45

static float sample(uint32_t x, uint32_t y, uint32_t c) {
    return (float)((int)((x * 73 + y * 151 + c * 31) % 1000) - 300) / 37.0f;
}

/* Values a float channel must carry exactly, special ones included. */
static float special(uint32_t i) {
    static const float values[] = { 0.0f,      -0.0f, 1e-40f,      -FLT_MAX, FLT_MAX, INFINITY,
                                    -INFINITY, NAN,   1.0f / 3.0f, 65504.0f, 1e20f };
    return values[i % (sizeof values / sizeof values[0])];
}

static const cv_exr_compression compressions[] = { CV_EXR_ZIP, CV_EXR_PIZ, CV_EXR_NONE };

static void test_float_round_trip(void) {
    static float nx[W * H], ny[W * H], nz[W * H], depth[W * H];
    for (uint32_t i = 0; i < W * H; i++) {
        nx[i] = sample(i % W, i / W, 0);
        ny[i] = sample(i % W, i / W, 1) * 1e-3f;
        nz[i] = sample(i % W, i / W, 2) * 1e6f;
        depth[i] = i < 64 ? special(i) : sample(i % W, i / W, 3);
    }
    cv_exr_layer layers[] = {
        { .name = "normal",
          .channel_count = 3,
          .channels = { "X", "Y", "Z" },
          .type = CV_EXR_FLOAT,
          .planes = { nx, ny, nz } },
        { .name = "depth", .channel_count = 1, .channels = { "Z" }, .type = CV_EXR_FLOAT, .planes = { depth } },
    };
    for (int k = 0; k < 3; k++) {
        const char *path = scratch_path(0, "float.exr");
        CHECK_OK(cv_exr_write(
            path, &(cv_exr_desc){
                      .width = W, .height = H, .compression = compressions[k], .layer_count = 2, .layers = layers }));
        cv_exr_image img;
        CHECK_OK(cv_exr_read(path, &img));
        CHECK_EQ_INT(img.width, W);
        CHECK_EQ_INT(img.height, H);
        CHECK_EQ_INT(img.compression, compressions[k]);
        CHECK_EQ_INT(img.channel_count, 4);
        const float *rx = cv_exr_image_find(&img, "normal.X");
        const float *ry = cv_exr_image_find(&img, "normal.Y");
        const float *rz = cv_exr_image_find(&img, "normal.Z");
        const float *rd = cv_exr_image_find(&img, "depth.Z");
        CHECK(rx && ry && rz && rd);
        if (rx && ry && rz && rd) {
            CHECK(memcmp(rx, nx, sizeof nx) == 0);
            CHECK(memcmp(ry, ny, sizeof ny) == 0);
            CHECK(memcmp(rz, nz, sizeof nz) == 0);
            CHECK(memcmp(rd, depth, sizeof depth) == 0); /* NaN and -0 bits included */
        }
        for (uint32_t i = 0; i < img.channel_count; i++)
            CHECK_EQ_INT(img.channels[i].type, CV_EXR_FLOAT);
        cv_exr_image_free(&img);
        CHECK(img.channels == NULL && img.channel_count == 0);
    }
}

/* |decoded - v| within half rounding: half a unit in the last place of an
 * 11-bit significand for normal halves, 2^-25 below them; beyond 65504
 * (half's largest) values round to infinity. */
static bool within_half(float v, float decoded) {
    float a = fabsf(v);
    if (a >= 65520.0f)
        return isinf(decoded) && signbit(decoded) == signbit(v);
    if (a < 6.103515625e-05f) /* 2^-14, smallest normal half */
        return fabsf(decoded - v) <= 0x1p-25f;
    return fabsf(decoded - v) <= a * 0x1p-11f;
}

static void test_half_round_trip(void) {
    /* Channels with clearly different values, so swapped or reordered
     * channels (OpenEXRCore 3.1 returns half RGBA as ABGR when decoded
     * interleaved) cannot pass. */
    static float rgba[W * H * 4];
    for (uint32_t i = 0; i < W * H; i++) {
        float scale = powf(2.0f, (float)(int)(i % 40) - 24.0f);
        rgba[i * 4 + 0] = 1.0f + sample(i % W, i / W, 0) * scale;
        rgba[i * 4 + 1] = 100.0f + (float)(i % 97);
        rgba[i * 4 + 2] = -3.0f - sample(i % W, i / W, 2) * 1e-4f;
        rgba[i * 4 + 3] = i < 8 ? (float[]){ 0.5f, 65504.0f, 1e5f, -1e5f, 0x1p-24f, 0x1p-14f, 0.0f, 1.0f / 3.0f }[i]
                                : (float)(i % 2);
    }
    cv_exr_layer beauty = {
        .channel_count = 4, .channels = { "R", "G", "B", "A" }, .type = CV_EXR_HALF, .interleaved = rgba
    };
    for (int k = 0; k < 3; k++) {
        const char *path = scratch_path(0, "half.exr");
        CHECK_OK(cv_exr_write(path, &(cv_exr_desc){ .width = W,
                                                    .height = H,
                                                    .compression = compressions[k],
                                                    .layer_count = 1,
                                                    .layers = &beauty }));
        cv_exr_image img;
        CHECK_OK(cv_exr_read(path, &img));
        const char *names[4] = { "R", "G", "B", "A" };
        uint32_t outside = 0;
        for (int c = 0; c < 4; c++) {
            const float *plane = cv_exr_image_find(&img, names[c]);
            CHECK(plane != NULL);
            for (uint32_t i = 0; plane && i < W * H; i++)
                outside += !within_half(rgba[i * 4 + c], plane[i]);
        }
        CHECK_EQ_INT(outside, 0);
        /* Values a half holds exactly come back exactly. */
        const float *a = cv_exr_image_find(&img, "A");
        if (a != NULL) {
            CHECK(a[0] == 0.5f && a[1] == 65504.0f && a[4] == 0x1p-24f && a[5] == 0x1p-14f && a[6] == 0.0f &&
                  a[9] == 1.0f);
            CHECK(isinf(a[2]) && a[2] > 0 && isinf(a[3]) && a[3] < 0);
            CHECK(a[7] != 1.0f / 3.0f && fabsf(a[7] - 1.0f / 3.0f) <= 0x1p-13f);
        }
        for (uint32_t i = 0; i < img.channel_count; i++)
            CHECK_EQ_INT(img.channels[i].type, CV_EXR_HALF);
        cv_exr_image_free(&img);
    }
}

static void test_layers_and_names(void) {
    static float rgba[W * H * 4], albedo[3][W * H], normal[W * H * 3], depth[W * H], ao[W * H];
    for (uint32_t i = 0; i < W * H; i++) {
        for (int c = 0; c < 4; c++)
            rgba[i * 4 + c] = (float)(c + 1) * 0.25f;
        for (int c = 0; c < 3; c++) {
            albedo[c][i] = 0.125f * (float)(c + 1);
            normal[i * 3 + c] = (float)(c + 1) * -1.5f;
        }
        depth[i] = 10.0f + (float)i;
        ao[i] = (float)(i % 5) * 0.25f;
    }
    cv_exr_layer layers[] = {
        { .channel_count = 4, .channels = { "R", "G", "B", "A" }, .type = CV_EXR_HALF, .interleaved = rgba },
        { .name = "albedo",
          .channel_count = 3,
          .channels = { "R", "G", "B" },
          .type = CV_EXR_HALF,
          .planes = { albedo[0], albedo[1], albedo[2] } },
        { .name = "normal",
          .channel_count = 3,
          .channels = { "X", "Y", "Z" },
          .type = CV_EXR_FLOAT,
          .interleaved = normal },
        { .name = "depth", .channel_count = 1, .channels = { "Z" }, .type = CV_EXR_FLOAT, .planes = { depth } },
        { .name = "ao", .channel_count = 1, .channels = { "Y" }, .type = CV_EXR_HALF, .planes = { ao } },
    };
    const char *path = scratch_path(0, "layers.exr");
    CHECK_OK(cv_exr_write(
        path,
        &(cv_exr_desc){ .width = W, .height = H, .compression = CV_EXR_PIZ, .layer_count = 5, .layers = layers }));
    cv_exr_image img;
    CHECK_OK(cv_exr_read(path, &img));
    static const char *expected[] = { "A",        "B",    "G",       "R",        "albedo.B", "albedo.G",
                                      "albedo.R", "ao.Y", "depth.Z", "normal.X", "normal.Y", "normal.Z" };
    static const cv_exr_type types[] = { CV_EXR_HALF,  CV_EXR_HALF,  CV_EXR_HALF,  CV_EXR_HALF,
                                         CV_EXR_HALF,  CV_EXR_HALF,  CV_EXR_HALF,  CV_EXR_HALF,
                                         CV_EXR_FLOAT, CV_EXR_FLOAT, CV_EXR_FLOAT, CV_EXR_FLOAT };
    CHECK_EQ_INT(img.channel_count, 12);
    for (uint32_t i = 0; i < img.channel_count && i < 12; i++) {
        CHECK(strcmp(img.channels[i].name, expected[i]) == 0);
        CHECK_EQ_INT(img.channels[i].type, types[i]);
    }
    /* Every plane holds its own layer's values (all exactly representable). */
    struct {
        const char *name;
        float first, last;
    } probes[] = {
        { "R", 0.25f, 0.25f },
        { "G", 0.5f, 0.5f },
        { "B", 0.75f, 0.75f },
        { "A", 1.0f, 1.0f },
        { "albedo.R", 0.125f, 0.125f },
        { "albedo.G", 0.25f, 0.25f },
        { "albedo.B", 0.375f, 0.375f },
        { "normal.X", -1.5f, -1.5f },
        { "normal.Y", -3.0f, -3.0f },
        { "normal.Z", -4.5f, -4.5f },
        { "depth.Z", 10.0f, 10.0f + W * H - 1 },
        { "ao.Y", 0.0f, (float)((W * H - 1) % 5) * 0.25f },
    };
    for (size_t p = 0; p < sizeof probes / sizeof probes[0]; p++) {
        const float *plane = cv_exr_image_find(&img, probes[p].name);
        CHECK(plane != NULL);
        if (plane != NULL)
            CHECK(plane[0] == probes[p].first && plane[W * H - 1] == probes[p].last);
    }
    CHECK(cv_exr_image_find(&img, "albedo.A") == NULL);
    CHECK(cv_exr_image_find(&img, "Z") == NULL);
    cv_exr_image_free(&img);
}

static void test_compression_choice(void) {
    static float smooth[256 * 64];
    for (uint32_t i = 0; i < 256 * 64; i++)
        smooth[i] = (float)(i % 256) / 256.0f;
    cv_exr_layer layer = {
        .name = "ao", .channel_count = 1, .channels = { "Y" }, .type = CV_EXR_HALF, .planes = { smooth }
    };
    size_t sizes[3];
    for (int k = 0; k < 3; k++) {
        const char *path = scratch_path(0, "size.exr");
        CHECK_OK(cv_exr_write(path, &(cv_exr_desc){ .width = 256,
                                                    .height = 64,
                                                    .compression = compressions[k],
                                                    .layer_count = 1,
                                                    .layers = &layer }));
        unsigned char *bytes = NULL;
        CHECK(file_read_all(path, &bytes, &sizes[k]));
        free(bytes);
    }
    /* 32 KiB of half data: compressed well below, uncompressed above. */
    CHECK(sizes[2] > 256 * 64 * 2);
    CHECK(sizes[0] * 4 < sizes[2] && sizes[1] * 4 < sizes[2]);
}

static void test_rejected_descriptions(void) {
    float plane[4] = { 0 };
    const char *path = scratch_path(0, "never.exr");
    cv_exr_layer ok = {
        .name = "ao", .channel_count = 1, .channels = { "Y" }, .type = CV_EXR_HALF, .planes = { plane }
    };
    cv_exr_desc desc = { .width = 2, .height = 2, .layer_count = 1, .layers = &ok };
    int entries = scratch_dir_entries();

    cv_exr_desc d = desc;
    d.width = 0;
    CHECK_RESULT(cv_exr_write(path, &d), CV_ERROR_INVALID_ARGUMENT);
    CHECK(strncmp(cv_last_error(), path, strlen(path)) == 0);
    d = desc;
    d.compression = (cv_exr_compression)9;
    CHECK_RESULT(cv_exr_write(path, &d), CV_ERROR_INVALID_ARGUMENT);
    d = desc;
    d.layer_count = 0;
    CHECK_RESULT(cv_exr_write(path, &d), CV_ERROR_INVALID_ARGUMENT);

    cv_exr_layer twice[2] = { ok, ok };
    d = desc;
    d.layers = twice;
    d.layer_count = 2;
    CHECK_RESULT(cv_exr_write(path, &d), CV_ERROR_INVALID_ARGUMENT);
    CHECK(strstr(cv_last_error(), "channel 'ao.Y' appears twice") != NULL);

    cv_exr_layer bad = ok;
    bad.name = "a_layer_name_far_too_long_for_exr";
    d = desc;
    d.layers = &bad;
    CHECK_RESULT(cv_exr_write(path, &d), CV_ERROR_INVALID_ARGUMENT);
    CHECK(strstr(cv_last_error(), "longer than 31") != NULL);
    bad = ok;
    bad.planes[0] = NULL;
    CHECK_RESULT(cv_exr_write(path, &d), CV_ERROR_INVALID_ARGUMENT);
    CHECK(strstr(cv_last_error(), "planes[0]") != NULL);
    bad = ok;
    bad.channel_count = 5;
    CHECK_RESULT(cv_exr_write(path, &d), CV_ERROR_INVALID_ARGUMENT);
    bad = ok;
    bad.type = (cv_exr_type)0;
    CHECK_RESULT(cv_exr_write(path, &d), CV_ERROR_INVALID_ARGUMENT);
    bad = ok;
    bad.channels[0] = "";
    CHECK_RESULT(cv_exr_write(path, &d), CV_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(cv_exr_write(path, NULL), CV_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(cv_exr_write(NULL, &desc), CV_ERROR_INVALID_ARGUMENT);
    CHECK_EQ_INT(scratch_dir_entries(), entries);
}

static void test_unwritable_path(void) {
    float plane[4] = { 1, 2, 3, 4 };
    cv_exr_layer layer = { .channel_count = 1, .channels = { "Y" }, .type = CV_EXR_FLOAT, .planes = { plane } };
    cv_exr_desc desc = { .width = 2, .height = 2, .layer_count = 1, .layers = &layer };
    const char *path = scratch_path(0, "no-such-dir/out.exr");
    int entries = scratch_dir_entries();
    CHECK_RESULT(cv_exr_write(path, &desc), CV_ERROR_IO);
    CHECK(strncmp(cv_last_error(), path, strlen(path)) == 0);
    /* A path under a regular file. */
    CHECK(file_write_all(scratch_path(1, "plain"), "x", 1));
    CHECK_RESULT(cv_exr_write(scratch_path(0, "plain/out.exr"), &desc), CV_ERROR_IO);
    CHECK_EQ_INT(scratch_dir_entries(), entries + 1);
    unlink(scratch_path(1, "plain"));
}

/* A write that fails half way (the file-size limit makes write() fail with
 * EFBIG) is IO, leaves the existing file as it was and no temporary file. */
static void test_failed_write_keeps_existing(void) {
    static float noise[256 * 256];
    for (uint32_t i = 0; i < 256 * 256; i++)
        noise[i] = sample(i * 7919 % 256, i / 256, 0) * (float)(i % 13);
    cv_exr_layer layer = {
        .name = "depth", .channel_count = 1, .channels = { "Z" }, .type = CV_EXR_FLOAT, .planes = { noise }
    };
    const char *path = scratch_path(0, "keep.exr");
    CHECK(file_write_all(path, "original", 8));
    int entries = scratch_dir_entries();
    limit_file_size(64 * 1024);
    CHECK_RESULT(cv_exr_write(path,
                              &(cv_exr_desc){ .width = 256, .height = 256, .layer_count = 1, .layers = &layer }),
                 CV_ERROR_IO);
    limit_file_size(0);
    CHECK(strstr(cv_last_error(), "writing pixels") != NULL);
    unsigned char *bytes = NULL;
    size_t size = 0;
    CHECK(file_read_all(path, &bytes, &size));
    CHECK(size == 8 && bytes != NULL && memcmp(bytes, "original", 8) == 0);
    free(bytes);
    CHECK_EQ_INT(scratch_dir_entries(), entries);
    /* Without the limit the same write replaces it. */
    CHECK_OK(cv_exr_write(path, &(cv_exr_desc){ .width = 256, .height = 256, .layer_count = 1, .layers = &layer }));
    cv_exr_image img;
    CHECK_OK(cv_exr_read(path, &img));
    CHECK(img.channel_count == 1 && memcmp(img.channels[0].pixels, noise, sizeof noise) == 0);
    cv_exr_image_free(&img);
    CHECK_EQ_INT(scratch_dir_entries(), entries);
}

static void check_read_fails(const char *path, cv_result code) {
    cv_exr_image img;
    memset(&img, 0x7B, sizeof img);
    cv_exr_image before = img;
    CHECK_RESULT(cv_exr_read(path, &img), code);
    CHECK(strncmp(cv_last_error(), path, strlen(path)) == 0);
    CHECK(memcmp(&img, &before, sizeof img) == 0);
}

static void test_unreadable_files(void) {
    check_read_fails(scratch_path(0, "missing.exr"), CV_ERROR_IO);
    CHECK(file_write_all(scratch_path(0, "empty.exr"), "", 0));
    check_read_fails(scratch_path(0, "empty.exr"), CV_ERROR_MALFORMED);
    unsigned char garbage[4096];
    for (size_t i = 0; i < sizeof garbage; i++)
        garbage[i] = (unsigned char)(i * 131 + 7);
    CHECK(file_write_all(scratch_path(0, "garbage.exr"), garbage, sizeof garbage));
    check_read_fails(scratch_path(0, "garbage.exr"), CV_ERROR_MALFORMED);
    /* The right magic number, then garbage. */
    memcpy(garbage, (const unsigned char[]){ 0x76, 0x2f, 0x31, 0x01, 2, 0, 0, 0 }, 8);
    CHECK(file_write_all(scratch_path(0, "magic.exr"), garbage, sizeof garbage));
    check_read_fails(scratch_path(0, "magic.exr"), CV_ERROR_MALFORMED);

    /* A valid file cut short anywhere: in the header, the chunk offsets, the
     * pixel data, or just its last byte. */
    static float plane[W * H];
    for (uint32_t i = 0; i < W * H; i++)
        plane[i] = sample(i % W, i / W, 0);
    cv_exr_layer layer = {
        .name = "depth", .channel_count = 1, .channels = { "Z" }, .type = CV_EXR_FLOAT, .planes = { plane }
    };
    const char *whole = scratch_path(1, "whole.exr");
    CHECK_OK(cv_exr_write(
        whole,
        &(cv_exr_desc){ .width = W, .height = H, .compression = CV_EXR_NONE, .layer_count = 1, .layers = &layer }));
    unsigned char *bytes = NULL;
    size_t size = 0;
    CHECK(file_read_all(whole, &bytes, &size));
    size_t cuts[] = { 4, 40, size / 4, size / 2, size - 100, size - 1 };
    const char *cut_path = scratch_path(0, "cut.exr");
    for (size_t i = 0; bytes != NULL && i < sizeof cuts / sizeof cuts[0]; i++) {
        CHECK(file_write_all(cut_path, bytes, cuts[i]));
        check_read_fails(cut_path, CV_ERROR_MALFORMED);
    }
    free(bytes);
    CHECK_RESULT(cv_exr_read(NULL, &(cv_exr_image){ 0 }), CV_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(cv_exr_read(whole, NULL), CV_ERROR_INVALID_ARGUMENT);
}

int main(void) {
    scratch_dir_create("exr");
    test_float_round_trip();
    test_half_round_trip();
    test_layers_and_names();
    test_compression_choice();
    test_rejected_descriptions();
    test_unwritable_path();
    test_failed_write_keeps_existing();
    test_unreadable_files();
    cv_exr_image_free(NULL);
    scratch_dir_remove();
    return check_report("test_image_exr");
}
