/* The gateway's private temporary files (temp_files.h). */
#include "temp_files.h"

#include <dirent.h>
#include <stdbool.h>
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

cv_result gw_temp_dir_create(const char *base, char out[GW_PATH_MAX]) {
    int n = snprintf(out, GW_PATH_MAX, "%s/corvid-gateway-XXXXXX", base);
    if (n < 0 || n >= GW_PATH_MAX)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "gateway: temporary directory '%s' is too long a path", base);
    if (!mkdtemp(out))
        return cv_error(CV_ERROR_IO, "gateway: cannot create a temporary directory in '%s': %s", base,
                        strerror(errno));
    return CV_OK;
}

void gw_temp_dir_remove(const char *dir) {
    DIR *d = opendir(dir);
    if (d) {
        struct dirent *e;
        char path[GW_PATH_MAX + 256];
        while ((e = readdir(d)) != NULL) {
            if (strcmp(e->d_name, ".") == 0 || strcmp(e->d_name, "..") == 0)
                continue;
            snprintf(path, sizeof(path), "%s/%s", dir, e->d_name);
            unlink(path);
        }
        closedir(d);
    }
    rmdir(dir);
}

cv_result gw_file_write(const char *path, const void *data, size_t size) {
    FILE *f = fopen(path, "wb");
    if (!f)
        return cv_error(CV_ERROR_IO, "gateway: cannot create '%s': %s", path, strerror(errno));
    bool ok = fwrite(data, 1, size, f) == size;
    ok = (fclose(f) == 0) && ok;
    return ok ? CV_OK : cv_error(CV_ERROR_IO, "gateway: cannot write '%s'", path);
}

cv_result gw_file_read(const char *path, uint8_t **data, size_t *size) {
    FILE *f = fopen(path, "rb");
    if (!f)
        return cv_error(CV_ERROR_IO, "gateway: cannot open '%s': %s", path, strerror(errno));
    long length = -1;
    if (fseek(f, 0, SEEK_END) == 0)
        length = ftell(f);
    uint8_t *bytes = length >= 0 ? malloc((size_t)length + 1) : NULL;
    bool ok = bytes && fseek(f, 0, SEEK_SET) == 0 && fread(bytes, 1, (size_t)length, f) == (size_t)length;
    fclose(f);
    if (!ok) {
        cv_result code = bytes || length < 0 ? CV_ERROR_IO : CV_ERROR_OUT_OF_MEMORY;
        free(bytes);
        return cv_error(code, "gateway: cannot read '%s'", path);
    }
    *data = bytes;
    *size = (size_t)length;
    return CV_OK;
}
