/* Embedded SPIR-V of every shader in shaders/, compiled at build time.
 *
 * Pipelines are built from these by name (pipeline_registry.h names the files);
 * no shader code is ever read from disk or sent over the wire. */
#ifndef CORVID_SHADERS_H
#define CORVID_SHADERS_H

#include <stddef.h>
#include <stdint.h>

/* The SPIR-V words of a shader by file name ("test_saxpy.comp"), with its size
 * in bytes; NULL (and size 0) if no such shader was built. */
const uint32_t *cv_shader_spirv(const char *file_name, size_t *size_bytes);
/* Number of embedded shaders, and their file names (for listings and tests). */
uint32_t cv_shader_count(void);
const char *cv_shader_name_at(uint32_t index);

#endif
