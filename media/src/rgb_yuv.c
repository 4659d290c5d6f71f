/* The colour conversions of rgb_yuv.h. RGBA -> I420, on the encoder's path every frame, is
 * written for the compiler to vectorise (media's CMakeLists builds this file at -O3): two
 * rows at a time in 16-bit lanes, with offsets chosen so no sum leaves 0..65535. I420 ->
 * RGBA (decoders for tests and tools) is scalar, branch-free through a clamping table.
 * docs/media.md has their cost at 1080p. */
#include "rgb_yuv.h"

#include <string.h>

/* 16 + (66 R + 129 G + 25 B + 128) / 256: at most 56228 + 128 before the shift. */
static inline uint8_t luma(uint16_t r, uint16_t g, uint16_t b) {
    return (uint8_t)(((uint16_t)(66 * r + 129 * g + 25 * b + 128) >> 8) + 16);
}

/* Two rows of luma; the mean colour of each 2x2 block makes one chroma sample. With 32896
 * (128.5 x 256) added first, Cb = 128 + (-38 R - 74 G + 112 B) / 256 stays in 4336..61456. */
static void convert_row_pair(const uint8_t *restrict top, const uint8_t *restrict bottom, uint32_t width,
                             uint8_t *restrict y0, uint8_t *restrict y1, uint8_t *restrict u, uint8_t *restrict v) {
    /* size_t indices: a 32-bit one could wrap, and the compiler would not see a fixed stride */
    for (size_t x = 0; x < width; x++) {
        const uint8_t *a = top + 4 * x, *c = bottom + 4 * x;
        y0[x] = luma(a[0], a[1], a[2]);
        y1[x] = luma(c[0], c[1], c[2]);
    }
    for (size_t x = 0; x < width / 2; x++) {
        const uint8_t *a = top + 8 * x, *c = bottom + 8 * x;
        uint16_t r = (uint16_t)((a[0] + a[4] + c[0] + c[4] + 2) >> 2);
        uint16_t g = (uint16_t)((a[1] + a[5] + c[1] + c[5] + 2) >> 2);
        uint16_t b = (uint16_t)((a[2] + a[6] + c[2] + c[6] + 2) >> 2);
        u[x] = (uint8_t)((uint16_t)(32896 + 112 * b - 38 * r - 74 * g) >> 8);
        v[x] = (uint8_t)((uint16_t)(32896 + 112 * r - 94 * g - 18 * b) >> 8);
    }
}

void rgba_to_i420(const uint8_t *rgba, size_t stride, uint32_t width, uint32_t height, const yuv_planes *out) {
    for (uint32_t y = 0; y < height; y += 2) {
        const uint8_t *top = rgba + (size_t)y * stride;
        convert_row_pair(top, top + stride, width, out->y + (size_t)y * out->y_stride,
                         out->y + (size_t)(y + 1) * out->y_stride, out->u + (size_t)(y / 2) * out->uv_stride,
                         out->v + (size_t)(y / 2) * out->uv_stride);
    }
}

/* Clamping to 0..255 by a table, indexed by the value: no branches in the pixel loop.
 * Values reach -278..534 (Y 0..255 and chroma 0..255 at their extremes). */
#define CLAMP_LOW 384
typedef struct yuv_tables {
    uint8_t clamp[1024];
} yuv_tables;

static void make_tables(yuv_tables *t) {
    for (int i = 0; i < 1024; i++) {
        int v = i - CLAMP_LOW;
        t->clamp[i] = (uint8_t)(v < 0 ? 0 : v > 255 ? 255 : v);
    }
}

static inline void expand_pixel(const uint8_t *clamp, int y, int r, int g, int b, uint8_t *out) {
    int c = 298 * (y - 16);
    out[0] = clamp[(c + r) >> 8];
    out[1] = clamp[(c + g) >> 8];
    out[2] = clamp[(c + b) >> 8];
    out[3] = 255;
}

/* One row; each chroma sample's share of R, G and B is made once for its two pixels. */
static void expand_row(const yuv_tables *t, const uint8_t *restrict yrow, const uint8_t *restrict urow,
                       const uint8_t *restrict vrow, uint32_t width, uint8_t *restrict out) {
    const uint8_t *clamp = t->clamp + CLAMP_LOW;
    for (size_t x = 0; x < width; x += 2) {
        int d = urow[x / 2] - 128, e = vrow[x / 2] - 128;
        int r = 409 * e + 128, g = -100 * d - 208 * e + 128, b = 516 * d + 128;
        expand_pixel(clamp, yrow[x], r, g, b, out + 4 * x);
        if (x + 1 < width) /* a decoded picture may have an odd width */
            expand_pixel(clamp, yrow[x + 1], r, g, b, out + 4 * x + 4);
    }
}

void i420_to_rgba(const yuv_planes_const *in, uint32_t width, uint32_t height, uint8_t *rgba, size_t stride) {
    yuv_tables t;
    make_tables(&t);
    for (uint32_t y = 0; y < height; y++)
        expand_row(&t, in->y + (size_t)y * in->y_stride, in->u + (size_t)(y / 2) * in->uv_stride,
                   in->v + (size_t)(y / 2) * in->uv_stride, width, rgba + (size_t)y * stride);
}
