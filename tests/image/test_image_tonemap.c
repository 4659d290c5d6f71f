/* Tone mapping: known bytes for both curves, exposure in stops, monotonic
 * curves and bytes, sRGB encoding inverting the standard decoding for every
 * byte, alpha handling, odd input, and rejected arguments. */
#include <math.h>
#include <string.h>

#include "check.h"
#include "corvid/tonemap.h"

/* The standard sRGB decoding, written independently of the encoder. */
static double srgb_decode(double v) { return v <= 0.04045 ? v / 12.92 : pow((v + 0.055) / 1.055, 2.4); }

static uint8_t map1(cv_tonemap_curve curve, float exposure, float x) {
    float rgb[3] = { x, x, x };
    uint8_t out[3] = { 0 };
    CHECK_OK(cv_tonemap_to_srgb8(&(cv_tonemap_desc){ .exposure = exposure, .curve = curve }, rgb, 3, 1, 1, out, 3));
    CHECK(out[0] == out[1] && out[1] == out[2]);
    return out[0];
}

static void test_known_values(void) {
    /* Expected bytes: round(255 * srgb(f(x))), worked out by hand from the
     * formulas in corvid/tonemap.h. */
    static const struct {
        float x;
        uint8_t aces, reinhard;
    } table[] = {
        { 0.0f, 0, 0 },     { 0.001f, 1, 3 },   { 0.18f, 141, 109 }, { 0.5f, 206, 156 },   { 1.0f, 232, 188 },
        { 2.0f, 245, 213 }, { 4.0f, 252, 231 }, { 8.0f, 255, 242 },  { 100.0f, 255, 254 },
    };
    for (size_t i = 0; i < sizeof table / sizeof table[0]; i++) {
        CHECK_EQ_INT(map1(CV_TONEMAP_ACES, 0.0f, table[i].x), table[i].aces);
        CHECK_EQ_INT(map1(CV_TONEMAP_REINHARD, 0.0f, table[i].x), table[i].reinhard);
    }
    CHECK(fabsf(cv_tonemap_curve_eval(CV_TONEMAP_ACES, 1.0f) - 2.54f / 3.16f) < 1e-6f);
    CHECK(cv_tonemap_curve_eval(CV_TONEMAP_REINHARD, 1.0f) == 0.5f);
    CHECK(cv_tonemap_curve_eval(CV_TONEMAP_ACES, 7.3f) == 1.0f);
    CHECK(cv_tonemap_curve_eval(CV_TONEMAP_ACES, 7.2f) < 1.0f);

    /* Exposure is in stops: +1 doubles, -2 quarters. */
    CHECK_EQ_INT(map1(CV_TONEMAP_ACES, 1.0f, 0.5f), 232);
    CHECK_EQ_INT(map1(CV_TONEMAP_ACES, -2.0f, 4.0f), 232);
    CHECK_EQ_INT(map1(CV_TONEMAP_REINHARD, 3.0f, 0.125f), 188);

    /* Outside the usual range. */
    CHECK_EQ_INT(map1(CV_TONEMAP_ACES, 0.0f, -1.0f), 0);
    CHECK_EQ_INT(map1(CV_TONEMAP_ACES, 0.0f, NAN), 0);
    CHECK_EQ_INT(map1(CV_TONEMAP_ACES, 0.0f, INFINITY), 255);
    CHECK_EQ_INT(map1(CV_TONEMAP_REINHARD, 0.0f, INFINITY), 255);
    CHECK_EQ_INT(map1(CV_TONEMAP_REINHARD, 0.0f, -INFINITY), 0);
    CHECK_EQ_INT(map1(CV_TONEMAP_ACES, 100.0f, 1e30f), 255); /* overflows to infinity */
}

static void test_monotonic(void) {
    static const cv_tonemap_curve curves[] = { CV_TONEMAP_ACES, CV_TONEMAP_REINHARD };
    for (int k = 0; k < 2; k++) {
        float previous_value = 0.0f;
        uint8_t previous_byte = 0;
        uint32_t decreases = 0, flat_below_one = 0;
        /* 1e-6 to 1e6, 200000 steps on a log scale. */
        for (int i = 0; i <= 200000; i++) {
            float x = powf(10.0f, -6.0f + 12.0f * (float)i / 200000.0f);
            float v = cv_tonemap_curve_eval(curves[k], x);
            uint8_t b = cv_srgb_encode8(v);
            decreases += v < previous_value || b < previous_byte;
            flat_below_one += i > 0 && v == previous_value && v < 0.99f;
            previous_value = v;
            previous_byte = b;
        }
        CHECK_EQ_INT(decreases, 0);
        CHECK_EQ_INT(flat_below_one, 0);  /* strictly increasing until it saturates */
        CHECK_EQ_INT(previous_byte, 255); /* both saturate well before 1e6 */
    }
}

