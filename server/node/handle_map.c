/* Client-to-node handle translation (handle_map.h). */
#include "handle_map.h"

#include <stdlib.h>

static uint32_t slot_for(uint64_t key, uint32_t capacity) {
    key ^= key >> 33; /* murmur3's 64-bit finaliser: ids differ mostly in low bits */
    key *= 0xff51afd7ed558ccdull;
    key ^= key >> 33;
    key *= 0xc4ceb9fe1a85ec53ull;
    key ^= key >> 33;
    return (uint32_t)key & (capacity - 1);
}

void cv_handle_map_init(cv_handle_map *m) { *m = (cv_handle_map){ 0 }; }

void cv_handle_map_finish(cv_handle_map *m) {
    free(m->entries);
    *m = (cv_handle_map){ 0 };
}

uint64_t cv_handle_map_get(const cv_handle_map *m, uint64_t key) {
    if (!key || !m->capacity)
        return 0;
    for (uint32_t i = slot_for(key, m->capacity);; i = (i + 1) & (m->capacity - 1)) {
        if (m->entries[i].key == key)
            return m->entries[i].value;
        if (m->entries[i].key == 0)
            return 0;
    }
}

static void insert(cv_handle_map_entry *entries, uint32_t capacity, uint64_t key, uint64_t value) {
    uint32_t i = slot_for(key, capacity);
    while (entries[i].key)
        i = (i + 1) & (capacity - 1);
    entries[i] = (cv_handle_map_entry){ key, value };
}

cv_result cv_handle_map_put(cv_handle_map *m, uint64_t key, uint64_t value) {
    if (!key || !value)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "handle map: zero key or value");
    if ((m->count + 1) * 2 > m->capacity) {
        uint32_t cap = m->capacity ? m->capacity * 2 : 64;
        if (cap < m->capacity)
            return cv_error(CV_ERROR_LIMIT_EXCEEDED, "handle map: more than 2^31 entries");
        cv_handle_map_entry *e = calloc(cap, sizeof(*e));
        if (!e)
            return cv_error(CV_ERROR_OUT_OF_MEMORY, "handle map of %u entries", cap);
        for (uint32_t i = 0; i < m->capacity; i++)
            if (m->entries[i].key)
                insert(e, cap, m->entries[i].key, m->entries[i].value);
        free(m->entries);
        m->entries = e;
        m->capacity = cap;
    }
    insert(m->entries, m->capacity, key, value);
    m->count++;
    return CV_OK;
}

bool cv_handle_map_remove(cv_handle_map *m, uint64_t key) {
    if (!key || !m->capacity)
        return false;
    uint32_t mask = m->capacity - 1, i = slot_for(key, m->capacity);
    while (m->entries[i].key != key) {
        if (m->entries[i].key == 0)
            return false;
        i = (i + 1) & mask;
    }
    /* Backward-shift: move later members of the probe run into the hole. */
    for (uint32_t j = (i + 1) & mask; m->entries[j].key; j = (j + 1) & mask) {
        uint32_t home = slot_for(m->entries[j].key, m->capacity);
        bool movable = i <= j ? (home <= i || home > j) : (home <= i && home > j);
        if (movable) {
            m->entries[i] = m->entries[j];
            i = j;
        }
    }
    m->entries[i] = (cv_handle_map_entry){ 0 };
    m->count--;
    return true;
}
