/* PNG through libpng's full API with memory callbacks: RGBA8 rows written as 8-bit RGB
 * (libpng strips the filler byte) at a fast zlib level, and any PNG read back as RGBA8
 * with alpha 255. libpng reports failures by longjmp to the setjmp of the function that
 * drives it; each such function keeps its changing state in a struct of its caller's, so
 * nothing it needs after the jump lives in its own registers. */
#include <png.h>
#include <setjmp.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>

#include "codec_ops.h"
#include "corvid/frame_codec.h"
#include "corvid/log.h"

/* zlib level 1 with libpng's choice of filter per row: on a 1080p rendered-looking frame with
 * grain, 0.37 of the RGB bytes in 140 ms, where level 6 gives 0.33 in 1050 ms (docs/media.md). */
#define PNG_ZLIB_LEVEL 1

typedef struct png_job {
    char message[160]; /* libpng's reason, for the error */
    uint8_t *data;     /* encode: the output; decode: the pixels */
    size_t size, capacity;
    const uint8_t *input; /* decode: the PNG bytes */
    size_t input_size, input_pos;
    png_bytep *rows; /* decode: into data */
} png_job;

static void on_png_error(png_structp png, png_const_charp message) {
    png_job *job = png_get_error_ptr(png);
    snprintf(job->message, sizeof job->message, "%s", message);
    png_longjmp(png, 1);
}

static void on_png_warning(png_structp png, png_const_charp message) {
    (void)png;
    cv_log(CV_LOG_DEBUG, "png", "%s", message);
}

static void on_png_write(png_structp png, png_bytep bytes, png_size_t n) {
    png_job *job = png_get_io_ptr(png);
    if (n > job->capacity - job->size) {
        size_t capacity = job->capacity * 2 > job->size + n ? job->capacity * 2 : job->size + n;
        uint8_t *grown = realloc(job->data, capacity);
        if (!grown)
            png_error(png, "no memory for the output");
        job->data = grown;
        job->capacity = capacity;
    }
    memcpy(job->data + job->size, bytes, n);
    job->size += n;
}

static void on_png_flush(png_structp png) { (void)png; }

typedef struct png_encoder {
    uint32_t width, height;
} png_encoder;

static cv_result png_encoder_create(uint32_t width, uint32_t height, void **state) {
    png_encoder *e = malloc(sizeof *e);
    if (!e)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "png encoder: no memory");
    *e = (png_encoder){ width, height };
    *state = e;
    return CV_OK;
}

static bool write_png(const png_encoder *e, const uint8_t *pixels, size_t stride, png_job *job) {
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, job, on_png_error, on_png_warning);
    png_infop info = png ? png_create_info_struct(png) : NULL;
    if (!info) {
        png_destroy_write_struct(&png, NULL);
        snprintf(job->message, sizeof job->message, "no memory for libpng");
        return false;
    }
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_write_struct(&png, &info);
        return false;
    }
    png_set_write_fn(png, job, on_png_write, on_png_flush);
    png_set_compression_level(png, PNG_ZLIB_LEVEL);
    png_set_filter(png, PNG_FILTER_TYPE_BASE, PNG_ALL_FILTERS);
    png_set_IHDR(png, info, e->width, e->height, 8, PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE,
                 PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_write_info(png, info);
    png_set_filler(png, 0, PNG_FILLER_AFTER); /* rows are RGBA: drop the 4th byte */
    /* libpng copies each row before transforming it: the caller's pixels are only read. */
    for (uint32_t y = 0; y < e->height; y++)
        png_write_row(png, (png_const_bytep)(pixels + (size_t)y * stride));
    png_write_end(png, info);
    png_destroy_write_struct(&png, &info);
    return true;
}

