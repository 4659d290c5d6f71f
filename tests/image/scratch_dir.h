/* A fresh directory per test run for the files the image tests write, and
 * helpers to damage and inspect those files. */
#ifndef CORVID_TEST_SCRATCH_DIR_H
#define CORVID_TEST_SCRATCH_DIR_H

#include <stdbool.h>
#include <stddef.h>

/* Creates /tmp/corvid-<name>-XXXXXX; returns its path (static storage). */
const char *scratch_dir_create(const char *name);
/* "<dir>/<file>" in a static buffer of its own per call slot (0..3). */
const char *scratch_path(int slot, const char *file);
/* Number of entries in the scratch directory (temporary files included). */
int scratch_dir_entries(void);
/* Removes the directory and everything in it. */
void scratch_dir_remove(void);

/* Makes writes of this process fail past `bytes` bytes per file (EFBIG, with
 * SIGXFSZ ignored), to fail a write half way through; 0 lifts the limit. */
void limit_file_size(unsigned long bytes);

/* Whole-file helpers; false on any failure. */
bool file_read_all(const char *path, unsigned char **data, size_t *size);
bool file_write_all(const char *path, const void *data, size_t size);

#endif
