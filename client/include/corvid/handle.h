/* Typed, generational 64-bit resource handles.
 *
 * A handle names a resource owned by the application (a cv_context). It is a
 * plain 64-bit value so it can cross the wire, packed as
 *
 *     bits 63..60  resource type (cv_handle_type)
 *     bits 59..48  context tag (1..4095: which live context made it)
 *     bits 47..24  generation (1..2^24-1; bumps every time the slot is freed)
 *     bits 23..0   slot index (so at most 2^24 handles of one type per context)
 *
 * The value 0 is never a valid handle. Each resource kind has its own struct
 * type, so passing a cv_buffer where a cv_texture is wanted does not compile;
 * handles that arrive as raw u64 (from the wire, from a decoded command list)
 * are checked at run time: wrong type, another context's handle, stale
 * generation and double destroy all give distinct errors. Lookup is an array
 * index plus a compare (O(1)).
 *
 * Handles belong to one context. Every context gets a tag that no other live
 * context in the process has, and every lookup compares it, so context A's
 * handle used on context B, on B's devices or in a list compiled on B's device
 * fails with CV_ERROR_FOREIGN_HANDLE even when the slot and generation match one
 * of B's (a node holds one context per client session: this keeps sessions
 * apart). Devices belong to one context too, and a device's table holds only
 * its context's handles, so cv_device_lookup() never finds a foreign one.
 *
 * A slot whose generation reaches 2^24-1 is retired when that handle is
 * destroyed, never reused: a wrapped generation would make an old handle valid
 * again. A context therefore loses one slot per 2^24-1 destroys of that slot.
 *
 * One handle, many representations: every cv_device keeps its own object for a
 * handle, loaded and unloaded independently (see device.h).
 *
 * There is no fence handle: a submission is identified by its ticket, the
 * value it signals on its device's timeline (cv_device_submit/cv_device_wait). */
#ifndef CORVID_HANDLE_H
#define CORVID_HANDLE_H

#include <stdint.h>
#include <stdbool.h>

typedef enum cv_handle_type {
    CV_HANDLE_NONE = 0,
    CV_HANDLE_BUFFER = 1,
    CV_HANDLE_TEXTURE = 2,
    CV_HANDLE_SAMPLER = 3,
    CV_HANDLE_PIPELINE = 4,
    CV_HANDLE_CMDLIST = 5,
    CV_HANDLE_ACCEL = 6,
    CV_HANDLE_TYPE_COUNT
} cv_handle_type;
_Static_assert(CV_HANDLE_TYPE_COUNT <= 16, "the handle's type field has 4 bits");

typedef struct cv_handle {
    uint64_t id;
} cv_handle; /* any type, checked at run time */
typedef struct cv_buffer {
    uint64_t id;
} cv_buffer;
typedef struct cv_texture {
    uint64_t id;
} cv_texture;
typedef struct cv_sampler {
    uint64_t id;
} cv_sampler;
typedef struct cv_pipeline {
    uint64_t id;
} cv_pipeline;
typedef struct cv_cmdlist {
    uint64_t id;
} cv_cmdlist;
typedef struct cv_accel {
    uint64_t id;
} cv_accel; /* acceleration structure for tracing rays */

#define CV_HANDLE_INDEX_BITS 24u
#define CV_HANDLE_GENERATION_BITS 24u
#define CV_HANDLE_TAG_BITS 12u /* a node holds a context per session: thousands at once */
#define CV_HANDLE_INDEX_MAX ((1u << CV_HANDLE_INDEX_BITS) - 1u)
#define CV_HANDLE_GENERATION_MAX ((1u << CV_HANDLE_GENERATION_BITS) - 1u)
#define CV_HANDLE_TAG_MAX ((1u << CV_HANDLE_TAG_BITS) - 1u)

static inline uint64_t cv_handle_pack(cv_handle_type type, uint32_t tag, uint32_t generation, uint32_t index) {
    return ((uint64_t)(type & 0xfu) << 60) | ((uint64_t)(tag & CV_HANDLE_TAG_MAX) << 48) |
           ((uint64_t)(generation & CV_HANDLE_GENERATION_MAX) << 24) | (index & CV_HANDLE_INDEX_MAX);
}
static inline cv_handle_type cv_handle_type_of(uint64_t id) { return (cv_handle_type)(id >> 60); }
static inline uint32_t cv_handle_tag(uint64_t id) { return (uint32_t)(id >> 48) & CV_HANDLE_TAG_MAX; }
static inline uint32_t cv_handle_generation(uint64_t id) { return (uint32_t)(id >> 24) & CV_HANDLE_GENERATION_MAX; }
static inline uint32_t cv_handle_index(uint64_t id) { return (uint32_t)id & CV_HANDLE_INDEX_MAX; }

/* Converts any typed handle to the untyped cv_handle (compile error for other types). */
#define cv_any(h) \
    _Generic((h), cv_handle \
             : (h), cv_buffer \
             : (cv_handle){ (h).id }, cv_texture \
             : (cv_handle){ (h).id }, cv_sampler \
             : (cv_handle){ (h).id }, cv_pipeline \
             : (cv_handle){ (h).id }, cv_cmdlist \
             : (cv_handle){ (h).id }, cv_accel \
             : (cv_handle){ (h).id })

/* "buffer", "texture", ... ("none" for 0, "invalid" for an unknown tag). */
const char *cv_handle_type_name(cv_handle_type type);

#endif
