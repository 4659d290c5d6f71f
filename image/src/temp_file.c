/* See temp_file.h. */
#include "temp_file.h"

#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

cv_result image_temp_create(const char *path, char **temp, int *fd) {
    static _Atomic unsigned counter;
    const char *slash = strrchr(path, '/');
    int dir_len = slash != NULL ? (int)(slash - path + 1) : 0;
    /* The directory part, ".", a pid, "-", a counter and the suffix. */
    size_t size = (size_t)dir_len + 64;
    char *name = malloc(size);
    if (name == NULL)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "%s: no memory for a temporary name", path);
    for (int attempt = 0; attempt < 100; attempt++) {
        snprintf(name, size, "%.*s.%ld-%u.corvid-tmp", dir_len, path, (long)getpid(), counter++);
        int f = open(name, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
        if (f >= 0) {
            *temp = name;
            *fd = f;
            return CV_OK;
        }
        if (errno != EEXIST)
            break;
    }
    cv_result r = cv_error(CV_ERROR_IO, "%s: cannot create a temporary file beside it: %s", path, strerror(errno));
    free(name);
    return r;
}

cv_result image_temp_commit(const char *temp, const char *path) {
    if (rename(temp, path) == 0)
        return CV_OK;
    cv_result r = cv_error(CV_ERROR_IO, "%s: cannot replace: %s", path, strerror(errno));
    unlink(temp);
    return r;
}
