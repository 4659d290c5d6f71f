/* Generational handle slots (see handle_pool.h). */
#include "corvid/handle_pool.h"

#include <stdlib.h>

cv_result cv_handle_pool_init(cv_handle_pool *pool, cv_handle_type type, uint32_t tag, uint32_t capacity) {
    if (type == CV_HANDLE_NONE || type >= CV_HANDLE_TYPE_COUNT || tag == 0 || tag > CV_HANDLE_TAG_MAX ||
        capacity == 0 || capacity > CV_HANDLE_INDEX_MAX + 1)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "handle pool: bad type %d, context tag %u or capacity %u "
                        "(1..%u)", (int)type, tag, capacity, CV_HANDLE_INDEX_MAX + 1);
    pool->type = type;
    pool->tag = tag;
    pool->capacity = capacity;
    pool->live = 0;
    pool->generation = calloc(capacity, sizeof(uint32_t));
    pool->in_use = calloc(capacity, 1);
    pool->free_slots = malloc((size_t)capacity * sizeof(uint32_t));
    if (!pool->generation || !pool->in_use || !pool->free_slots) {
        cv_handle_pool_finish(pool);
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "handle pool of %u %s slots", capacity,
                        cv_handle_type_name(type));
    }
    /* Hand out low indices first: the stack's top is slot 0. */
    for (uint32_t i = 0; i < capacity; i++) {
        pool->generation[i] = 1;
        pool->free_slots[i] = capacity - 1 - i;
    }
    pool->free_count = capacity;
    return CV_OK;
}

void cv_handle_pool_finish(cv_handle_pool *pool) {
    free(pool->generation);
    free(pool->in_use);
    free(pool->free_slots);
    pool->generation = NULL;
    pool->in_use = NULL;
    pool->free_slots = NULL;
    pool->capacity = pool->free_count = pool->live = 0;
}

cv_result cv_handle_pool_alloc(cv_handle_pool *pool, uint64_t *out_id) {
    if (pool->free_count == 0)
        return cv_error(CV_ERROR_OUT_OF_HANDLES, "all %u %s handles are in use", pool->capacity,
                        cv_handle_type_name(pool->type));
    uint32_t index = pool->free_slots[--pool->free_count];
    pool->in_use[index] = 1;
    pool->live++;
    *out_id = cv_handle_pack(pool->type, pool->tag, pool->generation[index], index);
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
        return cv_error(CV_ERROR_FOREIGN_HANDLE, "%s handle 0x%016llx belongs to another context (its tag is %u, "
                        "this context's is %u)", cv_handle_type_name(pool->type), (unsigned long long)id,
                        cv_handle_tag(id), pool->tag);
    uint32_t index = cv_handle_index(id);
    if (index >= pool->capacity || cv_handle_generation(id) == 0)
        return cv_error(CV_ERROR_INVALID_HANDLE, "%s handle 0x%016llx: slot %u is out of range (%u slots)",
                        cv_handle_type_name(pool->type), (unsigned long long)id, index, pool->capacity);
    if (!pool->in_use[index] || pool->generation[index] != cv_handle_generation(id))
        return cv_error(CV_ERROR_STALE_HANDLE, "%s handle 0x%016llx is stale (slot %u is at generation %u%s)",
                        cv_handle_type_name(pool->type), (unsigned long long)id, index,
                        pool->generation[index], pool->in_use[index] ? "" : ", free");
    return CV_OK;
}

cv_result cv_handle_pool_free(cv_handle_pool *pool, uint64_t id) {
    cv_result r = cv_handle_pool_check(pool, id);
    if (r != CV_OK)
        return r;
    uint32_t index = cv_handle_index(id);
    pool->in_use[index] = 0;
    uint32_t next = (pool->generation[index] + 1) & CV_HANDLE_GENERATION_MAX;
    pool->generation[index] = next ? next : 1;
    pool->free_slots[pool->free_count++] = index;
    pool->live--;
    return CV_OK;
}

uint32_t cv_handle_pool_slot_generation(const cv_handle_pool *pool, uint32_t index) {
    return index < pool->capacity ? pool->generation[index] : 0;
}
