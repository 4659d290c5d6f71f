/* A pool of generational handle slots for one resource type of one context.
 *
 * Used by the application's context (who owns handles); every device indexes
 * its own tables by the same slot index. Not thread-safe: callers hold their
 * own lock. Slots are handed out lowest index first, then reused
 * last-freed-first; each free bumps the slot's generation, so an old handle to
 * a reused slot is reported stale. A slot freed at generation
 * CV_HANDLE_GENERATION_MAX is retired for good instead: wrapping its generation
 * would make its oldest handles valid again. A pool thus loses one slot per
 * 2^24-1 reuses of that slot, and `retired` says how many it has lost.
 *
 * Each slot carries `data_size` bytes for the caller (the context keeps a
 * resource's description or a command list there). Memory grows with use: a
 * pool starts with none and adds chunks of slots as handles are created, each
 * chunk twice the previous, up to `capacity`. Chunks never move, so a pointer
 * to a slot's data stays valid until the pool is finished. */
#ifndef CORVID_HANDLE_POOL_H
#define CORVID_HANDLE_POOL_H

#include <stddef.h>

#include "corvid/handle.h"
#include "corvid/result.h"

/* Chunk 0 holds slots [0, 64); chunk k >= 1 holds [64 << (k-1), 64 << k). */
#define CV_HANDLE_POOL_FIRST_CHUNK_BITS 6u
#define CV_HANDLE_POOL_CHUNKS (CV_HANDLE_INDEX_BITS - CV_HANDLE_POOL_FIRST_CHUNK_BITS + 1u)

typedef struct cv_handle_pool {
    cv_handle_type type;
    uint32_t tag;      /* context tag of every handle it makes, 1..CV_HANDLE_TAG_MAX */
    uint32_t capacity; /* the most slots it may hold */
    uint32_t live;     /* allocated and not yet freed */
    uint32_t used;     /* slots [0, used) have been handed out at least once */
    uint32_t retired;  /* slots whose generations are used up, never handed out again */
    size_t data_size;  /* caller's bytes per slot */
    size_t stride;     /* bytes per slot in a chunk */
    unsigned char *chunks[CV_HANDLE_POOL_CHUNKS];
    uint32_t *free_slots; /* stack of freed slot indices, room for every existing slot */
    uint32_t free_count;
} cv_handle_pool;

/* capacity: 1..CV_HANDLE_INDEX_MAX + 1 slots. Allocates nothing. */
cv_result cv_handle_pool_init(cv_handle_pool *pool, cv_handle_type type, uint32_t tag, uint32_t capacity,
                              size_t data_size);
void cv_handle_pool_finish(cv_handle_pool *pool);

/* Allocates a slot; *out_id gets the packed handle. CV_ERROR_OUT_OF_HANDLES
 * when all `capacity` slots are in use or retired, CV_ERROR_OUT_OF_MEMORY if a new chunk
 * cannot be had (the pool is then unchanged). A fresh slot's data is zeroed; a
 * reused slot's data is as its last user left it. */
cv_result cv_handle_pool_alloc(cv_handle_pool *pool, uint64_t *out_id);
/* Frees a live handle (retiring its slot at the last generation). Stale or
 * double frees fail and change nothing. */
cv_result cv_handle_pool_free(cv_handle_pool *pool, uint64_t id);
/* CV_OK if `id` is a live handle of this pool; otherwise INVALID_HANDLE (0, no
 * context tag, index out of range), WRONG_HANDLE_TYPE, FOREIGN_HANDLE (another
 * context's tag) or STALE_HANDLE, with a message. */
cv_result cv_handle_pool_check(const cv_handle_pool *pool, uint64_t id);
/* The caller's data of slot `index` (NULL if that slot was never handed out). */
void *cv_handle_pool_data(const cv_handle_pool *pool, uint32_t index);
/* Current generation of a slot (for tests and diagnostics; 0 out of range). */
uint32_t cv_handle_pool_slot_generation(const cv_handle_pool *pool, uint32_t index);

/* For tests only: sets the generation of a slot that was handed out before and
 * is free now, so that generation exhaustion is testable without 2^24
 * create/destroy cycles. INVALID_ARGUMENT for any other slot or generation. */
cv_result cv_handle_pool_set_generation_for_test(cv_handle_pool *pool, uint32_t index, uint32_t generation);

#endif
