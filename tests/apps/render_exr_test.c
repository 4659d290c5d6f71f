/* corvid-render's EXR as a user gets it (GPU render on 2 virtual GPUs, and
 * the CPU reference): the right size, every per-pass layer with its channels
 * (beauty R G B A; direct.R G B; shadow.Y; ao.Y; albedo.R G B; normal.X Y Z;
 * depth.Z; reflection.R G B with reflections on, the default; motion.X Y from
 * the GPU render, which always makes it, not from the reference),
 * and sane values: depth.Z finite and > 0 where A = 1, +inf where A = 0;
 * direct within 0 .. beauty per channel (shadow.Y is half: a visibility of
 * 1e-8 reads 0 there, so "0 in shadow" is checked on the float planes in
 * tests/renderer/render_outputs_test.c); shadow and ao within 0..1; normals
 * of unit length on geometry.
 * Usage: render_exr_test CORVID_RENDER */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

#include "check.h"
#include "corvid/image_exr.h"

#define W 96
#define H 54

static const char *expected[] = { "R",        "G",        "B",        "A",        "direct.R", "direct.G",
                                  "direct.B", "shadow.Y", "ao.Y",     "albedo.R", "albedo.G", "albedo.B",
                                  "normal.X", "normal.Y", "normal.Z", "depth.Z" };
#define EXPECTED (sizeof expected / sizeof expected[0])

static void check_frame(const char *path, const char *what, bool motion) {
    cv_exr_image img = { 0 };
    CHECK_OK(cv_exr_read(path, &img));
    CHECK_EQ_INT(img.width, W);
    CHECK_EQ_INT(img.height, H);
    CHECK_EQ_INT(img.channel_count, EXPECTED + 3 + (motion ? 2 : 0));
    for (size_t c = 0; c < EXPECTED; c++)
        if (!cv_exr_image_find(&img, expected[c])) {
            check_failures++;
            fprintf(stderr, "%s: no channel %s\n", what, expected[c]);
        }
    CHECK(cv_exr_image_find(&img, "reflection.R") && cv_exr_image_find(&img, "reflection.B"));
    CHECK((cv_exr_image_find(&img, "motion.X") != NULL) == motion);
    const float *a = cv_exr_image_find(&img, "A"), *z = cv_exr_image_find(&img, "depth.Z"),
                *shadow = cv_exr_image_find(&img, "shadow.Y"), *ao = cv_exr_image_find(&img, "ao.Y");
    const float *beauty[3] = { cv_exr_image_find(&img, "R"), cv_exr_image_find(&img, "G"),
                               cv_exr_image_find(&img, "B") };
    const float *direct[3] = { cv_exr_image_find(&img, "direct.R"), cv_exr_image_find(&img, "direct.G"),
                               cv_exr_image_find(&img, "direct.B") };
    const float *normal[3] = { cv_exr_image_find(&img, "normal.X"), cv_exr_image_find(&img, "normal.Y"),
                               cv_exr_image_find(&img, "normal.Z") };
    bool all = a && z && shadow && ao;
    for (int k = 0; k < 3; k++)
        all = all && beauty[k] && direct[k] && normal[k];
    if (!all) {
        cv_exr_image_free(&img);
        return;
    }
    uint32_t geometry = 0, lit = 0, bad_depth = 0, bad_direct = 0, bad_vis = 0, bad_normal = 0;
    for (uint32_t i = 0; i < W * H; i++) {
        bad_vis += !(shadow[i] >= 0.0f && shadow[i] <= 1.0f && ao[i] >= 0.0f && ao[i] <= 1.0f);
        if (a[i] == 0.0f) {
            bad_depth += !(isinf(z[i]) && z[i] > 0.0f);
            bad_direct += direct[0][i] != 0.0f || direct[1][i] != 0.0f || direct[2][i] != 0.0f;
            continue;
        }
        geometry++;
        bad_depth += !(isfinite(z[i]) && z[i] > 0.0f);
        float len = sqrtf(normal[0][i] * normal[0][i] + normal[1][i] * normal[1][i] + normal[2][i] * normal[2][i]);
        bad_normal += fabsf(len - 1.0f) > 1e-3f;
        for (int k = 0; k < 3; k++)
            bad_direct += !(direct[k][i] >= 0.0f) || direct[k][i] > beauty[k][i] * 1.0001f + 1e-6f;
        lit += direct[0][i] > 0.0f;
    }
    fprintf(stderr, "%s: %u geometry pixels, %u lit by the sun\n", what, geometry, lit);
    CHECK(geometry > W * H / 2);
    CHECK(lit > 0);
    CHECK_EQ_INT(bad_depth, 0);
    CHECK_EQ_INT(bad_direct, 0);
    CHECK_EQ_INT(bad_vis, 0);
    CHECK_EQ_INT(bad_normal, 0);
    cv_exr_image_free(&img);
}

static int run(const char *cmd) {
    int status = system(cmd);
    return status >= 0 && WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

int main(int argc, char **argv) {
    if (argc < 2) {
        fprintf(stderr, "usage: render_exr_test CORVID_RENDER\n");
        return 2;
    }
    char dir[] = "/tmp/corvid_render_exr_XXXXXX", cmd[2048], path[512];
    CHECK(mkdtemp(dir) != NULL);
    snprintf(cmd, sizeof cmd,
             "'%s' --gpus 2 --adapters llvmpipe --size %ux%u --frames 2 --ao-samples 2 --quiet --out '%s/gpu'",
             argv[1], W, H, dir);
    CHECK_EQ_INT(run(cmd), 0);
    snprintf(path, sizeof path, "%s/gpu.exr", dir);
    check_frame(path, "GPU render", true);
    remove(path);
    snprintf(path, sizeof path, "%s/gpu.png", dir);
    remove(path);
    snprintf(cmd, sizeof cmd, "'%s' --reference 1 --size %ux%u --ao-samples 2 --quiet --out '%s/ref'", argv[1], W, H,
             dir);
    CHECK_EQ_INT(run(cmd), 0);
    snprintf(path, sizeof path, "%s/ref.exr", dir);
    check_frame(path, "CPU reference", false);
    remove(path);
    snprintf(path, sizeof path, "%s/ref.png", dir);
    remove(path);
    CHECK(rmdir(dir) == 0);
    CHECK_NOTHING_LIVE();
    return check_report("render_exr");
}
