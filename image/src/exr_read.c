/* cv_exr_read: every channel of a single-part scanline EXR decoded to float
 * planes, one plane per channel. Decoding each channel into its own plane
 * (never interleaved) avoids OpenEXRCore 3.1's reordering of half RGBA when
 * converted to interleaved float. Reads go through our own pread callback so
 * that a file which ends early is told apart from a failing disk. */
#include <errno.h>
#include <fcntl.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "corvid/file_util.h"
#include "corvid/image_exr.h"
#include "exr_errors.h"

typedef struct exr_file {
    int fd;
    int64_t size;
    int read_errno; /* set by a failing pread, 0 otherwise */
} exr_file;

static int64_t read_at(exr_const_context_t ctxt, void *user, void *buffer, uint64_t size, uint64_t offset,
                       exr_stream_error_func_ptr_t error_cb) {
    (void)ctxt;
    (void)error_cb;
    exr_file *file = user;
    uint8_t *out = buffer;
    uint64_t done = 0;
    while (done < size) {
        ssize_t n = pread(file->fd, out + done, size - done, (off_t)(offset + done));
        if (n < 0 && errno == EINTR)
            continue;
        if (n < 0) {
            file->read_errno = errno;
            return -1;
        }
        if (n == 0)
            break;
        done += (uint64_t)n;
    }
    return (int64_t)done;
}

static int64_t query_size(exr_const_context_t ctxt, void *user) {
    (void)ctxt;
    return ((exr_file *)user)->size;
}

static cv_exr_compression compression_of(exr_compression_t c) {
    switch (c) {
    case EXR_COMPRESSION_ZIP: return CV_EXR_ZIP;
    case EXR_COMPRESSION_PIZ: return CV_EXR_PIZ;
    case EXR_COMPRESSION_NONE: return CV_EXR_NONE;
    default: return CV_EXR_OTHER_COMPRESSION;
    }
}

/* Checks that the only part is a scanline image of HALF/FLOAT channels at full
 * resolution, and allocates the image's planes. */
static cv_result prepare_image(const char *path, exr_context_t ctx, const exr_file *file, cv_exr_image *img) {
    int parts = 0;
    exr_storage_t storage;
    exr_attr_box2i_t window;
    exr_compression_t compression;
    const exr_attr_chlist_t *channels = NULL;
    exr_result_t rv = exr_get_count(ctx, &parts);
    if (rv == EXR_ERR_SUCCESS && parts != 1)
        return cv_error(CV_ERROR_UNSUPPORTED, "%s: %d parts (only single-part files are read)", path, parts);
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_get_storage(ctx, 0, &storage);
    if (rv == EXR_ERR_SUCCESS && storage != EXR_STORAGE_SCANLINE)
        return cv_error(CV_ERROR_UNSUPPORTED, "%s: %s storage (only scanline files are read)", path,
                        storage == EXR_STORAGE_TILED ? "tiled" : "deep");
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_get_data_window(ctx, 0, &window);
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_get_compression(ctx, 0, &compression);
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_get_channels(ctx, 0, &channels);
    if (rv != EXR_ERR_SUCCESS)
        return exr_fail(exr_read_result(rv, file->read_errno), path, "reading the header", rv);

    int64_t width = (int64_t)window.max.x - window.min.x + 1;
    int64_t height = (int64_t)window.max.y - window.min.y + 1;
    if (width < 1 || height < 1 || width > UINT32_MAX || height > UINT32_MAX)
        return cv_error(CV_ERROR_MALFORMED, "%s: data window %lldx%lld is empty or too large", path, (long long)width,
                        (long long)height);
    if (channels->num_channels < 1)
        return cv_error(CV_ERROR_MALFORMED, "%s: no channels", path);
    for (int i = 0; i < channels->num_channels; i++) {
        const exr_attr_chlist_entry_t *e = &channels->entries[i];
        if (e->pixel_type != EXR_PIXEL_HALF && e->pixel_type != EXR_PIXEL_FLOAT)
            return cv_error(CV_ERROR_UNSUPPORTED,
                            "%s: channel '%s' holds UINT data (only HALF and "
                            "FLOAT are read)",
                            path, e->name.str);
        if (e->x_sampling != 1 || e->y_sampling != 1)
            return cv_error(CV_ERROR_UNSUPPORTED, "%s: channel '%s' is subsampled %dx%d", path, e->name.str,
                            e->x_sampling, e->y_sampling);
    }

    size_t pixels = (size_t)width * (size_t)height;
    if (pixels > SIZE_MAX / sizeof(float))
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "%s: %lldx%lld pixels do not fit in memory", path, (long long)width,
                        (long long)height);
    img->width = (uint32_t)width;
    img->height = (uint32_t)height;
    img->compression = compression_of(compression);
    img->channels = calloc((size_t)channels->num_channels, sizeof *img->channels);
    if (img->channels == NULL)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "%s: out of memory for %d channel records", path,
                        channels->num_channels);
    img->channel_count = (uint32_t)channels->num_channels;
    for (int i = 0; i < channels->num_channels; i++) {
        const exr_attr_chlist_entry_t *e = &channels->entries[i];
        cv_exr_channel *ch = &img->channels[i];
        ch->type = e->pixel_type == EXR_PIXEL_HALF ? CV_EXR_HALF : CV_EXR_FLOAT;
        ch->name = strdup(e->name.str);
        ch->pixels = malloc(pixels * sizeof(float));
        if (ch->name == NULL || ch->pixels == NULL)
            return cv_error(CV_ERROR_OUT_OF_MEMORY,
                            "%s: out of memory for channel '%s' (%lldx%lld floats, %zu bytes)", path, e->name.str,
                            (long long)width, (long long)height, pixels * sizeof(float));
    }
    return CV_OK;
}

