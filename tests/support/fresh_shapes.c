/* Fresh-resource helpers (fresh_shapes.h). A recycling allocator places
 * resources of the same shapes in the same memory, so markers left by one set
 * show up in the next unless the backend zeroes new resources. */
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "fresh_shapes.h"

#define MARKER 0xA5u

static const uint64_t buffer_sizes[] = { 64, 4096, 1u << 20 };

typedef struct texture_shape {
    cv_format format;
    uint32_t width, height;
    uint32_t usage;
} texture_shape;

static const texture_shape texture_shapes[] = {
    { CV_FORMAT_RGBA8_UNORM, 64, 64, CV_TEXTURE_USAGE_SAMPLED | CV_TEXTURE_USAGE_STORAGE },
    { CV_FORMAT_RGBA32F, 64, 64, CV_TEXTURE_USAGE_STORAGE },
    { CV_FORMAT_R32F, 256, 128, CV_TEXTURE_USAGE_STORAGE },
    { CV_FORMAT_RGBA8_UNORM, 32, 32, CV_TEXTURE_USAGE_COLOR_TARGET },
};
#define BUFFER_COUNT (sizeof(buffer_sizes) / sizeof(buffer_sizes[0]))
#define TEXTURE_COUNT (sizeof(texture_shapes) / sizeof(texture_shapes[0]))

static cv_result make_buffer(cv_context *ctx, cv_device *dev, uint64_t size, cv_buffer *out) {
    cv_buffer_desc desc = { .size = size, .usage = CV_BUFFER_USAGE_STORAGE, .label = "fresh buffer" };
    cv_result r = cv_buffer_create(ctx, &desc, out);
    return r == CV_OK ? cv_device_load(dev, cv_any(*out)) : r;
}

static cv_result make_texture(cv_context *ctx, cv_device *dev, const texture_shape *s, cv_texture *out) {
    cv_texture_desc desc = {
        .width = s->width, .height = s->height, .format = s->format, .usage = s->usage, .label = "fresh texture"
    };
    cv_result r = cv_texture_create(ctx, &desc, out);
    return r == CV_OK ? cv_device_load(dev, cv_any(*out)) : r;
}

static size_t texture_bytes(const texture_shape *s) {
    return (size_t)s->width * s->height * cv_format_bytes(s->format);
}

/* Counts the bytes of data that are not zero. */
static size_t nonzero(const uint8_t *data, size_t size) {
    size_t n = 0;
    for (size_t i = 0; i < size; i++)
        n += data[i] != 0;
    return n;
}

/* Creates every shape, writes the marker into each, and destroys them. */
static void leave_markers(cv_context *ctx, cv_device *dev, uint8_t *scratch) {
    cv_buffer buffers[BUFFER_COUNT];
    cv_texture textures[TEXTURE_COUNT];
    for (size_t i = 0; i < BUFFER_COUNT; i++) {
        CHECK_OK(make_buffer(ctx, dev, buffer_sizes[i], &buffers[i]));
        memset(scratch, MARKER, buffer_sizes[i]);
        CHECK_OK(cv_device_write_buffer(dev, buffers[i], 0, buffer_sizes[i], scratch));
    }
    for (size_t i = 0; i < TEXTURE_COUNT; i++) {
        const texture_shape *s = &texture_shapes[i];
        CHECK_OK(make_texture(ctx, dev, s, &textures[i]));
        memset(scratch, MARKER, texture_bytes(s));
        CHECK_OK(cv_device_write_texture(dev, textures[i], (cv_rect){ 0, 0, s->width, s->height }, scratch));
    }
    CHECK_OK(cv_device_wait_idle(dev));
    for (size_t i = 0; i < BUFFER_COUNT; i++)
        CHECK_OK(cv_buffer_destroy(ctx, buffers[i]));
    for (size_t i = 0; i < TEXTURE_COUNT; i++)
        CHECK_OK(cv_texture_destroy(ctx, textures[i]));
}

/* Creates every shape again and checks that each reads as zeros before any write. */
static size_t expect_zeros(cv_context *ctx, cv_device *dev, const char *where, uint8_t *scratch) {
    size_t total = 0;
    for (size_t i = 0; i < BUFFER_COUNT; i++) {
        cv_buffer b;
        CHECK_OK(make_buffer(ctx, dev, buffer_sizes[i], &b));
        memset(scratch, 0xFF, buffer_sizes[i]);
        CHECK_OK(cv_device_read_buffer(dev, b, 0, buffer_sizes[i], scratch));
        size_t dirty = nonzero(scratch, buffer_sizes[i]);
        if (dirty)
            fprintf(stderr, "%s: a fresh %llu-byte buffer holds %zu nonzero bytes\n", where,
                    (unsigned long long)buffer_sizes[i], dirty);
        CHECK_EQ_INT(dirty, 0);
        CHECK_OK(cv_buffer_destroy(ctx, b));
        total += dirty;
    }
    for (size_t i = 0; i < TEXTURE_COUNT; i++) {
        const texture_shape *s = &texture_shapes[i];
        cv_texture t;
        CHECK_OK(make_texture(ctx, dev, s, &t));
        memset(scratch, 0xFF, texture_bytes(s));
        CHECK_OK(cv_device_read_texture(dev, t, (cv_rect){ 0, 0, s->width, s->height }, scratch));
        size_t dirty = nonzero(scratch, texture_bytes(s));
        if (dirty)
            fprintf(stderr, "%s: a fresh %ux%u %s texture holds %zu nonzero bytes\n", where, s->width, s->height,
                    cv_format_name(s->format), dirty);
        CHECK_EQ_INT(dirty, 0);
        CHECK_OK(cv_texture_destroy(ctx, t));
        total += dirty;
    }
    return total;
}

static uint8_t *scratch_alloc(void) {
    uint8_t *scratch = malloc(1u << 20);
    CHECK(scratch != NULL);
    return scratch;
}

void fresh_leave_markers(cv_context *ctx, cv_device *dev) {
    uint8_t *scratch = scratch_alloc();
    if (scratch)
        leave_markers(ctx, dev, scratch);
    free(scratch);
}

size_t fresh_expect_zeros(cv_context *ctx, cv_device *dev, const char *where) {
    uint8_t *scratch = scratch_alloc();
    size_t dirty = scratch ? expect_zeros(ctx, dev, where, scratch) : 0;
    free(scratch);
    return dirty;
}
