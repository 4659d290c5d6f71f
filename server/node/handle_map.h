/* A session's translation table: the client's handle ids to the node's own.
 *
 * A node never uses a client's handle values: each session creates its own
 * resources in its own context and keeps this map from the ids the client chose
 * to the handles the node made. A client id that is not in the map (another
 * session's, a stale one, an invented one) translates to nothing, so a client
 * can only ever reach what it created itself. Open addressing with linear
 * probing and backward-shift deletion (no tombstones), doubling at 1/2 load. */
#ifndef CORVID_NODE_HANDLE_MAP_H
#define CORVID_NODE_HANDLE_MAP_H

#include <stdbool.h>
#include <stdint.h>

#include "corvid/result.h"

typedef struct cv_handle_map_entry {
    uint64_t key;   /* client id; 0 = empty */
    uint64_t value; /* node id */
} cv_handle_map_entry;

typedef struct cv_handle_map {
    cv_handle_map_entry *entries;
    uint32_t capacity; /* power of two, or 0 */
    uint32_t count;
} cv_handle_map;

void cv_handle_map_init(cv_handle_map *m);
void cv_handle_map_finish(cv_handle_map *m);
/* 0 if key is absent. */
uint64_t cv_handle_map_get(const cv_handle_map *m, uint64_t key);
/* Adds key -> value (key absent, both non-zero); CV_ERROR_OUT_OF_MEMORY leaves the map as it was. */
cv_result cv_handle_map_put(cv_handle_map *m, uint64_t key, uint64_t value);
/* Removes key; false if it was absent. */
bool cv_handle_map_remove(cv_handle_map *m, uint64_t key);

#endif
