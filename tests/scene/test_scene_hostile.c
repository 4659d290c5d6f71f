/* Scene files written by a hostile tester, none of which may hang, exhaust
 * memory or fail silently: non-regular files, glTF/GLB files whose lengths or
 * node graphs are lies, truncated ones, and scenes too small or too large to
 * frame. Each must fail fast with a message naming the file and the problem. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "check.h"
#include "corvid/scene_import.h"

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

int main(void) {
    CHECK(mkdtemp(dir) != NULL);
    test_non_regular();
    CHECK(rmdir(dir) == 0);
    return check_report("test_scene_hostile");
}
