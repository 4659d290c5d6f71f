/* See image_decode.h. libpng and libjpeg report errors by longjmp from their
 * error callbacks: everything allocated is reachable from the decoder's
 * context struct (never from locals changed after setjmp), and freed on both
 * paths. */
#include "image_decode.h"

#include <stdio.h> /* before jpeglib.h, which uses FILE */

#include <jpeglib.h>

#include <jerror.h>
#include <png.h>
#include <setjmp.h>
#include <stdlib.h>
#include <string.h>

#include "corvid/scene.h"

/* libjpeg's own tables and buffers besides the coefficients of a
 * progressive image: a few MB at the largest side. */
#define JPEG_TABLE_BYTES (64ull * 1024 * 1024)

static const uint8_t png_magic[8] = { 0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n' };

/* The sides, and the bytes the image would take in the scene with its mip
 * chain against what is left of the scene's budget: both known from the
 * header, before any texel memory exists. */
static cv_result check_sides(const char *what, const char *kind, uint32_t w, uint32_t h, uint64_t budget) {
    if (w == 0 || h == 0)
        return cv_error(CV_ERROR_MALFORMED, "%s: %s header says %ux%u texels", what, kind, w, h);
    if (w > CV_IMAGE_MAX_SIDE || h > CV_IMAGE_MAX_SIDE)
        return cv_error(CV_ERROR_LIMIT_EXCEEDED, "%s: %s is %ux%u texels, a side over the limit of %u", what, kind, w,
                        h, CV_IMAGE_MAX_SIDE);
    uint64_t bytes = cv_image_stored_bytes(w, h);
    if (bytes > budget)
        return cv_error(CV_ERROR_LIMIT_EXCEEDED,
                        "%s: %s is %ux%u texels, %llu bytes with its mip chain: over the %llu bytes left of the "
                        "scene's image budget (refused before decoding)",
                        what, kind, w, h, (unsigned long long)bytes, (unsigned long long)budget);
    return CV_OK;
}

/* ---- PNG ---- */

typedef struct png_ctx {
    jmp_buf jump;
    char message[200];
    const uint8_t *data;
    size_t size, offset;
    uint8_t *rgba;
    png_bytep *rows;
} png_ctx;

static void png_fail(png_structp png, png_const_charp msg) {
    png_ctx *c = png_get_error_ptr(png);
    snprintf(c->message, sizeof c->message, "%s", msg);
    longjmp(c->jump, 1);
}

static void png_warn(png_structp png, png_const_charp msg) {
    (void)png;
    (void)msg;
}

static void png_read_mem(png_structp png, png_bytep out, png_size_t n) {
    png_ctx *c = png_get_io_ptr(png);
    if (n > c->size - c->offset)
        png_error(png, "data ends early (truncated)");
    memcpy(out, c->data + c->offset, n);
    c->offset += n;
}

static cv_result decode_png(const uint8_t *data, size_t size, uint64_t budget, const char *what, uint8_t **out,
                            uint32_t *ow, uint32_t *oh) {
    /* The sides first, from IHDR (always the first chunk), before libpng
     * reads on: a header alone is enough to refuse a huge image. */
    if (size >= 24 && memcmp(data + 12, "IHDR", 4) == 0) {
        uint32_t w = (uint32_t)data[16] << 24 | (uint32_t)data[17] << 16 | (uint32_t)data[18] << 8 | data[19];
        uint32_t h = (uint32_t)data[20] << 24 | (uint32_t)data[21] << 16 | (uint32_t)data[22] << 8 | data[23];
        cv_result r = check_sides(what, "PNG", w, h, budget);
        if (r != CV_OK)
            return r;
    }
    png_ctx *c = calloc(1, sizeof *c);
    if (!c)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "%s: no memory to decode PNG", what);
    c->data = data;
    c->size = size;
    png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, c, png_fail, png_warn);
    png_infop info = png ? png_create_info_struct(png) : NULL;
    if (!info) {
        png_destroy_read_struct(png ? &png : NULL, NULL, NULL);
        free(c);
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "%s: no memory to decode PNG", what);
    }
    cv_result r = CV_OK;
    if (setjmp(c->jump)) {
        r = cv_error(CV_ERROR_MALFORMED, "%s: corrupt PNG: %s", what, c->message);
        goto done;
    }
    png_set_read_fn(png, c, png_read_mem);
    png_read_info(png, info);
    png_uint_32 w, h;
    int depth, color, interlace;
    png_get_IHDR(png, info, &w, &h, &depth, &color, &interlace, NULL, NULL);
    if ((r = check_sides(what, "PNG", w, h, budget)) != CV_OK)
        goto done;
    /* To RGBA8, bytes as stored: no gamma handling is requested. */
    png_set_expand(png); /* palette -> RGB, gray < 8 bits -> 8, tRNS -> alpha */
    if (depth == 16)
        png_set_scale_16(png); /* (v * 255 + 32895) >> 16: rounds */
    if (color == PNG_COLOR_TYPE_GRAY || color == PNG_COLOR_TYPE_GRAY_ALPHA)
        png_set_gray_to_rgb(png);
    png_set_add_alpha(png, 0xff, PNG_FILLER_AFTER); /* no-op where alpha exists */
    png_set_interlace_handling(png);
    png_read_update_info(png, info);
    if (png_get_rowbytes(png, info) != (size_t)w * 4)
        png_error(png, "unexpected row layout after conversion to RGBA8");
    c->rgba = malloc((size_t)w * h * 4);
    c->rows = malloc((size_t)h * sizeof(png_bytep));
    if (!c->rgba || !c->rows) {
        r = cv_error(CV_ERROR_OUT_OF_MEMORY, "%s: no memory for a %ux%u PNG", what, (unsigned)w, (unsigned)h);
        goto done;
    }
    for (png_uint_32 y = 0; y < h; y++)
        c->rows[y] = c->rgba + (size_t)y * w * 4;
    png_read_image(png, c->rows);
    png_read_end(png, NULL);
    *out = c->rgba;
    c->rgba = NULL;
    *ow = w;
    *oh = h;
