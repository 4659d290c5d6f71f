/* Scene files written by a hostile tester, none of which may hang, exhaust
 * memory or fail silently: non-regular files, glTF/GLB files whose lengths or
 * node graphs are lies, truncated ones, and scenes too small or too large to
 * frame. Each must fail fast with a message naming the file and the problem. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "check.h"
#include "corvid/scene_import.h"
#include "scene_test_util.h"

static char dir[] = "/tmp/corvid_hostile_XXXXXX";

static const char *path_of(const char *name) {
    static char path[4][512];
    static int slot;
    slot = (slot + 1) % 4;
    snprintf(path[slot], sizeof path[slot], "%s/%s", dir, name);
    return path[slot];
}

static double now_s(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + ts.tv_nsec / 1e9;
}

/* Import must fail with `code`, within a second, naming the file and `what`. */
static void expect_rejected(const char *path, cv_result code, const char *what) {
    cv_scene *s = NULL;
    double t = now_s();
    CHECK_RESULT(cv_scene_import(path, &s), code);
    t = now_s() - t;
    CHECK(t < 1.0);
    CHECK(s == NULL);
    CHECK(strstr(cv_last_error(), path) != NULL);
    if (what && !strstr(cv_last_error(), what))
        fprintf(stderr, "expected '%s' in: %s\n", what, cv_last_error());
    CHECK(what == NULL || strstr(cv_last_error(), what) != NULL);
}

/* A FIFO used to block the import (in fopen) until a writer came. */
static void test_non_regular(void) {
    const char *fifo = path_of("scene.obj");
    CHECK(mkfifo(fifo, 0600) == 0);
    expect_rejected(fifo, CV_ERROR_IO, "not a regular file");
    unlink(fifo);
    expect_rejected("/dev/null", CV_ERROR_IO, "not a regular file");
}

static void put32(unsigned char *p, uint32_t v) {
    for (int i = 0; i < 4; i++)
        p[i] = (unsigned char)(v >> (8 * i));
}

/* A GLB whose JSON chunk claims 0xFFFFFFF0 bytes made assimp allocate them
 * (36 s, 4.2 GB for 588 bytes); a GLB whose header claims more than the file
 * holds is a truncated file, not one "no reader" takes. */
static void test_glb_lengths(void) {
    static const char json[] = "{\"asset\":{\"version\":\"2.0\"},\"scenes\":[{\"nodes\":[]}]}    ";
    unsigned char glb[588] = { 0 };
    size_t json_size = sizeof json - 1;
    memcpy(glb, "glTF", 4);
    put32(glb + 4, 2);
    put32(glb + 8, sizeof glb);
    put32(glb + 12, 0xFFFFFFF0u);
    memcpy(glb + 16, "JSON", 4);
    memcpy(glb + 20, json, json_size);
    const char *path = path_of("huge_chunk.glb");
    write_whole_file(path, glb, sizeof glb);
    expect_rejected(path, CV_ERROR_MALFORMED, "chunk 0 claims 4294967280 bytes, only 568 follow");
    unlink(path);

    put32(glb + 12, (uint32_t)json_size);
    path = path_of("cut.glb");
    write_whole_file(path, glb, 300);
    expect_rejected(path, CV_ERROR_MALFORMED, "truncated GLB: its header says 588 bytes, the file has 300");
    unlink(path);
    write_whole_file(path, glb, 7);
    expect_rejected(path, CV_ERROR_MALFORMED, "truncated GLB");
    unlink(path);
}

/* Writes a glTF of `levels` + 1 nodes, node i listing node i + 1 twice as
 * its child: 2^(levels + 1) - 1 instances once expanded. */
static void write_dag(const char *path, int levels, bool cycle) {
    char json[8192];
    int n = snprintf(json, sizeof json,
                     "{\"asset\":{\"version\":\"2.0\"},\"scene\":0,"
                     "\"scenes\":[{\"nodes\":[0]}],\"nodes\":[");
    for (int i = 0; i <= levels; i++) {
        if (i < levels)
            n += snprintf(json + n, sizeof json - n, "{\"children\":[%d,%d]},", i + 1, i + 1);
        else
            n += snprintf(json + n, sizeof json - n, cycle ? "{\"children\":[0]}" : "{}");
    }
    n += snprintf(json + n, sizeof json - n, "]}");
    write_whole_file(path, json, (size_t)n);
}

/* A 1.2 KB glTF of 30 levels, each node referencing the next twice, cost
 * assimp over 12 GB: its node graph expands to 2^31 - 1 instances. */
