/* cv_file_set and the writers' temporaries: an EXR and PNG pair replaces the
 * old pair only when both were written; every failure (a PNG that cannot be
 * written, a destination that is a directory, a rename that fails) leaves the
 * old files as they were, no temporary behind, and a message with the
 * system's reason. */
#include <errno.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "check.h"
#include "corvid/image_exr.h"
#include "corvid/image_files.h"
#include "corvid/image_png.h"
#include "scratch_dir.h"

#define W 128
#define H 128

static float plane[W * H];
static uint8_t rgb[W * H * 3];

static cv_result write_exr(const char *path) {
    cv_exr_layer layer = { .channel_count = 1, .channels = { "Y" }, .type = CV_EXR_FLOAT, .planes = { plane } };
    return cv_exr_write(path, &(cv_exr_desc){ .width = W, .height = H, .layer_count = 1, .layers = &layer });
}

static bool file_is(const char *path, const char *text) {
    unsigned char *bytes = NULL;
    size_t size = 0;
    bool same = file_read_all(path, &bytes, &size) && size == strlen(text) && memcmp(bytes, text, size) == 0;
    free(bytes);
    return same;
}

static void write_old_pair(void) {
    CHECK(file_write_all(scratch_path(0, "f.exr"), "old exr", 7));
    CHECK(file_write_all(scratch_path(1, "f.png"), "old png", 7));
}

static void test_pair_committed(void) {
    write_old_pair();
    cv_file_set *set = NULL;
    const char *exr_temp = NULL, *png_temp = NULL;
    CHECK_OK(cv_file_set_create(&set));
    CHECK_OK(cv_file_set_add(set, scratch_path(0, "f.exr"), &exr_temp));
    CHECK_OK(cv_file_set_add(set, scratch_path(1, "f.png"), &png_temp));
    CHECK_EQ_INT(scratch_dir_entries(), 4);
    CHECK_OK(write_exr(exr_temp));
    CHECK_OK(cv_png_write(png_temp, W, H, 3, rgb));
    /* Nothing is replaced before the commit. */
    CHECK(file_is(scratch_path(0, "f.exr"), "old exr") && file_is(scratch_path(1, "f.png"), "old png"));
    CHECK_OK(cv_file_set_commit(set));
    cv_file_set_destroy(set);
    CHECK_EQ_INT(scratch_dir_entries(), 2);
    cv_exr_image exr;
    CHECK_OK(cv_exr_read(scratch_path(0, "f.exr"), &exr));
    CHECK(exr.width == W && exr.channel_count == 1);
    cv_exr_image_free(&exr);
    cv_png_image png;
    CHECK_OK(cv_png_read(scratch_path(1, "f.png"), &png));
    CHECK(png.width == W && png.height == H);
    cv_png_image_free(&png);
}

/* The disk "fills" (file-size limit, EFBIG) while the PNG is written, after
 * the EXR was: neither old file changes and no temporary remains. */
static void test_png_fails_after_exr(void) {
    write_old_pair();
    cv_file_set *set = NULL;
    const char *exr_temp = NULL, *png_temp = NULL;
    CHECK_OK(cv_file_set_create(&set));
    CHECK_OK(cv_file_set_add(set, scratch_path(0, "f.exr"), &exr_temp));
    CHECK_OK(cv_file_set_add(set, scratch_path(1, "f.png"), &png_temp));
    CHECK_OK(write_exr(exr_temp));
    limit_file_size(200);
    CHECK_RESULT(cv_png_write(png_temp, W, H, 3, rgb), CV_ERROR_IO);
    limit_file_size(0);
    CHECK(strstr(cv_last_error(), strerror(EFBIG)) != NULL);
    cv_file_set_destroy(set);
    CHECK(file_is(scratch_path(0, "f.exr"), "old exr") && file_is(scratch_path(1, "f.png"), "old png"));
    CHECK_EQ_INT(scratch_dir_entries(), 2);
}

