/* Generational handle slots (see handle_pool.h). */
#include "corvid/handle_pool.h"

#include <stdlib.h>
#include <string.h>

/* What the pool keeps per slot, ahead of the caller's data. */
typedef enum slot_state { SLOT_FREE = 0, SLOT_LIVE, SLOT_RETIRED } slot_state;

typedef struct slot {
    uint32_t generation; /* 1..CV_HANDLE_GENERATION_MAX, never 0 */
    uint32_t state;      /* slot_state */
} slot;

/* The caller's data starts this far into a slot, aligned for any type. */
#define DATA_OFFSET ((sizeof(slot) + _Alignof(max_align_t) - 1) / _Alignof(max_align_t) * _Alignof(max_align_t))

static uint32_t chunk_of(uint32_t index) {
    uint32_t bits = 31u - (uint32_t)__builtin_clz(index | 1u); /* floor(log2(index)), 0 for 0 */
    return bits < CV_HANDLE_POOL_FIRST_CHUNK_BITS ? 0 : bits - CV_HANDLE_POOL_FIRST_CHUNK_BITS + 1;
}

static uint32_t chunk_base(uint32_t chunk) {
    return chunk ? (1u << CV_HANDLE_POOL_FIRST_CHUNK_BITS) << (chunk - 1) : 0;
}

/* Slots in a chunk: the chunk's share of [0, capacity). */
static uint32_t chunk_length(const cv_handle_pool *pool, uint32_t chunk) {
    uint32_t base = chunk_base(chunk);
    uint32_t end = chunk ? base * 2 : 1u << CV_HANDLE_POOL_FIRST_CHUNK_BITS;
    return (end < pool->capacity ? end : pool->capacity) - base;
}

static slot *slot_at(const cv_handle_pool *pool, uint32_t index) {
    uint32_t chunk = chunk_of(index);
    return (slot *)(pool->chunks[chunk] + (size_t)(index - chunk_base(chunk)) * pool->stride);
}

cv_result cv_handle_pool_init(cv_handle_pool *pool, cv_handle_type type, uint32_t tag, uint32_t capacity,
                              size_t data_size) {
    if (type == CV_HANDLE_NONE || type >= CV_HANDLE_TYPE_COUNT || tag == 0 || tag > CV_HANDLE_TAG_MAX ||
        capacity == 0 || capacity > CV_HANDLE_INDEX_MAX + 1)
        return cv_error(CV_ERROR_INVALID_ARGUMENT,
                        "handle pool: bad type %d, context tag %u or capacity %u "
                        "(1..%u)",
                        (int)type, tag, capacity, CV_HANDLE_INDEX_MAX + 1);
    memset(pool, 0, sizeof(*pool));
    pool->type = type;
    pool->tag = tag;
    pool->capacity = capacity;
    pool->data_size = data_size;
    pool->stride = (DATA_OFFSET + data_size + _Alignof(max_align_t) - 1) / _Alignof(max_align_t) *
                   _Alignof(max_align_t);
    return CV_OK;
}

void cv_handle_pool_finish(cv_handle_pool *pool) {
    for (uint32_t c = 0; c < CV_HANDLE_POOL_CHUNKS; c++)
        free(pool->chunks[c]);
    free(pool->free_slots);
    memset(pool, 0, sizeof(*pool));
}

/* Makes sure slot `index` (== pool->used) exists: adds its chunk, and room on
 * the free stack for every slot, so that freeing never needs memory. */
static cv_result ensure_slot(cv_handle_pool *pool, uint32_t index) {
    uint32_t chunk = chunk_of(index);
    if (pool->chunks[chunk])
        return CV_OK;
    uint32_t length = chunk_length(pool, chunk);
    unsigned char *memory = calloc(length, pool->stride);
    uint32_t *stack = memory ? realloc(pool->free_slots, (size_t)(index + length) * sizeof(uint32_t)) : NULL;
    if (!stack) {
        free(memory);
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "%s handle pool: growing to %u slots",
                        cv_handle_type_name(pool->type), index + length);
    }
    pool->free_slots = stack;
    pool->chunks[chunk] = memory;
    for (uint32_t i = 0; i < length; i++)
        ((slot *)(memory + (size_t)i * pool->stride))->generation = 1;
    return CV_OK;
}

