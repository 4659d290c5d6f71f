/* cv_exr_write: a multi-layer scanline EXR through OpenEXRCore's chunk
 * encoder. The description is checked in full before the file is created. */
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "corvid/image_exr.h"
#include "corvid/types.h"
#include "exr_errors.h"
#include "temp_file.h"

/* One channel of the file and where its floats come from. */
typedef struct exr_source {
    char name[CV_EXR_MAX_NAME + 1];
    cv_exr_type type;
    const float *first; /* sample of pixel (0, 0) */
    uint32_t stride;    /* floats from one pixel's sample to the next's */
} exr_source;

typedef struct exr_sources {
    uint32_t count;
    exr_source list[CV_EXR_MAX_CHANNELS];
} exr_sources;

static cv_result add_layer_sources(const char *path, uint32_t index, const cv_exr_layer *layer,
                                   exr_sources *sources) {
    const char *prefix = layer->name != NULL ? layer->name : "";
    if (layer->channel_count == 0 || layer->channel_count > CV_EXR_MAX_LAYER_CHANNELS)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "%s: layer %u '%s': channel_count %u is outside 1..%u", path,
                        index, prefix, layer->channel_count, CV_EXR_MAX_LAYER_CHANNELS);
    if (layer->type != CV_EXR_HALF && layer->type != CV_EXR_FLOAT)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "%s: layer %u '%s': type %d is neither HALF nor FLOAT", path,
                        index, prefix, (int)layer->type);
    if (sources->count + layer->channel_count > CV_EXR_MAX_CHANNELS)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "%s: layer %u '%s': more than %u channels in all", path, index,
                        prefix, CV_EXR_MAX_CHANNELS);
    for (uint32_t c = 0; c < layer->channel_count; c++) {
        const char *channel = layer->channels[c];
        if (channel == NULL || channel[0] == '\0')
            return cv_error(CV_ERROR_INVALID_ARGUMENT, "%s: layer %u '%s': channels[%u] has no name", path, index,
                            prefix, c);
        exr_source *s = &sources->list[sources->count];
        int n = snprintf(s->name, sizeof s->name, "%s%s%s", prefix, prefix[0] ? "." : "", channel);
        if (n < 0 || (size_t)n >= sizeof s->name)
            return cv_error(CV_ERROR_INVALID_ARGUMENT,
                            "%s: layer %u: channel name '%s%s%s' is longer than %d characters", path, index, prefix,
                            prefix[0] ? "." : "", channel, CV_EXR_MAX_NAME);
        for (uint32_t k = 0; k < sources->count; k++) {
            if (strcmp(sources->list[k].name, s->name) == 0)
                return cv_error(CV_ERROR_INVALID_ARGUMENT, "%s: layer %u: channel '%s' appears twice", path, index,
                                s->name);
        }
        if (layer->interleaved != NULL) {
            s->first = layer->interleaved + c;
            s->stride = layer->channel_count;
        } else {
            if (layer->planes[c] == NULL)
                return cv_error(CV_ERROR_INVALID_ARGUMENT,
                                "%s: layer %u '%s': neither interleaved nor planes[%u] is given", path, index, prefix,
                                c);
            s->first = layer->planes[c];
            s->stride = 1;
        }
        s->type = layer->type;
        sources->count++;
    }
    return CV_OK;
}

static cv_result check_desc(const char *path, const cv_exr_desc *desc, exr_sources *sources) {
    if (path == NULL || path[0] == '\0')
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "exr: no path given");
    if (desc == NULL)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "%s: desc is NULL", path);
    if (desc->width == 0 || desc->width > CV_MAX_TEXTURE_DIM || desc->height == 0 ||
        desc->height > CV_MAX_TEXTURE_DIM)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "%s: size %ux%u is outside 1..%u per side", path, desc->width,
                        desc->height, CV_MAX_TEXTURE_DIM);
    if (desc->compression != CV_EXR_ZIP && desc->compression != CV_EXR_PIZ && desc->compression != CV_EXR_NONE)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "%s: compression %d is not ZIP, PIZ or NONE", path,
                        (int)desc->compression);
    if (desc->layer_count == 0 || desc->layers == NULL)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "%s: no layers given", path);
    sources->count = 0;
    for (uint32_t i = 0; i < desc->layer_count; i++) {
        cv_result r = add_layer_sources(path, i, &desc->layers[i], sources);
        if (r != CV_OK)
            return r;
    }
    return CV_OK;
}

static exr_compression_t exr_compression_of(cv_exr_compression c) {
    switch (c) {
    case CV_EXR_ZIP: return EXR_COMPRESSION_ZIP;
    case CV_EXR_PIZ: return EXR_COMPRESSION_PIZ;
    default: return EXR_COMPRESSION_NONE;
    }
}

static const exr_source *find_source(const exr_sources *sources, const char *name) {
    for (uint32_t i = 0; i < sources->count; i++) {
        if (strcmp(sources->list[i].name, name) == 0)
            return &sources->list[i];
    }
    return NULL;
}

