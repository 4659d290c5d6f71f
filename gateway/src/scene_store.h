/* The gateway's scene store: uploaded models by the SHA-256 of their bytes
 * (content-addressed, so a client asks first and never sends a known model
 * again), each parsed once on upload (a bad model is refused with the
 * loader's message) and kept parsed with its BVH for the jobs that render it.
 * Bounded: one upload at most max_scene_bytes, all of them at most
 * max_store_bytes (of upload bytes); the least recently used models no job
 * holds make room for a new one. Thread-safe. */
#ifndef CORVID_GATEWAY_SCENE_STORE_H
#define CORVID_GATEWAY_SCENE_STORE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "corvid/bvh.h"
#include "corvid/result.h"
#include "corvid/scene.h"
#include "corvid/sha256.h"

typedef struct gw_store gw_store;

/* A stored model; valid while a reference is held (gw_store_acquire .. gw_store_release). */
typedef struct gw_scene {
    char sha[CV_SHA256_HEX_SIZE];
    cv_scene *scene;
    cv_bvh *bvh;
    uint64_t bytes; /* of the upload */
} gw_scene;

cv_result gw_store_create(uint64_t max_scene_bytes, uint64_t max_store_bytes, const char *temp_dir, gw_store **out);
void gw_store_destroy(gw_store *s); /* every reference must have been released */

/* Stores a model: over max_scene_bytes is CV_ERROR_LIMIT_EXCEEDED; `expected_sha` (64 hex digits, or NULL to
 * take the body's) not the body's hash CV_ERROR_HASH_MISMATCH; a model the loader refuses CV_ERROR_MALFORMED
 * (or its code) with its message; no room left beside the models jobs hold CV_ERROR_OUT_OF_MEMORY. *created
 * is false when the model was known already. Parses without the store's lock held. */
cv_result gw_store_put(gw_store *s, const uint8_t *data, size_t size, const char *expected_sha,
                       char sha[CV_SHA256_HEX_SIZE], bool *created);

/* A reference to a stored model; CV_ERROR_NOT_FOUND naming the hash. */
cv_result gw_store_acquire(gw_store *s, const char *sha, const gw_scene **out);
void gw_store_release(gw_store *s, const gw_scene *scene);

/* Whether a model is stored, and its figures. */
bool gw_store_describe(gw_store *s, const char *sha, uint64_t *bytes, uint64_t *triangles);

#endif
