/* Files written together: a frame's EXR and its PNG preview must never
 * disagree (a new EXR beside an old PNG after a full disk). Each file of the
 * set is written under a temporary name in its destination's directory; only
 * when every one has been written are they renamed into place, and whatever
 * fails removes every temporary and leaves the existing files untouched.
 *
 *     cv_file_set *set;
 *     const char *exr_temp, *png_temp;
 *     cv_result r = cv_file_set_create(&set);
 *     if (r == CV_OK) r = cv_file_set_add(set, "out/frame.exr", &exr_temp);
 *     if (r == CV_OK) r = cv_file_set_add(set, "out/frame.png", &png_temp);
 *     if (r == CV_OK) r = cv_exr_write(exr_temp, &desc);
 *     if (r == CV_OK) r = cv_png_write(png_temp, w, h, 3, rgb);
 *     if (r == CV_OK) r = cv_file_set_commit(set);
 *     cv_file_set_destroy(set);   // removes the temporaries of an uncommitted set
 *
 * Adding a file checks its destination first (a name, not a directory, a
 * directory that exists and takes new files), so callers can add the files
 * before long work and learn of a bad destination at once.
 *
 * The renames of a commit are separate system calls: they cannot fail for the
 * reasons checked when adding, but if one still does (the directory changed
 * meanwhile), the files renamed before it stay replaced and the message says so.
 *
 * Errors: CV_ERROR_INVALID_ARGUMENT for a path with no file name, or more than
 * CV_FILE_SET_MAX files; CV_ERROR_IO with the system's reason otherwise.
 * Messages start with the destination path. */
#ifndef CORVID_IMAGE_FILES_H
#define CORVID_IMAGE_FILES_H

#include "corvid/result.h"

#define CV_FILE_SET_MAX 8

typedef struct cv_file_set cv_file_set;

cv_result cv_file_set_create(cv_file_set **out);

/* Reserves a temporary file for `path` and gives its name in *temp (valid
 * until the set is destroyed); the writer replaces that file. */
cv_result cv_file_set_add(cv_file_set *set, const char *path, const char **temp);

/* Renames every temporary over its destination, in the order added. */
cv_result cv_file_set_commit(cv_file_set *set);

/* Removes the temporaries not committed and frees the set; NULL is fine. */
void cv_file_set_destroy(cv_file_set *set);

/* After a writer failed on a temporary of the set: cv_last_error() with each
 * temporary's name replaced by the file it stands for ("out/frame.exr: No
 * space left on device", not "out/.123-0.corvid-tmp: ..."); returns `r`. */
cv_result cv_file_set_name_error(const cv_file_set *set, cv_result r);

/* Removes every temporary file this library's writers (file sets, cv_exr_write,
 * cv_png_write) hold at this moment, in any thread. Async-signal-safe: for a
 * handler of SIGINT / SIGTERM that then calls _exit, so that an interrupted
 * program leaves no hidden ".<pid>-<n>.corvid-tmp" files. (At most 32 at once
 * are tracked; a program of Corvid's holds at most 8.) */
void cv_image_temps_remove_all(void);

#endif
