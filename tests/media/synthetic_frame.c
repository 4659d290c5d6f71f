/* The synthetic frames and difference statistics of synthetic_frame.h. */
#include "synthetic_frame.h"

#include <math.h>
#include <stdbool.h>

/* A small integer hash: the same grain at the same pixel and time on every machine. */
static uint32_t grain(uint32_t x, uint32_t y, uint32_t t) {
    uint32_t h = x * 0x8da6b343u ^ y * 0xd8163841u ^ t * 0xcb1ab31fu;
    h ^= h >> 13;
    h *= 0x5bd1e995u;
    return h ^ (h >> 15);
}

/* Linear radiance of one pixel, before the grain. */
static void shade(uint32_t x, uint32_t y, uint32_t w, uint32_t h, uint32_t t, float rgb[3]) {
    float u = (float)x / (float)w, v = (float)y / (float)h;
    /* sky to ground, and a soft highlight */
    float sky = 1.0f - v;
    float spot = expf(-((u - 0.7f) * (u - 0.7f) + (v - 0.3f) * (v - 0.3f)) * 12.0f) * 3.0f;
    rgb[0] = 0.2f + 0.5f * u + spot;
    rgb[1] = 0.3f + 0.4f * sky + spot * 0.9f;
    rgb[2] = 0.5f + 0.5f * sky * (1.0f - u) + spot * 0.6f;
    /* a box that moves with t, with a dark outline */
    uint32_t bx = (w / 8 + t * 3u) % (w > 8 ? w - w / 4 : 1), by = h / 3, bw = w / 4, bh = h / 3;
    if (x >= bx && x < bx + bw && y >= by && y < by + bh) {
        bool edge = x < bx + 2 || x + 2 >= bx + bw || y < by + 2 || y + 2 >= by + bh;
        float k = edge ? 0.02f : 0.9f;
        rgb[0] = k * 1.0f;
        rgb[1] = k * 0.4f;
        rgb[2] = k * 0.1f;
    }
    /* thin vertical lines drifting right */
    if ((x + t) % 37u == 0) {
        rgb[0] = rgb[1] = rgb[2] = 0.05f;
    }
}

static uint8_t to_srgb8(float linear) {
    float c = linear / (1.0f + linear); /* Reinhard: a tone map of sorts */
    float s = c <= 0.0031308f ? 12.92f * c : 1.055f * powf(c, 1.0f / 2.4f) - 0.055f;
    return (uint8_t)lrintf(s * 255.0f);
}

void synthetic_frame(uint8_t *rgba, uint32_t width, uint32_t height, uint32_t t, uint32_t noise) {
    for (uint32_t y = 0; y < height; y++) {
        for (uint32_t x = 0; x < width; x++) {
            float rgb[3];
            shade(x, y, width, height, t, rgb);
            uint8_t *p = rgba + ((size_t)y * width + x) * 4u;
            for (int c = 0; c < 3; c++) {
                int v = to_srgb8(rgb[c]);
                if (noise)
                    v += (int)(grain(x, y, t * 3u + (uint32_t)c) % (2u * noise + 1u)) - (int)noise;
                p[c] = (uint8_t)(v < 0 ? 0 : v > 255 ? 255 : v);
            }
            p[3] = 255;
        }
    }
}

void synthetic_radiance(float *rgba, uint32_t width, uint32_t height, uint32_t t) {
    for (uint32_t y = 0; y < height; y++) {
        for (uint32_t x = 0; x < width; x++) {
            float *p = rgba + ((size_t)y * width + x) * 4u;
            shade(x, y, width, height, t, p);
            for (int c = 0; c < 3; c++) /* Monte Carlo grain: a few percent */
                p[c] *= 0.97f + 0.06f * (float)(grain(x, y, t * 3u + (uint32_t)c) & 0xffffu) / 65535.0f;
            p[3] = 1.0f;
        }
    }
}

frame_diff frame_compare(const uint8_t *a, const uint8_t *b, uint32_t width, uint32_t height) {
    double sum_sq[3] = { 0, 0, 0 }, sum_abs = 0;
    uint32_t max_abs = 0;
    size_t pixels = (size_t)width * height;
    for (size_t i = 0; i < pixels; i++) {
        for (int c = 0; c < 3; c++) {
            int d = (int)a[4 * i + (size_t)c] - (int)b[4 * i + (size_t)c];
            uint32_t ad = (uint32_t)(d < 0 ? -d : d);
            sum_sq[c] += (double)d * d;
            sum_abs += ad;
            if (ad > max_abs)
                max_abs = ad;
        }
    }
    double min_psnr = INFINITY;
    for (int c = 0; c < 3; c++) {
        double mse = sum_sq[c] / (double)pixels;
        double psnr = mse == 0 ? INFINITY : 10.0 * log10(255.0 * 255.0 / mse);
        if (psnr < min_psnr)
            min_psnr = psnr;
    }
    return (frame_diff){ .mean_abs = sum_abs / (double)(pixels * 3u), .min_psnr_db = min_psnr, .max_abs = max_abs };
}