cv_result cv_handle_pool_alloc(cv_handle_pool *pool, uint64_t *out_id) {
    uint32_t index;
    if (pool->free_count) {
        index = pool->free_slots[--pool->free_count];
    } else if (pool->used < pool->capacity) {
        cv_result r = ensure_slot(pool, pool->used);
        if (r != CV_OK)
            return r;
        index = pool->used++;
    } else {
        return cv_error(CV_ERROR_OUT_OF_HANDLES,
                        "all %u %s handles are in use (%u retired: their generations are "
                        "used up)",
                        pool->capacity, cv_handle_type_name(pool->type), pool->retired);
    }
    slot *s = slot_at(pool, index);
    s->state = SLOT_LIVE;
    pool->live++;
    *out_id = cv_handle_pack(pool->type, pool->tag, s->generation, index);
    return CV_OK;
}

cv_result cv_handle_pool_check(const cv_handle_pool *pool, uint64_t id) {
    if (id == 0)
        return cv_error(CV_ERROR_INVALID_HANDLE, "null %s handle", cv_handle_type_name(pool->type));
    if (cv_handle_type_of(id) != pool->type)
        return cv_error(CV_ERROR_WRONG_HANDLE_TYPE, "handle 0x%016llx is a %s handle, a %s handle is needed",
                        (unsigned long long)id, cv_handle_type_name(cv_handle_type_of(id)),
                        cv_handle_type_name(pool->type));
    if (cv_handle_tag(id) == 0)
        return cv_error(CV_ERROR_INVALID_HANDLE, "%s handle 0x%016llx carries no context tag",
                        cv_handle_type_name(pool->type), (unsigned long long)id);
    if (cv_handle_tag(id) != pool->tag)
        return cv_error(CV_ERROR_FOREIGN_HANDLE,
                        "%s handle 0x%016llx belongs to another context (its tag is %u, "
                        "this context's is %u)",
                        cv_handle_type_name(pool->type), (unsigned long long)id, cv_handle_tag(id), pool->tag);
    uint32_t index = cv_handle_index(id);
    if (index >= pool->capacity || cv_handle_generation(id) == 0)
        return cv_error(CV_ERROR_INVALID_HANDLE, "%s handle 0x%016llx: slot %u is out of range (%u slots)",
                        cv_handle_type_name(pool->type), (unsigned long long)id, index, pool->capacity);
    uint32_t generation = cv_handle_pool_slot_generation(pool, index);
    slot_state state = index < pool->used ? (slot_state)slot_at(pool, index)->state : SLOT_FREE;
    if (state != SLOT_LIVE || generation != cv_handle_generation(id))
        return cv_error(CV_ERROR_STALE_HANDLE, "%s handle 0x%016llx is stale (slot %u is at generation %u%s)",
                        cv_handle_type_name(pool->type), (unsigned long long)id, index, generation,
                        state == SLOT_LIVE   ? ""
                        : state == SLOT_FREE ? ", free"
                                             : ", retired: generations used up");
    return CV_OK;
}

cv_result cv_handle_pool_free(cv_handle_pool *pool, uint64_t id) {
    cv_result r = cv_handle_pool_check(pool, id);
    if (r != CV_OK)
        return r;
    uint32_t index = cv_handle_index(id);
    slot *s = slot_at(pool, index);
    pool->live--;
    if (s->generation == CV_HANDLE_GENERATION_MAX) {
        /* The next generation would wrap to 1 and revive every old handle of this slot. */
        s->state = SLOT_RETIRED;
        pool->retired++;
        return CV_OK;
    }
    s->state = SLOT_FREE;
    s->generation++;
    pool->free_slots[pool->free_count++] = index;
    return CV_OK;
}

void *cv_handle_pool_data(const cv_handle_pool *pool, uint32_t index) {
    return index < pool->used ? (unsigned char *)slot_at(pool, index) + DATA_OFFSET : NULL;
}

uint32_t cv_handle_pool_slot_generation(const cv_handle_pool *pool, uint32_t index) {
    if (index >= pool->capacity)
        return 0;
    return index < pool->used ? slot_at(pool, index)->generation : 1;
}

cv_result cv_handle_pool_set_generation_for_test(cv_handle_pool *pool, uint32_t index, uint32_t generation) {
    if (index >= pool->used || slot_at(pool, index)->state != SLOT_FREE || generation == 0 ||
        generation > CV_HANDLE_GENERATION_MAX)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "%s handle pool: cannot set slot %u to generation %u",
                        cv_handle_type_name(pool->type), index, generation);
    slot_at(pool, index)->generation = generation;
    return CV_OK;
}
