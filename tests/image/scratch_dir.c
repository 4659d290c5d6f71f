/* See scratch_dir.h. */
#include "scratch_dir.h"

#include <dirent.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <unistd.h>

static char dir[256];

const char *scratch_dir_create(const char *name) {
    snprintf(dir, sizeof dir, "/tmp/corvid-%s-XXXXXX", name);
    if (mkdtemp(dir) == NULL) {
        perror("mkdtemp");
        exit(1);
    }
    return dir;
}

const char *scratch_path(int slot, const char *file) {
    static char paths[4][512];
    snprintf(paths[slot], sizeof paths[slot], "%s/%s", dir, file);
    return paths[slot];
}

int scratch_dir_entries(void) {
    DIR *d = opendir(dir);
    if (d == NULL)
        return -1;
    int n = 0;
    for (struct dirent *e = readdir(d); e != NULL; e = readdir(d))
        n += strcmp(e->d_name, ".") != 0 && strcmp(e->d_name, "..") != 0;
    closedir(d);
    return n;
}

void scratch_dir_remove(void) {
    DIR *d = opendir(dir);
    if (d == NULL)
        return;
    for (struct dirent *e = readdir(d); e != NULL; e = readdir(d)) {
        if (strcmp(e->d_name, ".") != 0 && strcmp(e->d_name, "..") != 0)
            unlink(scratch_path(3, e->d_name));
    }
    closedir(d);
    rmdir(dir);
}

void limit_file_size(unsigned long bytes) {
    static struct rlimit original;
    static bool saved;
    if (!saved) {
        getrlimit(RLIMIT_FSIZE, &original);
        signal(SIGXFSZ, SIG_IGN);
        saved = true;
    }
    struct rlimit limit = original;
    if (bytes != 0)
        limit.rlim_cur = bytes;
    setrlimit(RLIMIT_FSIZE, &limit);
}

bool file_read_all(const char *path, unsigned char **data, size_t *size) {
    FILE *f = fopen(path, "rb");
    if (f == NULL)
        return false;
    bool ok = fseek(f, 0, SEEK_END) == 0;
    long length = ok ? ftell(f) : -1;
    ok = ok && length >= 0 && fseek(f, 0, SEEK_SET) == 0;
    unsigned char *buffer = ok ? malloc((size_t)length + 1) : NULL;
    ok = buffer != NULL && fread(buffer, 1, (size_t)length, f) == (size_t)length;
    fclose(f);
    if (!ok) {
        free(buffer);
        return false;
    }
    *data = buffer;
    *size = (size_t)length;
    return true;
}

bool file_write_all(const char *path, const void *data, size_t size) {
    FILE *f = fopen(path, "wb");
    if (f == NULL)
        return false;
    bool ok = fwrite(data, 1, size, f) == size;
    return fclose(f) == 0 && ok;
}