static void test_node_graph(void) {
    const char *path = path_of("dag.gltf");
    write_dag(path, 30, false);
    expect_rejected(path, CV_ERROR_LIMIT_EXCEEDED, "expands to more than 1000000 node instances");
    write_dag(path, 3, true);
    expect_rejected(path, CV_ERROR_MALFORMED, "cycle through node 0");
    const char bad_child[] = "{\"asset\":{\"version\":\"2.0\"},\"nodes\":[{\"children\":[7]}]}";
    write_whole_file(path, bad_child, sizeof bad_child - 1);
    expect_rejected(path, CV_ERROR_MALFORMED, "node 0 has a child that is not a node index in 0..0");
    unlink(path);
}

/* Truncated JSON is called truncated (assimp said "No suitable reader found"). */
static void test_truncated_json(void) {
    const char json[] =
        "{\"asset\":{\"version\":\"2.0\"},\"buffers\":[{\"uri\":\"data:application/octet-stream;base64,AAAA";
    const char *path = path_of("cut.gltf");
    write_whole_file(path, json, sizeof json - 1);
    expect_rejected(path, CV_ERROR_MALFORMED, "truncated glTF");
    write_whole_file(path, "{\"asset\":}", 11);
    expect_rejected(path, CV_ERROR_MALFORMED, "invalid glTF: its JSON does not parse at byte 9");
    unlink(path);
}

/* An OBJ cube of side `side` with its corner at `at` on every axis. */
static const char *write_cube(const char *name, double at, double side) {
    const char *path = path_of(name);
    FILE *f = fopen(path, "w");
    CHECK(f != NULL);
    if (!f)
        return path;
    for (int v = 0; v < 8; v++)
        fprintf(f, "v %.9g %.9g %.9g\n", at + side * (v & 1), at + side * (v >> 1 & 1), at + side * (v >> 2 & 1));
    fprintf(f, "f 1 2 4 3\nf 5 6 8 7\nf 1 2 6 5\nf 3 4 8 7\nf 1 3 7 5\nf 2 4 8 6\n");
    fclose(f);
    return path;
}

/* Scenes at extreme scales: the framing camera must see those it can (its
 * target at the centre, its position finite and away from it), and the
 * others are refused with figures rather than rendered as an empty sky. */
static void test_extreme_scales(void) {
    static const struct {
        double at, side;
        bool frameable;
    } cases[] = {
        { 0.0, 1.0, true },   { 0.0, 1e-5, true },   { 1e-3, 1e-7, true },
        { 0.0, 1e17, true },  { 0.0, 1e-25, false }, { 1e3, 1e-5, false },
        { 0.0, 1e20, false }, { 0.0, 3e38, false },  { 3e38, 1e30, false },
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        const char *path = write_cube("cube.obj", cases[i].at, cases[i].side);
        cv_scene *s = NULL;
        cv_result r = cv_scene_import(path, &s);
        if (r != CV_OK) {
            /* Coordinates past float's range are refused by the import itself. */
            CHECK(!cases[i].frameable);
            CHECK_RESULT(r, CV_ERROR_MALFORMED);
            continue;
        }
        if (cases[i].frameable) {
            CHECK_OK(cv_scene_check_framing(s));
            cv_camera c = cv_scene_framing_camera(s);
            double center = cases[i].at + 0.5 * cases[i].side;
            for (int k = 0; k < 3; k++) {
                CHECK(isfinite(c.position[k]));
                CHECK(fabs(c.target[k] - center) <= 1e-3 * cases[i].side + 1e-6 * fabs(center));
                /* 2.2 radii along the diagonal: 2.2 * sqrt(3) / 2 / sqrt(3) sides per axis. */
                CHECK(fabs((c.position[k] - c.target[k]) / cases[i].side - 1.1) < 1e-3);
            }
        } else {
            CHECK_RESULT(cv_scene_check_framing(s), CV_ERROR_OUT_OF_RANGE);
            CHECK(strncmp(cv_last_error(), "scene ", 6) == 0);
        }
        cv_scene_destroy(s);
    }
    unlink(path_of("cube.obj"));
}

int main(void) {
    CHECK(mkdtemp(dir) != NULL);
    test_non_regular();
    test_glb_lengths();
    test_node_graph();
    test_truncated_json();
    test_extreme_scales();
    CHECK(rmdir(dir) == 0);
    return check_report("test_scene_hostile");
}
