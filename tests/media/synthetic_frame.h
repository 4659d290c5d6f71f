/* A rendered-looking RGBA8 test frame for the codec tests and bench_frame_codec: smooth
 * gradients (sky, shading), hard edges (a box with a dark outline, thin lines) and a little
 * deterministic noise (path-tracing grain). `t` moves the box and the lines, so successive
 * values make a moving sequence; the same arguments always give the same bytes. Also the
 * difference statistics the tests state their tolerances in. */
#ifndef CORVID_TEST_SYNTHETIC_FRAME_H
#define CORVID_TEST_SYNTHETIC_FRAME_H

#include <stddef.h>
#include <stdint.h>

/* rgba: width * height * 4 bytes, rows tightly packed; alpha 255. noise: amplitude in LSB. */
void synthetic_frame(uint8_t *rgba, uint32_t width, uint32_t height, uint32_t t, uint32_t noise);

/* The same picture as linear RGBA32F radiance (values up to about 4, as an HDR render). */
void synthetic_radiance(float *rgba, uint32_t width, uint32_t height, uint32_t t);

typedef struct frame_diff {
    double mean_abs;    /* over R, G and B of every pixel, in LSB */
    double min_psnr_db; /* the lowest of the three channels' PSNR */
    uint32_t max_abs;   /* in LSB */
} frame_diff;

/* a, b: RGBA8, rows tightly packed; alpha not compared. */
frame_diff frame_compare(const uint8_t *a, const uint8_t *b, uint32_t width, uint32_t height);

#endif
