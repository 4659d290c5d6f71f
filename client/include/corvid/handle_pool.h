/* A pool of generational handle slots for one resource type.
 *
 * Used by the application's context (who owns handles) and by every device
 * (whose tables are indexed by the same slot index). Not thread-safe: callers
 * hold their own lock. Slots are reused last-freed-first; each free bumps the
 * slot's generation, so an old handle to a reused slot is reported stale. */
#ifndef CORVID_HANDLE_POOL_H
#define CORVID_HANDLE_POOL_H

#include "corvid/handle.h"
#include "corvid/result.h"

typedef struct cv_handle_pool {
    cv_handle_type type;
    uint32_t tag;           /* context tag of every handle it makes, 1..CV_HANDLE_TAG_MAX */
    uint32_t capacity;
    uint32_t live;          /* allocated and not yet freed */
    uint32_t *generation;   /* per slot, 1..CV_HANDLE_GENERATION_MAX, never 0 */
    uint8_t *in_use;        /* per slot */
    uint32_t *free_slots;   /* stack of free slot indices */
    uint32_t free_count;
} cv_handle_pool;

/* capacity: 1..CV_HANDLE_INDEX_MAX + 1 slots. */
cv_result cv_handle_pool_init(cv_handle_pool *pool, cv_handle_type type, uint32_t tag, uint32_t capacity);
void cv_handle_pool_finish(cv_handle_pool *pool);

/* Allocates a slot; *out_id gets the packed handle. CV_ERROR_OUT_OF_HANDLES when full. */
cv_result cv_handle_pool_alloc(cv_handle_pool *pool, uint64_t *out_id);
/* Frees a live handle. Stale or double frees fail and change nothing. */
cv_result cv_handle_pool_free(cv_handle_pool *pool, uint64_t id);
/* CV_OK if `id` is a live handle of this pool; otherwise INVALID_HANDLE (0, no
 * context tag, index out of range), WRONG_HANDLE_TYPE, FOREIGN_HANDLE (another
 * context's tag) or STALE_HANDLE, with a message. */
cv_result cv_handle_pool_check(const cv_handle_pool *pool, uint64_t id);
/* Current generation of a slot (for tests and diagnostics). */
uint32_t cv_handle_pool_slot_generation(const cv_handle_pool *pool, uint32_t index);

#endif
