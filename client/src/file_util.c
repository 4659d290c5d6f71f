/* See corvid/file_util.h. */
#include "corvid/file_util.h"

#include <errno.h>
#include <fcntl.h>
#include <stdbool.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

static const char *kind_of(mode_t mode) {
    return S_ISFIFO(mode)   ? "a FIFO"
           : S_ISDIR(mode)  ? "a directory"
           : S_ISCHR(mode)  ? "a character device"
           : S_ISBLK(mode)  ? "a block device"
           : S_ISSOCK(mode) ? "a socket"
                            : "not a plain file";
}

static cv_result not_regular(const char *path, mode_t mode) {
    return cv_error(CV_ERROR_IO, "%s: is not a regular file (%s)", path, kind_of(mode));
}

cv_result cv_file_open_regular(const char *path, int flags, unsigned mode, int *fd) {
    if (!path || !path[0] || !fd)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_file_open_regular: no path");
    int f = open(path, flags | O_NONBLOCK | O_CLOEXEC, (mode_t)mode);
    if (f < 0) {
        int err = errno;
        struct stat st;
        /* A FIFO without a reader refuses a non-blocking writer (ENXIO); a
         * directory refuses writing (EISDIR): say what the path is instead. */
        if (stat(path, &st) == 0 && !S_ISREG(st.st_mode))
            return not_regular(path, st.st_mode);
        return cv_error(CV_ERROR_IO, "%s: %s", path, strerror(err));
    }
    struct stat st;
    if (fstat(f, &st) != 0 || !S_ISREG(st.st_mode)) {
        cv_result r = fstat(f, &st) != 0 ? cv_error(CV_ERROR_IO, "%s: %s", path, strerror(errno))
                                         : not_regular(path, st.st_mode);
        close(f);
        return r;
    }
    int fl = fcntl(f, F_GETFL);
    if (fl < 0 || fcntl(f, F_SETFL, fl & ~O_NONBLOCK) != 0) {
        cv_result r = cv_error(CV_ERROR_IO, "%s: %s", path, strerror(errno));
        close(f);
        return r;
    }
    *fd = f;
    return CV_OK;
}

cv_result cv_file_fopen_regular(const char *path, const char *mode, FILE **out) {
    if (!mode || !out)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_file_fopen_regular: NULL argument");
    bool write = mode[0] == 'w';
    if (!write && mode[0] != 'r')
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_file_fopen_regular: mode '%s' is not r, rb, w or wb", mode);
    int fd;
    cv_result r = cv_file_open_regular(path, write ? O_WRONLY | O_CREAT | O_TRUNC : O_RDONLY, 0666, &fd);
    if (r != CV_OK)
        return r;
    FILE *f = fdopen(fd, write ? "wb" : "rb");
    if (!f) {
        r = cv_error(CV_ERROR_IO, "%s: %s", path, strerror(errno));
        close(fd);
        return r;
    }
    *out = f;
    return CV_OK;
}