static cv_result png_encode(void *state, const uint8_t *pixels, size_t stride, const cv_encode_params *params,
                            cv_encoded *out) {
    (void)params;
    const png_encoder *e = state;
    png_job job = { .capacity = (size_t)e->width * e->height + 1024 };
    job.data = malloc(job.capacity);
    if (!job.data)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "png encoder: no memory for %zu bytes", job.capacity);
    if (!write_png(e, pixels, stride, &job)) {
        free(job.data);
        return cv_error(CV_ERROR_BACKEND, "png encoder %ux%u: %s", e->width, e->height, job.message);
    }
    out->data = job.data;
    out->size = job.size;
    out->keyframe = true;
    return CV_OK;
}

static void png_encoder_destroy(void *state) { free(state); }

static void on_png_read(png_structp png, png_bytep bytes, png_size_t n) {
    png_job *job = png_get_io_ptr(png);
    if (n > job->input_size - job->input_pos)
        png_error(png, "the data ends early");
    memcpy(bytes, job->input + job->input_pos, n);
    job->input_pos += n;
}

/* Any PNG to RGBA8: palettes and grey expanded, 16-bit cut to 8, alpha replaced by 255. */
static void set_rgba8(png_structp png, png_infop info) {
    png_set_expand(png);
    png_set_strip_16(png);
    png_set_gray_to_rgb(png);
    png_set_strip_alpha(png);
    png_set_filler(png, 0xff, PNG_FILLER_AFTER);
    png_set_interlace_handling(png);
    png_read_update_info(png, info);
}

static bool read_png(png_job *job, uint32_t *width, uint32_t *height) {
    png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, job, on_png_error, on_png_warning);
    png_infop info = png ? png_create_info_struct(png) : NULL;
    if (!info) {
        png_destroy_read_struct(&png, NULL, NULL);
        snprintf(job->message, sizeof job->message, "no memory for libpng");
        return false;
    }
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_read_struct(&png, &info, NULL);
        return false;
    }
    png_set_read_fn(png, job, on_png_read);
    png_set_user_limits(png, CV_CODEC_MAX_SIDE, CV_CODEC_MAX_SIDE);
    png_read_info(png, info);
    set_rgba8(png, info);
    *width = png_get_image_width(png, info);
    *height = png_get_image_height(png, info);
    if (png_get_rowbytes(png, info) != (size_t)*width * 4u)
        png_error(png, "unexpected row size after the conversion to RGBA8");
    job->size = (size_t)*width * *height * 4u;
    job->data = malloc(job->size);
    if (!job->data)
        png_error(png, "no memory for the pixels");
    job->rows = malloc(sizeof(png_bytep) * *height);
    if (!job->rows)
        png_error(png, "no memory for the rows");
    for (uint32_t y = 0; y < *height; y++)
        job->rows[y] = job->data + (size_t)y * *width * 4u;
    png_read_image(png, job->rows);
    png_read_end(png, NULL);
    png_destroy_read_struct(&png, &info, NULL);
    return true;
}

static cv_result png_decoder_create(void **state) {
    *state = NULL; /* a libpng reader lasts one image */
    return CV_OK;
}

static cv_result png_decode(void *state, const uint8_t *data, size_t size, uint8_t **out, size_t *out_size,
                            uint32_t *width, uint32_t *height) {
    (void)state;
    png_job job = { .input = data, .input_size = size };
    uint32_t w = 0, h = 0;
    bool read = read_png(&job, &w, &h);
    free(job.rows);
    if (!read) {
        free(job.data);
        return cv_error(CV_ERROR_MALFORMED, "png decoder: %s", job.message);
    }
    *out = job.data;
    *out_size = job.size;
    *width = w;
    *height = h;
    return CV_OK;
}

static void png_decoder_destroy(void *state) { (void)state; }

const codec_ops cv_png_codec_ops = {
    .encoder_create = png_encoder_create,
    .encode = png_encode,
    .encoder_destroy = png_encoder_destroy,
    .decoder_create = png_decoder_create,
    .decode = png_decode,
    .decoder_destroy = png_decoder_destroy,
};
