/* The gateway's private temporary files: a directory of its own (mode 0700)
 * per model parsed or image written, removed with what it holds afterwards,
 * so nothing half-written stays behind whatever failed. */
#ifndef CORVID_GATEWAY_TEMP_FILES_H
#define CORVID_GATEWAY_TEMP_FILES_H

#include <stddef.h>
#include <stdint.h>

#include "corvid/result.h"

#define GW_PATH_MAX 512

/* Creates <base>/corvid-gateway-XXXXXX into out. */
cv_result gw_temp_dir_create(const char *base, char out[GW_PATH_MAX]);
/* Removes the files directly in `dir`, then `dir`. */
void gw_temp_dir_remove(const char *dir);

cv_result gw_file_write(const char *path, const void *data, size_t size);
/* The whole file, malloc'd. */
cv_result gw_file_read(const char *path, uint8_t **data, size_t *size);

#endif
