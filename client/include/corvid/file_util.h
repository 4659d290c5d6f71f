/* Opening the files people name (scenes, images, tokens, port files, logs):
 * every one must be a regular file. A FIFO would block the program in open()
 * or read() (where SIGTERM may be blocked for sigwait, so the process could
 * not even be stopped), and a device or a directory is never what was meant.
 *
 *   int fd;
 *   cv_result r = cv_file_open_regular("scene.obj", O_RDONLY, 0, &fd);
 *   // a FIFO: CV_ERROR_IO "scene.obj: is not a regular file (a FIFO)", at once
 *   FILE *f;
 *   r = cv_file_fopen_regular("port.txt", "w", &f);
 *
 * How: the file is opened with O_NONBLOCK (so opening a FIFO returns at once),
 * checked with fstat, and only then made blocking again; nothing is read or
 * written before the check. Writing with O_CREAT | O_TRUNC truncates only a
 * regular file (O_TRUNC does nothing to a FIFO or a device). */
#ifndef CORVID_FILE_UTIL_H
#define CORVID_FILE_UTIL_H

#include <stdio.h>

#include "corvid/result.h"

/* open(path, flags | O_CLOEXEC, mode) for a regular file only; *fd on success.
 * Errors (CV_ERROR_IO) start with the path: "<path>: is not a regular file (a
 * FIFO)", or "<path>: <the system's reason>". */
cv_result cv_file_open_regular(const char *path, int flags, unsigned mode, int *fd);

/* The same as a stdio stream; `mode` is fopen's "r", "rb", "w" or "wb"
 * (a writable file is created mode 0666 less the umask, and truncated). */
cv_result cv_file_fopen_regular(const char *path, const char *mode, FILE **out);

#endif
