/* RGBA8 <-> I420 (planar 4:2:0 YCbCr) for the H.264 codec, BT.601 limited range
 * (Y 16..235, Cb/Cr 16..240): what an H.264 stream without colour description is taken to
 * be by every decoder. Fixed point, 8 fractional bits; sizes even (H.264 refuses odd ones). */
#ifndef CORVID_MEDIA_RGB_YUV_H
#define CORVID_MEDIA_RGB_YUV_H

#include <stddef.h>
#include <stdint.h>

typedef struct yuv_planes {
    uint8_t *y, *u, *v;
    size_t y_stride, uv_stride;
} yuv_planes;

typedef struct yuv_planes_const {
    const uint8_t *y, *u, *v;
    size_t y_stride, uv_stride;
} yuv_planes_const;

/* Each chroma sample is the mean of its 2x2 block's colours (alpha ignored). */
void rgba_to_i420(const uint8_t *rgba, size_t stride, uint32_t width, uint32_t height, const yuv_planes *out);
/* RGBA8 rows `stride` bytes apart, alpha 255; chroma nearest (each sample covers its 2x2 block). */
void i420_to_rgba(const yuv_planes_const *in, uint32_t width, uint32_t height, uint8_t *rgba, size_t stride);

#endif