/* Points the encoder's channels (in the file's order) at this chunk's rows. */
static exr_result_t bind_chunk(exr_encode_pipeline_t *enc, const exr_sources *sources, uint32_t width,
                               int32_t first_row) {
    for (int16_t i = 0; i < enc->channel_count; i++) {
        exr_coding_channel_info_t *ch = &enc->channels[i];
        const exr_source *s = find_source(sources, ch->channel_name);
        if (s == NULL)
            return EXR_ERR_INCORRECT_CHUNK;
        ch->user_data_type = EXR_PIXEL_FLOAT;
        ch->user_bytes_per_element = (int16_t)sizeof(float);
        ch->user_pixel_stride = (int32_t)(s->stride * sizeof(float));
        ch->user_line_stride = (int32_t)(s->stride * sizeof(float) * width);
        ch->encode_from_ptr = (const uint8_t *)(s->first + (size_t)first_row * width * s->stride);
    }
    return EXR_ERR_SUCCESS;
}

static cv_result write_chunks(const char *path, exr_context_t ctx, int part, uint32_t width,
                              const exr_sources *sources) {
    int32_t chunk_count = 0, lines = 0;
    exr_result_t rv = exr_get_chunk_count(ctx, part, &chunk_count);
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_get_scanlines_per_chunk(ctx, part, &lines);
    if (rv != EXR_ERR_SUCCESS)
        return exr_fail(CV_ERROR_BACKEND, path, "counting chunks", rv);
    exr_encode_pipeline_t enc = EXR_ENCODE_PIPELINE_INITIALIZER;
    for (int32_t c = 0; c < chunk_count && rv == EXR_ERR_SUCCESS; c++) {
        exr_chunk_info_t chunk;
        rv = exr_write_scanline_chunk_info(ctx, part, c * lines, &chunk);
        if (rv == EXR_ERR_SUCCESS)
            rv = c == 0 ? exr_encoding_initialize(ctx, part, &chunk, &enc)
                        : exr_encoding_update(ctx, part, &chunk, &enc);
        if (rv == EXR_ERR_SUCCESS)
            rv = bind_chunk(&enc, sources, width, chunk.start_y);
        if (rv == EXR_ERR_SUCCESS && c == 0)
            rv = exr_encoding_choose_default_routines(ctx, part, &enc);
        if (rv == EXR_ERR_SUCCESS)
            rv = exr_encoding_run(ctx, part, &enc);
    }
    exr_encoding_destroy(ctx, &enc);
    if (rv == EXR_ERR_WRITE_IO)
        return exr_fail(CV_ERROR_IO, path, "writing pixels", rv);
    if (rv != EXR_ERR_SUCCESS)
        return exr_fail(rv == EXR_ERR_OUT_OF_MEMORY ? CV_ERROR_OUT_OF_MEMORY : CV_ERROR_BACKEND, path,
                        "encoding pixels", rv);
    return CV_OK;
}

static cv_result define_part(const char *path, exr_context_t ctx, const cv_exr_desc *desc, const exr_sources *sources,
                             int *part) {
    exr_result_t rv = exr_add_part(ctx, NULL, EXR_STORAGE_SCANLINE, part);
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_initialize_required_attr_simple(ctx, *part, (int32_t)desc->width, (int32_t)desc->height,
                                                 exr_compression_of(desc->compression));
    /* The perceptual hint only steers lossy compressions, which we never use;
     * logarithmic is what other writers put by default. */
    for (uint32_t i = 0; i < sources->count && rv == EXR_ERR_SUCCESS; i++) {
        const exr_source *s = &sources->list[i];
        rv = exr_add_channel(ctx, *part, s->name, s->type == CV_EXR_HALF ? EXR_PIXEL_HALF : EXR_PIXEL_FLOAT,
                             EXR_PERCEPTUALLY_LOGARITHMIC, 1, 1);
    }
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_write_header(ctx);
    if (rv == EXR_ERR_WRITE_IO || rv == EXR_ERR_FILE_ACCESS)
        return exr_fail(CV_ERROR_IO, path, "writing the header", rv);
    if (rv != EXR_ERR_SUCCESS)
        return exr_fail(CV_ERROR_BACKEND, path, "defining the header", rv);
    return CV_OK;
}

cv_result cv_exr_write(const char *path, const cv_exr_desc *desc) {
    exr_sources sources;
    cv_result r = check_desc(path, desc, &sources);
    if (r != CV_OK)
        return r;

    /* OpenEXR's own temporary-file mode leaves its file behind when the final
     * rename fails and reports no reason, so the temporary is ours. */
    char *temp = NULL;
    int fd = -1;
    r = image_temp_create(path, &temp, &fd);
    if (r != CV_OK)
        return r;
    close(fd);
    exr_clear_captured_error();
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = exr_capture_error;
    exr_context_t ctx = NULL;
    exr_result_t rv = exr_start_write(&ctx, temp, EXR_WRITE_FILE_DIRECTLY, &init);
    if (rv != EXR_ERR_SUCCESS)
        r = exr_fail(rv == EXR_ERR_OUT_OF_MEMORY ? CV_ERROR_OUT_OF_MEMORY : CV_ERROR_IO, path,
                     "cannot create the file", rv);
    int part = 0;
    if (r == CV_OK)
        r = define_part(path, ctx, desc, &sources, &part);
    if (r == CV_OK)
        r = write_chunks(path, ctx, part, desc->width, &sources);
    if (ctx != NULL) {
        rv = exr_finish(&ctx);
        if (r == CV_OK && rv != EXR_ERR_SUCCESS)
            r = exr_fail(CV_ERROR_IO, path, "finishing the file", rv);
    }
    if (r == CV_OK)
        r = image_temp_commit(temp, path);
    else
        image_temp_remove(temp);
    free(temp);
    return r;
}
