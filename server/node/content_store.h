/* The node's content-addressed upload cache.
 *
 * Clients upload bulk data (scene geometry, BVHs, textures) keyed by the
 * SHA-256 of its bytes. Before sending a blob a client asks whether the node
 * has it; if it has, nothing is sent. The store keeps blobs on disk under a
 * size limit shared by every session of the node, evicting the least recently
 * used blobs that nobody is reading, and finds them again after a restart.
 *
 *     if (!cv_content_store_has(store, sha)) {
 *         cv_content_upload *u;
 *         cv_result r = cv_content_upload_begin(store, sha, size, &u);
 *         if (r == CV_OK) {
 *             for (each chunk, in order)
 *                 r = cv_content_upload_write(u, offset, chunk, chunk_size);   (abort on error)
 *             r = cv_content_upload_finish(u);   (checks the hash; frees u)
 *         }   (CV_ERROR_ALREADY_EXISTS: someone stored it meanwhile, fine)
 *     }
 *     cv_content_blob *b;
 *     if (cv_content_store_get(store, sha, &b) == CV_OK) {
 *         use cv_content_blob_data(b), cv_content_blob_size(b);
 *         cv_content_blob_release(b);
 *     }
 *
 * On disk, under the store's directory:
 *   objects/<first 2 hex digits>/<64 hex digits>   one file per blob, its bytes
 *   tmp/<64 hex digits>.<n>                         uploads being received
 *   lock                                            flock()ed while a store is open
 * A blob file appears only by rename() of a complete, hash-checked temporary,
 * so a blob is either absent or whole. Files are not fsync()ed: after a crash
 * a blob file may hold the wrong bytes, and the check on first use (below)
 * drops it. Each blob file's mtime is its last use (stamped at most once a
 * second while the store runs, exactly at close); a restart rebuilds the LRU
 * order from those times, exactly after a clean close, to about a second
 * after a crash.
 *
 * Trust in the files on disk: a blob whose file does not have the size the
 * store indexed is dropped whenever it is used. The first time a blob is used
 * after the store was opened (has() or get()), its content is hashed and
 * compared with its name; a mismatch drops it (file removed, has() answers
 * false, get() CV_ERROR_NOT_FOUND). That costs one SHA-256 pass over each blob
 * that was on disk at open (about 1.5-2 GB/s with SHA instructions), paid once
 * per blob by the first has() or get() that touches it, not at open; blobs
 * uploaded since the open were hashed on arrival and are not hashed again.
 * Damage done to a file after that first check is caught only if it changes
 * the file's size.
 *
 * Threads: every call may be made from any thread; one mutex guards the
 * index, and hashing, reading and writing blob bytes happen outside it. One
 * upload object is used by one thread at a time. A blob is received by one
 * upload at a time: a second begin for a hash that another upload is
 * receiving fails with CV_ERROR_BAD_STATE at once (it does not wait); the
 * caller retries later or asks the client to, as the first upload may yet be
 * aborted.
 *
 * Space: an upload reserves its size at begin, evicting blobs then to make
 * room, so an upload that is accepted is never refused for space at finish.
 * The limit covers stored blobs plus reservations; pinned blobs are never
 * evicted, so begin fails with CV_ERROR_LIMIT_EXCEEDED when the rest cannot
 * make room. */
#ifndef CORVID_CONTENT_STORE_H
#define CORVID_CONTENT_STORE_H

#include <stdbool.h>
#include <stdint.h>
#include <stddef.h>

#include "corvid/result.h"

typedef struct cv_content_store cv_content_store;
typedef struct cv_content_upload cv_content_upload; /* one blob being received */
typedef struct cv_content_blob cv_content_blob;     /* a pinned, readable blob */

typedef struct cv_content_stats {
    uint64_t bytes;     /* stored blobs, reservations of uploads not included */
    uint64_t entries;   /* stored blobs */
    uint64_t hits;      /* has() answered true */
    uint64_t misses;    /* has() answered false */
    uint64_t evictions; /* blobs removed to make room */
    uint64_t uploads;   /* uploads finished and stored */
    uint64_t rejected;  /* uploads refused for size or room at begin, or failed at finish
                             (incomplete, content not matching the key, I/O) */
    uint64_t dropped;   /* blob files found damaged on use and removed */
    uint64_t max_bytes;
} cv_content_stats;

#define CV_CONTENT_STORE_DEFAULT_MAX_BYTES (UINT64_C(1) << 30)

/* Opens (creating) a store in `dir` with a size limit (0: 1 GiB). Indexes the
 * blobs already there, oldest use first; removes leftover temporaries and any
 * file under objects/ whose name is not a valid lowercase hash in its right
 * folder; evicts down to the limit if it shrank. CV_ERROR_BAD_STATE if another
 * open store (this process or another) holds the directory. */
cv_result cv_content_store_open(const char *dir, uint64_t max_bytes, cv_content_store **out);
/* Every blob must have been released and every upload finished or aborted. */
void cv_content_store_close(cv_content_store *s);

/* Whether the blob is stored (and, on its first use since open, intact).
 * Counts a hit or a miss; a hit makes the blob the most recently used. */
bool cv_content_store_has(cv_content_store *s, const uint8_t sha[32]);

/* Starts receiving a blob of `size` bytes (0 allowed). CV_ERROR_ALREADY_EXISTS
 * if stored (the caller skips the upload; counts as a use for the LRU);
 * CV_ERROR_BAD_STATE if another upload is receiving it; CV_ERROR_LIMIT_EXCEEDED
 * if size > max_bytes or pinned blobs and other uploads leave no room. */
cv_result cv_content_upload_begin(cv_content_store *s, const uint8_t sha[32], uint64_t size, cv_content_upload **out);
/* Appends the next bytes: `offset` must equal the bytes received so far
 * (CV_ERROR_INVALID_ARGUMENT) and offset + len <= size (CV_ERROR_OUT_OF_RANGE).
 * On any error (CV_ERROR_IO included) the upload is unchanged and the same
 * chunk may be written again. */
cv_result cv_content_upload_write(cv_content_upload *u, uint64_t offset, const void *data, size_t len);
/* Completes the upload and frees `u`, whatever the result. All bytes must have
 * arrived (else CV_ERROR_BAD_STATE) and their SHA-256 must equal the key (else
 * CV_ERROR_HASH_MISMATCH, message with both hashes); on success the blob
 * becomes visible at once, as the most recently used. On failure nothing is
 * stored and no temporary is left. */
cv_result cv_content_upload_finish(cv_content_upload *u);
/* Frees `u` and removes its temporary; nothing is stored. */
void cv_content_upload_abort(cv_content_upload *u);
uint64_t cv_content_upload_received(const cv_content_upload *u);

/* Pins a stored blob and makes its bytes readable: blobs up to 4 MiB are read
 * into memory, larger ones mmap()ed (unmapping a small mapping cost more than
 * reading it). While pinned it is neither evicted nor deleted. Makes it the
 * most recently used. CV_ERROR_NOT_FOUND if absent, still being uploaded, or
 * found damaged (then dropped); CV_ERROR_IO if its file could not be read. */
cv_result cv_content_store_get(cv_content_store *s, const uint8_t sha[32], cv_content_blob **out);
const void *cv_content_blob_data(const cv_content_blob *b);
uint64_t cv_content_blob_size(const cv_content_blob *b);
void cv_content_blob_release(cv_content_blob *b);

cv_content_stats cv_content_store_stats(cv_content_store *s);

#endif
