/* Temporary files for atomic writes: a writer creates its output under a
 * temporary name in the destination's directory (same filesystem, so the
 * final rename is atomic) and renames it into place only when complete. */
#ifndef CORVID_IMAGE_TEMP_FILE_H
#define CORVID_IMAGE_TEMP_FILE_H

#include "corvid/result.h"

/* Creates a new, empty file (exclusively, mode 0666 less the umask) in the
 * directory of `path`, named ".<pid>-<n>.corvid-tmp" so that its length does
 * not depend on the destination's name. Returns an open descriptor and the
 * name in *temp (free it), or fails with CV_ERROR_IO naming `path` and the
 * system's reason. */
cv_result image_temp_create(const char *path, char **temp, int *fd);

/* Renames `temp` over `path`; on failure removes `temp` and fails with
 * CV_ERROR_IO naming `path` and the system's reason. */
cv_result image_temp_commit(const char *temp, const char *path);

/* Removes `temp` (a failed write) and forgets it. */
void image_temp_remove(const char *temp);

/* Forgets `temp` once it is gone by other means (renamed into place): live
 * temporaries are what cv_image_temps_remove_all removes. */
void image_temp_forget(const char *temp);

#endif
