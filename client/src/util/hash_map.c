/* The open-addressing u64 -> u64 map (corvid/hash_map.h). */
#include "corvid/hash_map.h"

#include <stdlib.h>
#include <string.h>
#include <sys/random.h>

#include "corvid/clock.h"

enum { SLOT_EMPTY = 0, SLOT_LIVE, SLOT_TOMBSTONE };

#define MIN_CAPACITY 16u
#define MAX_CAPACITY (UINT32_C(1) << 31)

static uint32_t home(const cv_hash_map *m, uint64_t key) {
    key ^= m->seed;
    key ^= key >> 33; /* murmur3's 64-bit finaliser: ids differ mostly in their low bits */
    key *= UINT64_C(0xff51afd7ed558ccd);
    key ^= key >> 33;
    key *= UINT64_C(0xc4ceb9fe1a85ec53);
    key ^= key >> 33;
    return (uint32_t)key & (m->capacity - 1);
}

uint64_t cv_hash_map_random_seed(void) {
    uint64_t seed;
    if (getrandom(&seed, sizeof seed, GRND_NONBLOCK) != (ssize_t)sizeof seed)
        seed = cv_now_ns() * UINT64_C(0x2545f4914f6cdd1d);
    return seed;
}

void cv_hash_map_init(cv_hash_map *m, uint64_t seed) { *m = (cv_hash_map){ .seed = seed }; }

void cv_hash_map_finish(cv_hash_map *m) {
    free(m->slots);
    free(m->states);
    *m = (cv_hash_map){ .seed = m->seed };
}

void cv_hash_map_clear(cv_hash_map *m) {
    if (m->capacity)
        memset(m->states, 0, m->capacity);
    m->count = 0;
    m->tombstones = 0;
}

/* The slot holding key, or UINT32_MAX. */
static uint32_t find(const cv_hash_map *m, uint64_t key) {
    if (!m->capacity)
        return UINT32_MAX;
    uint32_t mask = m->capacity - 1;
    for (uint32_t i = home(m, key);; i = (i + 1) & mask) {
        if (m->states[i] == SLOT_EMPTY)
            return UINT32_MAX;
        if (m->states[i] == SLOT_LIVE && m->slots[i].key == key)
            return i;
    }
}

bool cv_hash_map_get(const cv_hash_map *m, uint64_t key, uint64_t *value) {
    uint32_t i = find(m, key);
    if (i == UINT32_MAX)
        return false;
    if (value)
        *value = m->slots[i].value;
    return true;
}

/* Puts an absent key into the first empty or tombstone slot of its probe run (room is assured). */
static void place(cv_hash_map *m, uint64_t key, uint64_t value) {
    uint32_t mask = m->capacity - 1, i = home(m, key);
    while (m->states[i] == SLOT_LIVE)
        i = (i + 1) & mask;
    if (m->states[i] == SLOT_TOMBSTONE)
        m->tombstones--;
    m->states[i] = SLOT_LIVE;
    m->slots[i] = (cv_hash_map_slot){ key, value };
    m->count++;
}

/* Rebuilds the array without tombstones, doubled if live entries fill more than a quarter of it. */
static cv_result rebuild(cv_hash_map *m) {
    uint32_t capacity = m->capacity ? m->capacity : MIN_CAPACITY;
    if ((uint64_t)(m->count + 1) * 4 > capacity)
        capacity *= 2;
    if (capacity > MAX_CAPACITY || capacity < m->capacity)
        return cv_error(CV_ERROR_LIMIT_EXCEEDED, "hash map: more than 2^29 entries");
    cv_hash_map_slot *slots = malloc((size_t)capacity * sizeof(*slots));
    uint8_t *states = calloc(capacity, 1);
    if (!slots || !states) {
        free(slots);
        free(states);
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "hash map of %u slots", capacity);
    }
    cv_hash_map old = *m;
    *m = (cv_hash_map){ .slots = slots, .states = states, .capacity = capacity, .seed = old.seed };
    for (uint32_t i = 0; i < old.capacity; i++)
        if (old.states[i] == SLOT_LIVE)
            place(m, old.slots[i].key, old.slots[i].value);
    free(old.slots);
    free(old.states);
    return CV_OK;
}

cv_result cv_hash_map_put(cv_hash_map *m, uint64_t key, uint64_t value) {
    uint32_t i = find(m, key);
    if (i != UINT32_MAX) {
        m->slots[i].value = value;
        return CV_OK;
    }
    if ((uint64_t)(m->count + m->tombstones + 1) * 2 > m->capacity) {
        cv_result r = rebuild(m);
        if (r != CV_OK)
            return r;
    }
    place(m, key, value);
    return CV_OK;
}

bool cv_hash_map_remove(cv_hash_map *m, uint64_t key, uint64_t *value) {
    uint32_t i = find(m, key);
    if (i == UINT32_MAX)
        return false;
    if (value)
        *value = m->slots[i].value;
    m->states[i] = SLOT_TOMBSTONE;
    m->count--;
    m->tombstones++;
    return true;
}

uint32_t cv_hash_map_count(const cv_hash_map *m) { return m->count; }

bool cv_hash_map_next(const cv_hash_map *m, uint32_t *cursor, uint64_t *key, uint64_t *value) {
    for (uint32_t i = *cursor; i < m->capacity; i++) {
        if (m->states[i] != SLOT_LIVE)
            continue;
        if (key)
            *key = m->slots[i].key;
        if (value)
            *value = m->slots[i].value;
        *cursor = i + 1;
        return true;
    }
    *cursor = m->capacity;
    return false;
}