done:
    png_destroy_read_struct(&png, &info, NULL);
    free(c->rgba);
    free(c->rows);
    free(c);
    return r;
}

/* ---- JPEG ---- */

typedef struct jpeg_ctx {
    struct jpeg_error_mgr err; /* first: libjpeg hands back this pointer */
    jmp_buf jump;
    char message[JMSG_LENGTH_MAX];
    uint8_t *rgba;
} jpeg_ctx;

static void jpeg_fail(j_common_ptr cinfo) {
    jpeg_ctx *c = (jpeg_ctx *)cinfo->err;
    c->err.format_message(cinfo, c->message);
    longjmp(c->jump, 1);
}

/* Warnings (level -1: corrupt or truncated data that libjpeg would patch
 * over with grey) fail the decode; trace messages (>= 0) are ignored. */
static void jpeg_message(j_common_ptr cinfo, int level) {
    if (level < 0)
        jpeg_fail(cinfo);
}

static cv_result decode_jpeg(const uint8_t *data, size_t size, uint64_t budget, const char *what, uint8_t **out,
                             uint32_t *ow, uint32_t *oh) {
    jpeg_ctx *c = calloc(1, sizeof *c);
    struct jpeg_decompress_struct *d = calloc(1, sizeof *d);
    if (!c || !d) {
        free(c);
        free(d);
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "%s: no memory to decode JPEG", what);
    }
    d->err = jpeg_std_error(&c->err);
    c->err.error_exit = jpeg_fail;
    c->err.emit_message = jpeg_message;
    cv_result r = CV_OK;
    if (setjmp(c->jump)) {
        r = c->err.msg_code == JERR_NO_BACKING_STORE
                ? cv_error(CV_ERROR_LIMIT_EXCEEDED, "%s: JPEG needs more decoder memory than its %ux%u texels allow",
                           what, d->image_width, d->image_height)
                : cv_error(CV_ERROR_MALFORMED, "%s: corrupt JPEG: %s", what, c->message);
        goto done;
    }
    jpeg_create_decompress(d);
    jpeg_mem_src(d, data, (unsigned long)size);
    jpeg_read_header(d, TRUE);
    if ((r = check_sides(what, "JPEG", d->image_width, d->image_height, budget)) != CV_OK)
        goto done;
    /* A progressive JPEG keeps every coefficient (2 bytes per sample) until
     * its last scan: bounded by twice the image's own bytes plus room for
     * tables; past it libjpeg fails (it has no backing store), reported below. */
    d->mem->max_memory_to_use = (long)(2 * cv_image_stored_bytes(d->image_width, d->image_height) + JPEG_TABLE_BYTES);
    if (d->jpeg_color_space == JCS_CMYK || d->jpeg_color_space == JCS_YCCK) {
        r = cv_error(CV_ERROR_MALFORMED, "%s: CMYK JPEG is not supported (only gray and RGB)", what);
        goto done;
    }
    d->out_color_space = JCS_EXT_RGBA; /* libjpeg-turbo: alpha 255, gray expanded */
    jpeg_start_decompress(d);
    uint32_t w = d->output_width, h = d->output_height;
    c->rgba = malloc((size_t)w * h * 4);
    if (!c->rgba) {
        r = cv_error(CV_ERROR_OUT_OF_MEMORY, "%s: no memory for a %ux%u JPEG", what, w, h);
        goto done;
    }
    while (d->output_scanline < h) {
        JSAMPROW row = c->rgba + (size_t)d->output_scanline * w * 4;
        jpeg_read_scanlines(d, &row, 1);
    }
    jpeg_finish_decompress(d);
    *out = c->rgba;
    c->rgba = NULL;
    *ow = w;
    *oh = h;
done:
    jpeg_destroy_decompress(d);
    free(c->rgba);
    free(c);
    free(d);
    return r;
}

cv_result image_decode(const uint8_t *data, size_t size, uint64_t budget, const char *what, uint8_t **rgba,
                       uint32_t *width, uint32_t *height) {
    if (size >= 8 && memcmp(data, png_magic, 8) == 0)
        return decode_png(data, size, budget, what, rgba, width, height);
    if (size >= 3 && data[0] == 0xff && data[1] == 0xd8 && data[2] == 0xff)
        return decode_jpeg(data, size, budget, what, rgba, width, height);
    return cv_error(CV_ERROR_MALFORMED, "%s: neither PNG nor JPEG data (%zu bytes)", what, size);
}
