/* See model_files.h. */
#include "model_files.h"

#include <errno.h>
#include <fcntl.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

/* ---- assimp's file procs over a FILE * (the aiFile's UserData) ---- */

static FILE *file_of(struct aiFile *f) { return (FILE *)(void *)f->UserData; }

static size_t file_read(struct aiFile *f, char *data, size_t size, size_t count) {
    return fread(data, size, count, file_of(f));
}

static size_t file_write(struct aiFile *f, const char *data, size_t size, size_t count) {
    (void)f;
    (void)data;
    (void)size;
    (void)count;
    return 0; /* opened for reading only */
}

static size_t file_tell(struct aiFile *f) {
    long at = ftell(file_of(f));
    return at < 0 ? 0 : (size_t)at;
}

static size_t file_size(struct aiFile *f) {
    struct stat st;
    return fstat(fileno(file_of(f)), &st) == 0 ? (size_t)st.st_size : 0;
}

static enum aiReturn file_seek(struct aiFile *f, size_t offset, enum aiOrigin origin) {
    int whence = origin == aiOrigin_CUR ? SEEK_CUR : origin == aiOrigin_END ? SEEK_END : SEEK_SET;
    if (offset > (size_t)LONG_MAX)
        return aiReturn_FAILURE;
    return fseek(file_of(f), (long)offset, whence) == 0 ? aiReturn_SUCCESS : aiReturn_FAILURE;
}

static void file_flush(struct aiFile *f) { (void)f; }

/* Every file assimp opens, the model itself included, comes here. */
static struct aiFile *io_open(struct aiFileIO *io, const char *path, const char *mode) {
    model_files *m = (model_files *)(void *)io;
    if (!path || !mode || mode[0] != 'r')
        return NULL;
    char what[PATH_MAX + 64];
    snprintf(what, sizeof what, "%s: a file it names", m->model);
    FILE *f = NULL;
    cv_result r = model_files_open(m, path, what, &f);
    if (r != CV_OK) {
        /* Missing files are assimp's to report (some, like an mtllib, are optional). */
        if (r != CV_ERROR_NOT_FOUND && m->refused == CV_OK) {
            m->refused = r;
            snprintf(m->message, sizeof m->message, "%s", cv_last_error());
        }
        return NULL;
    }
    struct aiFile *af = calloc(1, sizeof *af);
    if (!af) {
        fclose(f);
        return NULL;
    }
    *af = (struct aiFile){ .ReadProc = file_read,
                           .WriteProc = file_write,
                           .TellProc = file_tell,
                           .FileSizeProc = file_size,
                           .SeekProc = file_seek,
                           .FlushProc = file_flush,
                           .UserData = (aiUserData)(void *)f };
    return af;
}

static void io_close(struct aiFileIO *io, struct aiFile *f) {
    (void)io;
    if (!f)
        return;
    fclose(file_of(f));
    free(f);
}

cv_result model_files_init(model_files *m, const char *model) {
    memset(m, 0, sizeof *m);
    m->model = model;
    m->io.OpenProc = io_open;
    m->io.CloseProc = io_close;
    char dir[PATH_MAX];
    const char *slash = strrchr(model, '/');
    if (!slash)
        snprintf(dir, sizeof dir, ".");
    else if (snprintf(dir, sizeof dir, "%.*s", slash == model ? 1 : (int)(slash - model), model) >= (int)sizeof dir)
        return cv_error(CV_ERROR_IO, "%s: the path is too long", model);
    if (!realpath(dir, m->root))
        return cv_error(errno == ENOENT ? CV_ERROR_NOT_FOUND : CV_ERROR_IO, "%s: cannot resolve its folder: %s",
                        model, strerror(errno));
    return CV_OK;
}

/* Whether `resolved` is the folder `root` or lies under it. */
static bool inside(const char *root, const char *resolved) {
    size_t n = strlen(root);
    if (strcmp(root, "/") == 0)
        return true;
    return strncmp(resolved, root, n) == 0 && resolved[n] == '/';
}

cv_result model_files_open(const model_files *m, const char *file, const char *what, FILE **out) {
    char resolved[PATH_MAX];
    if (!realpath(file, resolved))
        return errno == ENOENT || errno == ENOTDIR
                   ? cv_error(CV_ERROR_NOT_FOUND, "%s: no such file (%s)", what, file)
                   : cv_error(CV_ERROR_IO, "%s: cannot read %s: %s", what, file, strerror(errno));
    /* The model itself may be a link to elsewhere: the caller chose it. */
    if (strcmp(file, m->model) != 0 && !inside(m->root, resolved))
        return cv_error(CV_ERROR_MALFORMED,
                        "%s: %s resolves to %s, outside the model's folder %s (a model may only name files under "
                        "its folder)",
                        what, file, resolved, m->root);
    /* O_NONBLOCK: opening a FIFO for reading would wait for a writer;
     * O_NOFOLLOW: the path was resolved, a symlink now is a swap. */
    int fd = open(resolved, O_RDONLY | O_NONBLOCK | O_NOFOLLOW | O_CLOEXEC);
    if (fd < 0)
        return cv_error(CV_ERROR_IO, "%s: cannot open %s: %s", what, file, strerror(errno));
    struct stat st;
    if (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
        close(fd);
        return cv_error(CV_ERROR_IO, "%s: %s is not a regular file (a FIFO, socket, device or folder)", what, file);
    }
    FILE *f = fdopen(fd, "rb");
    if (!f) {
        close(fd);
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "%s: no memory to read %s", what, file);
    }
    *out = f;
    return CV_OK;
}
