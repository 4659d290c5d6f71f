/* cv_png_write / cv_png_read: RGB and RGBA round trip byte for byte, grey and
 * palette files are expanded, failed writes leave nothing behind (and an
 * existing file untouched), garbage and truncated files are MALFORMED. */
#include <png.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "check.h"
#include "corvid/image_png.h"
#include "scratch_dir.h"

#define W 61
#define H 17

static void fill(uint8_t *pixels, uint32_t channels) {
    for (uint32_t i = 0; i < W * H * channels; i++)
        pixels[i] = (uint8_t)(i * 37 + i / 7);
}

static void test_round_trip(void) {
    for (uint32_t channels = 3; channels <= 4; channels++) {
        static uint8_t pixels[W * H * 4];
        fill(pixels, channels);
        const char *path = scratch_path(0, "rt.png");
        CHECK_OK(cv_png_write(path, W, H, channels, pixels));
        cv_png_image img;
        CHECK_OK(cv_png_read(path, &img));
        CHECK_EQ_INT(img.width, W);
        CHECK_EQ_INT(img.height, H);
        CHECK_EQ_INT(img.channels, channels);
        CHECK(img.pixels != NULL && memcmp(img.pixels, pixels, W * H * channels) == 0);
        cv_png_image_free(&img);
        CHECK(img.pixels == NULL && img.width == 0);
    }
    /* A 1x1 image, and overwriting an existing file. */
    const char *path = scratch_path(0, "rt.png");
    CHECK_OK(cv_png_write(path, 1, 1, 3, (const uint8_t[]){ 255, 0, 7 }));
    cv_png_image img;
    CHECK_OK(cv_png_read(path, &img));
    CHECK(img.width == 1 && img.height == 1 && img.channels == 3);
    CHECK(img.pixels[0] == 255 && img.pixels[1] == 0 && img.pixels[2] == 7);
    cv_png_image_free(&img);
}

/* Files this writer does not produce but references may be: 8-bit grey and
 * grey+alpha, written here with libpng directly. */
static void test_grey_expanded(void) {
    uint8_t grey[4] = { 0, 85, 170, 255 };
    png_image image = { .version = PNG_IMAGE_VERSION, .width = 2, .height = 2, .format = PNG_FORMAT_GRAY };
    const char *path = scratch_path(0, "grey.png");
    CHECK(png_image_write_to_file(&image, path, 0, grey, 0, NULL) != 0);
    cv_png_image img;
    CHECK_OK(cv_png_read(path, &img));
    CHECK_EQ_INT(img.channels, 3);
    for (int i = 0; i < 4; i++)
        CHECK(img.pixels[i * 3] == grey[i] && img.pixels[i * 3 + 1] == grey[i] && img.pixels[i * 3 + 2] == grey[i]);
    cv_png_image_free(&img);

    uint8_t grey_alpha[8] = { 10, 255, 20, 128, 30, 0, 40, 255 };
    image = (png_image){ .version = PNG_IMAGE_VERSION, .width = 2, .height = 2, .format = PNG_FORMAT_GA };
    CHECK(png_image_write_to_file(&image, path, 0, grey_alpha, 0, NULL) != 0);
    CHECK_OK(cv_png_read(path, &img));
    CHECK_EQ_INT(img.channels, 4);
    for (int i = 0; i < 4; i++) {
        CHECK(img.pixels[i * 4] == grey_alpha[i * 2] && img.pixels[i * 4 + 2] == grey_alpha[i * 2]);
        CHECK(img.pixels[i * 4 + 3] == grey_alpha[i * 2 + 1]);
    }
    cv_png_image_free(&img);
}