/* A destination that is a directory is refused when added, before any work. */
static void test_destination_checked_when_added(void) {
    const char *dir = scratch_path(2, "d.png");
    CHECK(mkdir(dir, 0777) == 0);
    cv_file_set *set = NULL;
    const char *temp = NULL;
    CHECK_OK(cv_file_set_create(&set));
    CHECK_RESULT(cv_file_set_add(set, dir, &temp), CV_ERROR_IO);
    CHECK(strstr(cv_last_error(), "is a directory") != NULL);
    CHECK_RESULT(cv_file_set_add(set, scratch_path(3, "sub/"), &temp), CV_ERROR_INVALID_ARGUMENT);
    CHECK(strstr(cv_last_error(), "no file name") != NULL);
    CHECK_RESULT(cv_file_set_add(set, "", &temp), CV_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(cv_file_set_add(set, scratch_path(3, "missing/f.png"), &temp), CV_ERROR_IO);
    CHECK(strstr(cv_last_error(), strerror(ENOENT)) != NULL);
    cv_file_set_destroy(set);
    CHECK(rmdir(dir) == 0);
    CHECK_EQ_INT(scratch_dir_entries(), 2);
}

/* A rename that fails at commit (the PNG's destination became a directory)
 * reports the system's reason and which files were already replaced. */
static void test_failed_rename(void) {
    write_old_pair();
    cv_file_set *set = NULL;
    const char *exr_temp = NULL, *png_temp = NULL;
    CHECK_OK(cv_file_set_create(&set));
    CHECK_OK(cv_file_set_add(set, scratch_path(0, "f.exr"), &exr_temp));
    CHECK_OK(cv_file_set_add(set, scratch_path(2, "g.png"), &png_temp));
    CHECK_OK(write_exr(exr_temp));
    CHECK_OK(cv_png_write(png_temp, W, H, 3, rgb));
    CHECK(mkdir(scratch_path(2, "g.png"), 0777) == 0);
    CHECK(file_write_all(scratch_path(3, "g.png/x"), "x", 1));
    CHECK_RESULT(cv_file_set_commit(set), CV_ERROR_IO);
    CHECK(strstr(cv_last_error(), "g.png: cannot replace") != NULL);
    CHECK(strstr(cv_last_error(), "1 earlier file") != NULL);
    cv_file_set_destroy(set);
    unlink(scratch_path(3, "g.png/x"));
    CHECK(rmdir(scratch_path(2, "g.png")) == 0);
    CHECK_EQ_INT(scratch_dir_entries(), 2);
}

/* The single-file writers over a directory: the rename fails, the reason is
 * the system's (not "Success"), and the temporary is gone. */
static void test_writer_rename_fails(void) {
    const char *dir = scratch_path(2, "dir.exr");
    CHECK(mkdir(dir, 0777) == 0);
    CHECK(file_write_all(scratch_path(3, "dir.exr/x"), "x", 1));
    int entries = scratch_dir_entries();
    CHECK_RESULT(write_exr(dir), CV_ERROR_IO);
    CHECK(strstr(cv_last_error(), "cannot replace") != NULL);
    CHECK(strstr(cv_last_error(), "Success") == NULL);
    CHECK_RESULT(cv_png_write(dir, W, H, 3, rgb), CV_ERROR_IO);
    CHECK(strstr(cv_last_error(), "cannot replace") != NULL);
    CHECK(strstr(cv_last_error(), "Success") == NULL);
    CHECK_EQ_INT(scratch_dir_entries(), entries);
    unlink(scratch_path(3, "dir.exr/x"));
    CHECK(rmdir(dir) == 0);
}

int main(void) {
    scratch_dir_create("files");
    for (uint32_t i = 0; i < W * H; i++) {
        plane[i] = (float)(i * 7919 % 1013);
        /* Noise, so that the PNG does not compress below the size limit. */
        for (int c = 0; c < 3; c++)
            rgb[3 * i + c] = (uint8_t)((i * 3 + c) * 2654435761u >> 24);
    }
    test_pair_committed();
    test_png_fails_after_exr();
    test_destination_checked_when_added();
    test_failed_rename();
    test_writer_rename_fails();
    cv_file_set_destroy(NULL);
    scratch_dir_remove();
    return check_report("test_image_files");
}
