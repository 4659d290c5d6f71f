/* See temp_file.h. */
#include "temp_file.h"

#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "corvid/image_files.h"

/* The temporaries that exist now, so that a program stopped by a signal can
 * remove them (cv_image_temps_remove_all). process-wide: a signal
 * ends the whole process, whichever thread or file set made them. Fixed
 * slots with the names inline: the signal handler allocates nothing and
 * follows no pointer another thread may free. */
#define LIVE_SLOTS 32
enum { SLOT_FREE, SLOT_CLAIMED, SLOT_LIVE };
static struct {
    atomic_int state;
    char name[PATH_MAX];
} live[LIVE_SLOTS];

/* Notes `name` as live (untracked if every slot is taken or it is too long:
 * then only a signal leaves it behind, as before). */
static void live_add(const char *name) {
    size_t len = strlen(name);
    for (int i = 0; i < LIVE_SLOTS && len < PATH_MAX; i++) {
        int expected = SLOT_FREE;
        if (atomic_compare_exchange_strong(&live[i].state, &expected, SLOT_CLAIMED)) {
            memcpy(live[i].name, name, len + 1);
            atomic_store(&live[i].state, SLOT_LIVE);
            return;
        }
    }
}

void image_temp_forget(const char *temp) {
    for (int i = 0; i < LIVE_SLOTS; i++)
        if (atomic_load(&live[i].state) == SLOT_LIVE && strcmp(live[i].name, temp) == 0) {
            atomic_store(&live[i].state, SLOT_FREE);
            return;
        }
}

void cv_image_temps_remove_all(void) {
    for (int i = 0; i < LIVE_SLOTS; i++)
        if (atomic_load(&live[i].state) == SLOT_LIVE)
            unlink(live[i].name);
}

cv_result image_temp_create(const char *path, char **temp, int *fd) {
    /* process-wide: two threads (or two file sets) naming temporaries beside the same path must not pick
     * the same name; the pid separates processes, this counter the calls of one. */
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
            live_add(name);
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
    if (rename(temp, path) == 0) {
        image_temp_forget(temp);
        return CV_OK;
    }
    cv_result r = cv_error(CV_ERROR_IO, "%s: cannot replace: %s", path, strerror(errno));
    image_temp_remove(temp);
    return r;
}

void image_temp_remove(const char *temp) {
    unlink(temp);
    image_temp_forget(temp);
}
