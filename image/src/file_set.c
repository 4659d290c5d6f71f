/* See corvid/image_files.h. */
#include <errno.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "corvid/image_files.h"
#include "temp_file.h"

struct cv_file_set {
    uint32_t count;
    struct {
        char *path, *temp; /* temp is NULL once renamed into place */
    } files[CV_FILE_SET_MAX];
};

cv_result cv_file_set_create(cv_file_set **out) {
    if (out == NULL)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_file_set_create: out is NULL");
    cv_file_set *set = calloc(1, sizeof *set);
    if (set == NULL)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "cv_file_set_create: no memory");
    *out = set;
    return CV_OK;
}

/* The destination must name a file, and anything already there must be a
 * regular file: a rename would fail over a directory and silently replace a
 * device or a FIFO. */
static cv_result check_destination(const char *path) {
    const char *slash = strrchr(path, '/');
    const char *name = slash != NULL ? slash + 1 : path;
    if (name[0] == '\0' || strcmp(name, ".") == 0 || strcmp(name, "..") == 0)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "'%s': no file name (the path ends in a directory)", path);
    struct stat st;
    if (lstat(path, &st) == 0) {
        if (S_ISDIR(st.st_mode))
            return cv_error(CV_ERROR_IO, "%s: is a directory", path);
        if (!S_ISREG(st.st_mode))
            return cv_error(CV_ERROR_IO, "%s: exists and is not a regular file", path);
    } else if (errno != ENOENT) {
        return cv_error(CV_ERROR_IO, "%s: %s", path, strerror(errno));
    }
    return CV_OK;
}

cv_result cv_file_set_add(cv_file_set *set, const char *path, const char **temp) {
    if (set == NULL || path == NULL || temp == NULL)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_file_set_add: NULL argument");
    if (path[0] == '\0')
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "file set: empty path");
    if (set->count == CV_FILE_SET_MAX)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "%s: a file set holds at most %d files", path, CV_FILE_SET_MAX);
    cv_result r = check_destination(path);
    if (r != CV_OK)
        return r;
    char *copy = strdup(path);
    if (copy == NULL)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "%s: no memory", path);
    char *name = NULL;
    int fd = -1;
    r = image_temp_create(path, &name, &fd);
    if (r != CV_OK) {
        free(copy);
        return r;
    }
    close(fd);
    set->files[set->count].path = copy;
    set->files[set->count].temp = name;
    set->count++;
    *temp = name;
    return CV_OK;
}

cv_result cv_file_set_commit(cv_file_set *set) {
    if (set == NULL)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_file_set_commit: set is NULL");
    for (uint32_t i = 0; i < set->count; i++) {
        if (set->files[i].temp == NULL)
            continue;
        if (rename(set->files[i].temp, set->files[i].path) != 0) {
            return cv_error(CV_ERROR_IO, "%s: cannot replace: %s (%u earlier file(s) of the set already replaced)",
                            set->files[i].path, strerror(errno), i);
        }
        image_temp_forget(set->files[i].temp);
        free(set->files[i].temp);
        set->files[i].temp = NULL;
    }
    return CV_OK;
}

cv_result cv_file_set_name_error(const cv_file_set *set, cv_result r) {
    char message[CV_ERROR_MESSAGE_MAX];
    snprintf(message, sizeof message, "%s", cv_last_error());
    for (uint32_t i = 0; set != NULL && i < set->count; i++) {
        const char *temp = set->files[i].temp;
        char *at = temp != NULL ? strstr(message, temp) : NULL;
        if (at == NULL)
            continue;
        char rest[CV_ERROR_MESSAGE_MAX];
        snprintf(rest, sizeof rest, "%s", at + strlen(temp));
        snprintf(at, sizeof message - (size_t)(at - message), "%s%s", set->files[i].path, rest);
    }
    return cv_error(r, "%s", message);
}

void cv_file_set_destroy(cv_file_set *set) {
    if (set == NULL)
        return;
    for (uint32_t i = 0; i < set->count; i++) {
        if (set->files[i].temp != NULL)
            image_temp_remove(set->files[i].temp);
        free(set->files[i].temp);
        free(set->files[i].path);
    }
    free(set);
}
