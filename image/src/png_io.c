/* cv_png_write and cv_png_read through libpng's simplified API, which needs
 * no setjmp/longjmp: every failure comes back as a return value with a
 * message in png_image.message. */
#include <errno.h>
#include <png.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "corvid/file_util.h"
#include "corvid/image_png.h"
#include "corvid/types.h"
#include "temp_file.h"

cv_result cv_png_write(const char *path, uint32_t width, uint32_t height, uint32_t channels, const uint8_t *pixels) {
    if (path == NULL || path[0] == '\0')
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "png: no path given");
    if (width == 0 || width > CV_MAX_TEXTURE_DIM || height == 0 || height > CV_MAX_TEXTURE_DIM)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "%s: size %ux%u is outside 1..%u per side", path, width, height,
                        CV_MAX_TEXTURE_DIM);
    if (channels != 3 && channels != 4)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "%s: %u channels (3 for RGB or 4 for RGBA)", path, channels);
    if (pixels == NULL)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "%s: pixels is NULL", path);

    char *temp = NULL;
    int fd = -1;
    cv_result r = image_temp_create(path, &temp, &fd);
    if (r != CV_OK)
        return r;
    FILE *f = fdopen(fd, "wb");
    if (f == NULL) {
        r = cv_error(CV_ERROR_IO, "%s: cannot write: %s", path, strerror(errno));
        close(fd);
        image_temp_remove(temp);
        free(temp);
        return r;
    }
    png_image image = { .version = PNG_IMAGE_VERSION,
                        .width = width,
                        .height = height,
                        .format = channels == 4 ? PNG_FORMAT_RGBA : PNG_FORMAT_RGB };
    bool encoded = png_image_write_to_stdio(&image, f, 0, pixels, 0, NULL) != 0;
    bool flushed = encoded && fflush(f) == 0 && ferror(f) == 0;
    int write_errno = errno;
    bool closed = fclose(f) == 0;
    if (!closed && flushed)
        write_errno = errno;
    if (!encoded)
        r = cv_error(CV_ERROR_IO, "%s: %s", path, image.message);
    else if (!flushed || !closed)
        r = cv_error(CV_ERROR_IO, "%s: cannot write: %s", path, strerror(write_errno));
    if (r == CV_OK)
        r = image_temp_commit(temp, path);
    else
        image_temp_remove(temp);
    free(temp);
    return r;
}

/* A failing read call is IO; anything else, a short file included, is a
 * file that is not a valid or complete PNG. */
static cv_result read_failure(FILE *f, const char *path, const char *step, const char *message) {
    return cv_error(ferror(f) ? CV_ERROR_IO : CV_ERROR_MALFORMED, "%s: %s: %s%s", path, step, message,
                    feof(f) ? " (the file ends early)" : "");
}

cv_result cv_png_read(const char *path, cv_png_image *out) {
    if (path == NULL || path[0] == '\0')
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "png: no path given");
    if (out == NULL)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "%s: out is NULL", path);
    FILE *f;
    if (cv_file_fopen_regular(path, "rb", &f) != CV_OK) /* a FIFO would block in open */
        return CV_ERROR_IO;

    png_image image = { .version = PNG_IMAGE_VERSION };
    uint8_t *pixels = NULL;
    cv_result r = CV_OK;
    if (!png_image_begin_read_from_stdio(&image, f)) {
        r = read_failure(f, path, "not a readable PNG", image.message);
    } else {
        /* Untagged 16-bit data is far more often sRGB-encoded than linear. */
        image.flags |= PNG_IMAGE_FLAG_16BIT_sRGB;
        bool alpha = (image.format & PNG_FORMAT_FLAG_ALPHA) != 0;
        image.format = alpha ? PNG_FORMAT_RGBA : PNG_FORMAT_RGB;
        size_t size = (size_t)image.width * image.height * PNG_IMAGE_PIXEL_CHANNELS(image.format);
        pixels = malloc(size);
        if (pixels == NULL)
            r = cv_error(CV_ERROR_OUT_OF_MEMORY, "%s: %ux%u pixels", path, image.width, image.height);
        else if (!png_image_finish_read(&image, NULL, pixels, 0, NULL))
            r = read_failure(f, path, "reading pixels", image.message);
    }
    png_image_free(&image);
    fclose(f);
    if (r != CV_OK) {
        free(pixels);
        return r;
    }
    *out = (cv_png_image){ .width = image.width,
                           .height = image.height,
                           .channels = PNG_IMAGE_PIXEL_CHANNELS(image.format),
                           .pixels = pixels };
    return CV_OK;
}

void cv_png_image_free(cv_png_image *image) {
    if (image == NULL)
        return;
    free(image->pixels);
    memset(image, 0, sizeof *image);
}
