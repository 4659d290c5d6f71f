/* Image comparison: exact statistics for known differences in 8-bit and float
 * images, the NaN and infinity rules, and rejected arguments. */
#include <math.h>
#include <string.h>

#include "check.h"
#include "corvid/image_compare.h"

static void test_u8(void) {
    uint8_t a[4 * 4 * 3], b[4 * 4 * 3];
    for (int i = 0; i < 48; i++)
        a[i] = b[i] = (uint8_t)(i * 5);
    cv_image_diff d;
    CHECK_OK(cv_image_compare_u8(a, b, 4, 4, 3, 0, &d));
    CHECK(d.max_abs == 0.0 && d.rmse == 0.0 && isinf(d.psnr) && d.psnr > 0);
    CHECK_EQ_INT(d.pixels_over, 0);
    CHECK_EQ_INT(d.pixel_count, 16);

    /* One value off by 10: mse = 100 / 48. */
    b[7] += 10;
    CHECK_OK(cv_image_compare_u8(a, b, 4, 4, 3, 9, &d));
    CHECK(d.max_abs == 10.0);
    CHECK(fabs(d.rmse - sqrt(100.0 / 48.0)) < 1e-12);
    CHECK(fabs(d.psnr - 10.0 * log10(255.0 * 255.0 * 48.0 / 100.0)) < 1e-9);
    CHECK_EQ_INT(d.pixels_over, 1);
    CHECK_OK(cv_image_compare_u8(a, b, 4, 4, 3, 10, &d));
    CHECK_EQ_INT(d.pixels_over, 0);

    /* Two values of the same pixel count as one pixel; another pixel, lower
     * (differences are absolute), counts as a second. */
    b[8] = (uint8_t)(a[8] + 20);
    b[30] = (uint8_t)(a[30] - 30);
    CHECK_OK(cv_image_compare_u8(a, b, 4, 4, 3, 9, &d));
    CHECK(d.max_abs == 30.0);
    CHECK(fabs(d.rmse - sqrt((100.0 + 400.0 + 900.0) / 48.0)) < 1e-12);
    CHECK_EQ_INT(d.pixels_over, 2);
    /* Any channel count: the same bytes seen as 48 one-channel pixels. */
    CHECK_OK(cv_image_compare_u8(a, b, 48, 1, 1, 9, &d));
    CHECK_EQ_INT(d.pixels_over, 3);
    CHECK_EQ_INT(d.pixel_count, 48);
}

static void test_f32(void) {
    const float a[] = { 0.0f, 0.5f, 1.0f };
    const float b[] = { 0.0f, 0.25f, 1.0f };
    cv_image_diff d;
    CHECK_OK(cv_image_compare_f32(a, b, 3, 1, 1, 0.1, 1.0, &d));
    CHECK(d.max_abs == 0.25);
    CHECK(fabs(d.rmse - sqrt(0.0625 / 3.0)) < 1e-12);
    CHECK(fabs(d.psnr - 10.0 * log10(48.0)) < 1e-9);
    CHECK_EQ_INT(d.pixels_over, 1);
    CHECK_OK(cv_image_compare_f32(a, b, 1, 1, 3, 0.1, 2.0, &d));
    CHECK(fabs(d.psnr - 10.0 * log10(4.0 * 48.0)) < 1e-9);
    CHECK_EQ_INT(d.pixels_over, 1);
    CHECK_EQ_INT(d.pixel_count, 1);

    /* Equal specials differ by 0, unequal ones by infinity. */
    const float s1[] = { NAN, INFINITY, -0.0f, 1.0f };
    const float s2[] = { NAN, INFINITY, 0.0f, 1.0f };
    CHECK_OK(cv_image_compare_f32(s1, s2, 4, 1, 1, 0.0, 1.0, &d));
    CHECK(d.max_abs == 0.0 && isinf(d.psnr) && d.pixels_over == 0);
    const float s3[] = { 1.0f, -INFINITY, NAN, 1.0f };
    CHECK_OK(cv_image_compare_f32(s1, s3, 4, 1, 1, 1e30, 1.0, &d));
    CHECK(isinf(d.max_abs) && isinf(d.rmse));
    CHECK(isinf(d.psnr) && d.psnr < 0);
    CHECK_EQ_INT(d.pixels_over, 3);
}

static void test_rejected(void) {
    const uint8_t a[4] = { 0 };
    const float f[4] = { 0 };
    cv_image_diff d;
    memset(&d, 0x44, sizeof d);
    cv_image_diff before = d;
    CHECK_RESULT(cv_image_compare_u8(NULL, a, 1, 1, 4, 0, &d), CV_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(cv_image_compare_u8(a, a, 1, 1, 4, 0, NULL), CV_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(cv_image_compare_u8(a, a, 0, 1, 4, 0, &d), CV_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(cv_image_compare_u8(a, a, 1, 1, 0, 0, &d), CV_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(cv_image_compare_f32(f, f, 1, 1, 4, -1.0, 1.0, &d), CV_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(cv_image_compare_f32(f, f, 1, 1, 4, NAN, 1.0, &d), CV_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(cv_image_compare_f32(f, f, 1, 1, 4, 0.0, 0.0, &d), CV_ERROR_INVALID_ARGUMENT);
    CHECK(strstr(cv_last_error(), "peak") != NULL);
    CHECK_RESULT(cv_image_compare_f32(f, f, 1, 1, 4, 0.0, INFINITY, &d), CV_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(cv_image_compare_f32(f, NULL, 1, 1, 4, 0.0, 1.0, &d), CV_ERROR_INVALID_ARGUMENT);
    CHECK(memcmp(&d, &before, sizeof d) == 0);
}

int main(void) {
    test_u8();
    test_f32();
    test_rejected();
    return check_report("test_image_compare");
}