static void test_failed_writes(void) {
    uint8_t pixels[W * H * 4] = { 0 };
    int entries = scratch_dir_entries();
    const char *path = scratch_path(0, "no-such-dir/out.png");
    CHECK_RESULT(cv_png_write(path, W, H, 3, pixels), CV_ERROR_IO);
    CHECK(strncmp(cv_last_error(), path, strlen(path)) == 0);
    CHECK(file_write_all(scratch_path(1, "plain"), "x", 1));
    CHECK_RESULT(cv_png_write(scratch_path(0, "plain/out.png"), W, H, 3, pixels), CV_ERROR_IO);
    unlink(scratch_path(1, "plain"));
    /* The final rename fails when the path is a directory: the temporary file
     * is removed and the directory left alone. */
    CHECK(mkdir(scratch_path(1, "dir.png"), 0777) == 0);
    CHECK_RESULT(cv_png_write(scratch_path(1, "dir.png"), W, H, 3, pixels), CV_ERROR_IO);
    CHECK(rmdir(scratch_path(1, "dir.png")) == 0);

    const char *existing = scratch_path(1, "keep.png");
    CHECK(file_write_all(existing, "original", 8));
    CHECK_RESULT(cv_png_write(existing, 0, H, 3, pixels), CV_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(cv_png_write(existing, W, 100000, 3, pixels), CV_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(cv_png_write(existing, W, H, 2, pixels), CV_ERROR_INVALID_ARGUMENT);
    CHECK(strstr(cv_last_error(), "2 channels") != NULL);
    CHECK_RESULT(cv_png_write(existing, W, H, 3, NULL), CV_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(cv_png_write(NULL, W, H, 3, pixels), CV_ERROR_INVALID_ARGUMENT);
    unsigned char *bytes = NULL;
    size_t size = 0;
    CHECK(file_read_all(existing, &bytes, &size));
    CHECK(size == 8 && bytes != NULL && memcmp(bytes, "original", 8) == 0);
    free(bytes);
    unlink(existing);
    CHECK_EQ_INT(scratch_dir_entries(), entries);
}

/* A write that fails half way (the file-size limit makes write() fail with
 * EFBIG) is IO, leaves the existing file as it was and no temporary file. */
static void test_failed_write_keeps_existing(void) {
    static uint8_t noise[256 * 256 * 3];
    uint32_t state = 1;
    for (size_t i = 0; i < sizeof noise; i++) {
        state = state * 1664525u + 1013904223u;
        noise[i] = (uint8_t)(state >> 24);
    }
    const char *path = scratch_path(0, "keep.png");
    CHECK(file_write_all(path, "original", 8));
    int entries = scratch_dir_entries();
    limit_file_size(64 * 1024);
    CHECK_RESULT(cv_png_write(path, 256, 256, 3, noise), CV_ERROR_IO);
    limit_file_size(0);
    unsigned char *bytes = NULL;
    size_t size = 0;
    CHECK(file_read_all(path, &bytes, &size));
    CHECK(size == 8 && bytes != NULL && memcmp(bytes, "original", 8) == 0);
    free(bytes);
    CHECK_EQ_INT(scratch_dir_entries(), entries);
    CHECK_OK(cv_png_write(path, 256, 256, 3, noise));
    cv_png_image img;
    CHECK_OK(cv_png_read(path, &img));
    CHECK(img.channels == 3 && memcmp(img.pixels, noise, sizeof noise) == 0);
    cv_png_image_free(&img);
    CHECK_EQ_INT(scratch_dir_entries(), entries);
}

static void check_read_fails(const char *path, cv_result code) {
    cv_png_image img;
    memset(&img, 0x7B, sizeof img);
    cv_png_image before = img;
    CHECK_RESULT(cv_png_read(path, &img), code);
    CHECK(strncmp(cv_last_error(), path, strlen(path)) == 0);
    CHECK(memcmp(&img, &before, sizeof img) == 0);
}

static void test_unreadable_files(void) {
    check_read_fails(scratch_path(0, "missing.png"), CV_ERROR_IO);
    CHECK(file_write_all(scratch_path(0, "empty.png"), "", 0));
    check_read_fails(scratch_path(0, "empty.png"), CV_ERROR_MALFORMED);
    unsigned char garbage[2048];
    for (size_t i = 0; i < sizeof garbage; i++)
        garbage[i] = (unsigned char)(i * 131 + 7);
    CHECK(file_write_all(scratch_path(0, "garbage.png"), garbage, sizeof garbage));
    check_read_fails(scratch_path(0, "garbage.png"), CV_ERROR_MALFORMED);

    static uint8_t pixels[W * H * 3];
    fill(pixels, 3);
    const char *whole = scratch_path(1, "whole.png");
    CHECK_OK(cv_png_write(whole, W, H, 3, pixels));
    unsigned char *bytes = NULL;
    size_t size = 0;
    CHECK(file_read_all(whole, &bytes, &size));
    /* Cut in the signature, the header chunk, the pixel data, and before the
     * end chunk. */
    size_t cuts[] = { 4, 20, size / 2, size - 13 };
    const char *cut_path = scratch_path(0, "cut.png");
    for (size_t i = 0; bytes != NULL && i < sizeof cuts / sizeof cuts[0]; i++) {
        CHECK(file_write_all(cut_path, bytes, cuts[i]));
        check_read_fails(cut_path, CV_ERROR_MALFORMED);
    }
    /* One flipped bit in the pixel data fails its CRC. */
    if (bytes != NULL) {
        bytes[size / 2] ^= 0x10;
        CHECK(file_write_all(cut_path, bytes, size));
        check_read_fails(cut_path, CV_ERROR_MALFORMED);
    }
    free(bytes);
    /* A directory is not a file. */
    check_read_fails("/tmp", CV_ERROR_IO);
    CHECK_RESULT(cv_png_read(whole, NULL), CV_ERROR_INVALID_ARGUMENT);
    cv_png_image_free(NULL);
}

int main(void) {
    scratch_dir_create("png");
    test_round_trip();
    test_grey_expanded();
    test_failed_writes();
    test_failed_write_keeps_existing();
    test_unreadable_files();
    scratch_dir_remove();
    return check_report("test_image_png");
}