static void test_srgb(void) {
    /* Encoding inverts the standard decoding for every byte value. */
    uint32_t mismatches = 0;
    for (int b = 0; b < 256; b++)
        mismatches += cv_srgb_encode8((float)srgb_decode(b / 255.0)) != b;
    CHECK_EQ_INT(mismatches, 0);
    CHECK(cv_srgb_encode(0.0f) == 0.0f && cv_srgb_encode(1.0f) == 1.0f);
    CHECK(fabsf(cv_srgb_encode(0.5f) - 0.735357f) < 1e-5f);
    CHECK(fabsf(cv_srgb_encode(0.001f) - 0.01292f) < 1e-6f); /* the linear toe */
    CHECK(cv_srgb_encode(-1.0f) == 0.0f && cv_srgb_encode(2.0f) == 1.0f && cv_srgb_encode(NAN) == 0.0f);
}

static void test_alpha_and_layouts(void) {
    const float rgba[] = { 1, 1, 1, 0.25f, 0, 0, 0, 2.0f, 1, 0, 0, -1.0f };
    uint8_t out4[12], out3[9];
    cv_tonemap_desc desc = { .curve = CV_TONEMAP_REINHARD };
    CHECK_OK(cv_tonemap_to_srgb8(&desc, rgba, 4, 3, 1, out4, 4));
    const uint8_t expected4[] = { 188, 188, 188, 64, 0, 0, 0, 255, 188, 0, 0, 0 };
    CHECK(memcmp(out4, expected4, sizeof out4) == 0);
    CHECK_OK(cv_tonemap_to_srgb8(&desc, rgba, 4, 3, 1, out3, 3));
    const uint8_t expected3[] = { 188, 188, 188, 0, 0, 0, 188, 0, 0 };
    CHECK(memcmp(out3, expected3, sizeof out3) == 0);
    const float rgb[] = { 0.18f, 1.0f, 4.0f };
    CHECK_OK(cv_tonemap_to_srgb8(&(cv_tonemap_desc){ 0 }, rgb, 3, 1, 1, out4, 4));
    CHECK(out4[0] == 141 && out4[1] == 232 && out4[2] == 252 && out4[3] == 255);
}

static void test_rejected(void) {
    const float rgb[6] = { 0 };
    uint8_t out[8];
    memset(out, 0x33, sizeof out);
    cv_tonemap_desc ok = { 0 };
    CHECK_RESULT(cv_tonemap_to_srgb8(NULL, rgb, 3, 2, 1, out, 3), CV_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(cv_tonemap_to_srgb8(&ok, NULL, 3, 2, 1, out, 3), CV_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(cv_tonemap_to_srgb8(&ok, rgb, 3, 2, 1, NULL, 3), CV_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(cv_tonemap_to_srgb8(&(cv_tonemap_desc){ .exposure = NAN }, rgb, 3, 2, 1, out, 3),
                 CV_ERROR_INVALID_ARGUMENT);
    CHECK(strstr(cv_last_error(), "exposure") != NULL);
    CHECK_RESULT(cv_tonemap_to_srgb8(&(cv_tonemap_desc){ .exposure = INFINITY }, rgb, 3, 2, 1, out, 3),
                 CV_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(cv_tonemap_to_srgb8(&(cv_tonemap_desc){ .curve = (cv_tonemap_curve)7 }, rgb, 3, 2, 1, out, 3),
                 CV_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(cv_tonemap_to_srgb8(&ok, rgb, 2, 2, 1, out, 3), CV_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(cv_tonemap_to_srgb8(&ok, rgb, 3, 2, 1, out, 5), CV_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(cv_tonemap_to_srgb8(&ok, rgb, 3, 0, 1, out, 3), CV_ERROR_INVALID_ARGUMENT);
    uint8_t untouched[8];
    memset(untouched, 0x33, sizeof untouched);
    CHECK(memcmp(out, untouched, sizeof out) == 0);
}

int main(void) {
    test_known_values();
    test_monotonic();
    test_srgb();
    test_alpha_and_layouts();
    test_rejected();
    return check_report("test_image_tonemap");
}
