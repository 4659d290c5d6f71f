/* An open-addressing hash map from uint64_t keys to uint64_t values.
 *
 * The one hash table of the core: handle translation (a client's id to the
 * node's), content indexes (the first 8 bytes of a SHA-256 to an entry,
 * the caller comparing the full hash), any id -> index or id -> pointer table.
 * Every key is allowed, 0 and UINT64_MAX included; a value is whatever the
 * caller stores (an index, a handle, a pointer cast through uintptr_t).
 *
 * Linear probing over a power-of-two array; a removal leaves a tombstone so
 * that probe runs stay intact, and the array is rebuilt (tombstones dropped,
 * doubled when more than a quarter full of live entries) when live entries
 * and tombstones together would pass half of it. Keys are mixed with a seed
 * (murmur3's 64-bit finaliser of key ^ seed): a map whose keys a client
 * chooses takes a random seed, so that nobody can aim keys at one probe run.
 *
 *     cv_hash_map m;
 *     cv_hash_map_init(&m, cv_hash_map_random_seed());
 *     cv_result r = cv_hash_map_put(&m, client_id, node_id); (on failure the map is unchanged)
 *     uint64_t id;
 *     if (cv_hash_map_get(&m, client_id, &id))
 *         use(id);
 *     cv_hash_map_remove(&m, client_id, NULL);
 *     cv_hash_map_finish(&m);
 *
 * Not thread-safe: the owner locks. Iteration (cv_hash_map_next) sees each
 * entry once as long as the map is not changed meanwhile. */
#ifndef CORVID_HASH_MAP_H
#define CORVID_HASH_MAP_H

#include <stdbool.h>
#include <stdint.h>

#include "corvid/result.h"

typedef struct cv_hash_map_slot {
    uint64_t key;
    uint64_t value;
} cv_hash_map_slot;

typedef struct cv_hash_map {
    cv_hash_map_slot *slots;
    uint8_t *states;     /* per slot: empty, live or tombstone */
    uint32_t capacity;   /* power of two, or 0 before the first put */
    uint32_t count;      /* live entries */
    uint32_t tombstones; /* removed entries still in probe runs */
    uint64_t seed;
} cv_hash_map;

/* A seed nobody outside the process can guess (getrandom; the clock if that fails), for maps whose
 * keys come from clients. */
uint64_t cv_hash_map_random_seed(void);
/* An empty map (no allocation until the first put). */
void cv_hash_map_init(cv_hash_map *m, uint64_t seed);
/* Frees the map's memory; the map is empty and usable again. */
void cv_hash_map_finish(cv_hash_map *m);
/* Removes every entry and keeps the memory (for a map refilled again and again). */
void cv_hash_map_clear(cv_hash_map *m);
/* Whether key is present; its value into *value (may be NULL). */
bool cv_hash_map_get(const cv_hash_map *m, uint64_t key, uint64_t *value);
/* Sets key -> value, adding the key or replacing its value. CV_ERROR_OUT_OF_MEMORY or
 * CV_ERROR_LIMIT_EXCEEDED (2^29 entries) leave the map unchanged. */
cv_result cv_hash_map_put(cv_hash_map *m, uint64_t key, uint64_t value);
/* Removes key; false if it was absent. Its value into *value (may be NULL). */
bool cv_hash_map_remove(cv_hash_map *m, uint64_t key, uint64_t *value);
/* Live entries. */
uint32_t cv_hash_map_count(const cv_hash_map *m);
/* Iterates: *cursor = 0 first; true with the next entry's key and value (either may be NULL),
 * false at the end. */
bool cv_hash_map_next(const cv_hash_map *m, uint32_t *cursor, uint64_t *key, uint64_t *value);

#endif
