/* The colour conversions of rgb_yuv.h: two rows at a time, so each 2x2 block's chroma is
 * made from the pixels just read, in plain loops the compiler vectorises. */
#include "rgb_yuv.h"

static inline uint8_t luma(int r, int g, int b) { return (uint8_t)(16 + ((66 * r + 129 * g + 25 * b + 128) >> 8)); }

/* Two rows of luma and one row of chroma; r, g, b are sums over 2x2 blocks (4x the mean). */
static void convert_row_pair(const uint8_t *restrict top, const uint8_t *restrict bottom, uint32_t width,
                             uint8_t *restrict y0, uint8_t *restrict y1, uint8_t *restrict u, uint8_t *restrict v) {
    for (uint32_t x = 0; x < width; x += 2) {
        const uint8_t *a = top + 4 * x, *c = bottom + 4 * x;
        y0[x] = luma(a[0], a[1], a[2]);
        y0[x + 1] = luma(a[4], a[5], a[6]);
        y1[x] = luma(c[0], c[1], c[2]);
        y1[x + 1] = luma(c[4], c[5], c[6]);
        int r = a[0] + a[4] + c[0] + c[4];
        int g = a[1] + a[5] + c[1] + c[5];
        int b = a[2] + a[6] + c[2] + c[6];
        /* The sums carry 2 more fractional bits: shift by 10 instead of 8. */
        u[x / 2] = (uint8_t)(128 + ((-38 * r - 74 * g + 112 * b + 512) >> 10));
        v[x / 2] = (uint8_t)(128 + ((112 * r - 94 * g - 18 * b + 512) >> 10));
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

static inline uint8_t clamp8(int v) { return (uint8_t)(v < 0 ? 0 : v > 255 ? 255 : v); }

static void expand_row(const uint8_t *restrict yrow, const uint8_t *restrict urow, const uint8_t *restrict vrow,
                       uint32_t width, uint8_t *restrict out) {
    for (uint32_t x = 0; x < width; x++) {
        int c = 298 * (yrow[x] - 16) + 128;
        int d = urow[x / 2] - 128, e = vrow[x / 2] - 128;
        out[4 * x] = clamp8((c + 409 * e) >> 8);
        out[4 * x + 1] = clamp8((c - 100 * d - 208 * e) >> 8);
        out[4 * x + 2] = clamp8((c + 516 * d) >> 8);
        out[4 * x + 3] = 255;
    }
}

void i420_to_rgba(const yuv_planes_const *in, uint32_t width, uint32_t height, uint8_t *rgba, size_t stride) {
    for (uint32_t y = 0; y < height; y++)
        expand_row(in->y + (size_t)y * in->y_stride, in->u + (size_t)(y / 2) * in->uv_stride,
                   in->v + (size_t)(y / 2) * in->uv_stride, width, rgba + (size_t)y * stride);
}