static int64_t channel_index(const cv_exr_image *img, const char *name) {
    for (uint32_t i = 0; i < img->channel_count; i++) {
        if (strcmp(img->channels[i].name, name) == 0)
            return i;
    }
    return -1;
}

/* Points the decoder's channels at this chunk's rows of our planes. */
static exr_result_t bind_chunk(exr_decode_pipeline_t *dec, cv_exr_image *img, int32_t row) {
    for (int16_t i = 0; i < dec->channel_count; i++) {
        exr_coding_channel_info_t *ch = &dec->channels[i];
        int64_t index = channel_index(img, ch->channel_name);
        if (index < 0)
            return EXR_ERR_INCORRECT_CHUNK;
        cv_exr_channel *plane = &img->channels[index];
        ch->user_data_type = EXR_PIXEL_FLOAT;
        ch->user_bytes_per_element = (int16_t)sizeof(float);
        ch->user_pixel_stride = (int32_t)sizeof(float);
        ch->user_line_stride = (int32_t)(sizeof(float) * img->width);
        ch->decode_to_ptr = (uint8_t *)(plane->pixels + (size_t)row * img->width);
    }
    return EXR_ERR_SUCCESS;
}

static cv_result read_chunks(const char *path, exr_context_t ctx, const exr_file *file, cv_exr_image *img) {
    exr_attr_box2i_t window;
    int32_t chunk_count = 0, lines = 0;
    exr_result_t rv = exr_get_data_window(ctx, 0, &window);
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_get_chunk_count(ctx, 0, &chunk_count);
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_get_scanlines_per_chunk(ctx, 0, &lines);
    exr_decode_pipeline_t dec = EXR_DECODE_PIPELINE_INITIALIZER;
    for (int32_t c = 0; c < chunk_count && rv == EXR_ERR_SUCCESS; c++) {
        exr_chunk_info_t chunk;
        rv = exr_read_scanline_chunk_info(ctx, 0, window.min.y + c * lines, &chunk);
        if (rv == EXR_ERR_SUCCESS)
            rv = c == 0 ? exr_decoding_initialize(ctx, 0, &chunk, &dec) : exr_decoding_update(ctx, 0, &chunk, &dec);
        if (rv == EXR_ERR_SUCCESS)
            rv = bind_chunk(&dec, img, chunk.start_y - window.min.y);
        if (rv == EXR_ERR_SUCCESS && c == 0)
            rv = exr_decoding_choose_default_routines(ctx, 0, &dec);
        if (rv == EXR_ERR_SUCCESS)
            rv = exr_decoding_run(ctx, 0, &dec);
    }
    exr_decoding_destroy(ctx, &dec);
    if (rv != EXR_ERR_SUCCESS)
        return exr_fail(exr_read_result(rv, file->read_errno), path, "reading pixels", rv);
    return CV_OK;
}

cv_result cv_exr_read(const char *path, cv_exr_image *out) {
    if (path == NULL || path[0] == '\0')
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "exr: no path given");
    if (out == NULL)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "%s: out is NULL", path);
    exr_file file = { .fd = -1 };
    if (cv_file_open_regular(path, O_RDONLY, 0, &file.fd) != CV_OK) /* a FIFO would block in open */
        return CV_ERROR_IO;
    struct stat st;
    if (fstat(file.fd, &st) != 0) {
        cv_result r = cv_error(CV_ERROR_IO, "%s: cannot stat: %s", path, strerror(errno));
        close(file.fd);
        return r;
    }
    file.size = st.st_size;

    exr_clear_captured_error();
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = exr_capture_error;
    init.user_data = &file;
    init.read_fn = read_at;
    init.size_fn = query_size;
    /* A damaged file should fail, not be patched up from whatever chunks survive. */
    init.flags = EXR_CONTEXT_FLAG_DISABLE_CHUNK_RECONSTRUCTION;
    exr_context_t ctx = NULL;
    cv_exr_image img = { 0 };
    cv_result r = CV_OK;
    exr_result_t rv = exr_start_read(&ctx, path, &init);
    if (rv != EXR_ERR_SUCCESS)
        r = exr_fail(exr_read_result(rv, file.read_errno), path, "not a readable EXR", rv);
    if (r == CV_OK)
        r = prepare_image(path, ctx, &file, &img);
    if (r == CV_OK)
        r = read_chunks(path, ctx, &file, &img);
    exr_finish(&ctx);
    close(file.fd);
    if (r != CV_OK) {
        cv_exr_image_free(&img);
        return r;
    }
    *out = img;
    return CV_OK;
}

const float *cv_exr_image_find(const cv_exr_image *image, const char *name) {
    if (image == NULL || name == NULL)
        return NULL;
    int64_t index = channel_index(image, name);
    return index < 0 ? NULL : image->channels[index].pixels;
}

void cv_exr_image_free(cv_exr_image *image) {
    if (image == NULL)
        return;
    for (uint32_t i = 0; i < image->channel_count; i++) {
        free(image->channels[i].name);
        free(image->channels[i].pixels);
    }
    free(image->channels);
    memset(image, 0, sizeof *image);
}
