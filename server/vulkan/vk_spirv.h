/* A small SPIR-V reader: what a shader declares about its descriptor bindings
 * (kind, whether it reads and writes each) and its compute local size. Lets
 * pipeline creation check a shader against its registry entry, and lets the
 * barrier tracker treat read-only storage bindings as reads. */
#ifndef CORVID_VK_SPIRV_H
#define CORVID_VK_SPIRV_H

#include <stddef.h>

#include "vk_common.h"

typedef struct vk_spirv_binding {
    bool used;
    cv_binding_kind kind;
    bool reads, writes;
} vk_spirv_binding;

typedef struct vk_spirv_info {
    bool has_local_size; /* literal LocalSize (not specialised) */
    uint32_t local_size[3];
    vk_spirv_binding bindings[CV_MAX_BINDINGS];
} vk_spirv_info;

/* CV_ERROR_MALFORMED for a broken module, CV_ERROR_UNSUPPORTED for bindings
 * outside set 0 / slots 0..CV_MAX_BINDINGS-1 or of kinds the registry has no
 * letter for. `name` is used in messages. */
cv_result vk_spirv_reflect(const uint32_t *words, size_t size_bytes, const char *name, vk_spirv_info *out);

#endif
