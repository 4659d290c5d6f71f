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
 *         cv_result r = cv_content_upload_begin(store, sha, size, &u);   (may wait, see Threads)
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
 * Folders are 0700 and files 0600 whatever the umask (uploads are the
 * clients' data); open brings an older store's folders and blob files to
 * those modes (the top folder only if this user owns it: it may be a volume
 * the operator made). A blob file appears only by rename() of a complete,
 * hash-checked temporary, so a blob is either absent or whole. Files are not
 * fsync()ed: after a crash a blob file may hold the wrong bytes, and the check
 * on first use (below) drops it. Each blob file's mtime is its last use
 * (stamped at most once a second while the store runs, exactly at close); a
 * restart rebuilds the LRU order from those times, exactly after a clean
 * close, to about a second after a crash.
 *
 * Trust in the files on disk: a blob is used only while its file is the one
 * whose content was hashed. The first use after the store was opened (has()
 * or get()) hashes a blob's file and compares it with its name; uploads are
 * hashed on arrival. The store then remembers the file's inode, size and
 * mtime (the mtime it stamps itself), and every has() and get() compares
 * them with a stat of the file (about a microsecond): a file written to (its
 * mtime changes) or replaced (its inode changes) is hashed again before it
 * is used, and a mismatch drops it (file removed, has() answers false, get()
 * CV_ERROR_NOT_FOUND), so the client uploads it again. A hash costs about
 * 1.5-2 GB/s with SHA instructions (docs/node.md, "Content store", has the
 * figures); a stamp is skipped for a changed file, which would hide the
 * change. Not caught: a change that restores the inode and the exact mtime
 * (a deliberate forgery by this user), and a change to a mapped blob's file
 * while it is pinned.
 *
 * Threads: every call may be made from any thread; one mutex guards the
 * index, and hashing, reading and writing blob bytes happen outside it. One
 * upload object is used by one thread at a time. Two uploads of one blob at
 * once: the second begin waits (up to the upload wait, 30 s by default) for
 * the first to end; it answers CV_ERROR_ALREADY_EXISTS if the first stored the
 * blob, and starts receiving the blob itself if the first was aborted (its
 * session ended, say). A waiter whose time runs out receives the blob beside
 * the first upload, each into its own temporary; the first to finish stores
 * it and the later one's finish discards its copy and succeeds. So a second
 * uploader never fails because of the first. A thread must not begin an
 * upload of a blob it is itself receiving (it would wait for itself until the
 * upload wait ran out).
 *
 * Space: an upload reserves its size at begin, evicting blobs then to make
 * room, so an upload that is accepted is never refused for space at finish.
 * The limit covers stored blobs plus reservations; pinned blobs (and blobs a
 * late second upload still refers to) are never evicted, so begin fails with
 * CV_ERROR_LIMIT_EXCEEDED when the rest cannot make room. A blob larger than
 * the whole limit is refused at once, CV_ERROR_LIMIT_EXCEEDED with a message
 * naming its size and the limit. */
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
    uint64_t bytes;      /* stored blobs, reservations of uploads not included */
    uint64_t entries;    /* stored blobs */
    uint64_t hits;       /* has() answered true */
    uint64_t misses;     /* has() answered false */
    uint64_t evictions;  /* blobs removed to make room */
    uint64_t uploads;    /* uploads finished and stored */
    uint64_t rejected;   /* uploads refused for size or room at begin, or failed at finish
                             (incomplete, content not matching the key, I/O) */
    uint64_t dropped;    /* blob files found damaged (or changed) on use and removed */
    uint64_t waits;      /* begins that waited for another upload of the same blob */
    uint64_t duplicates; /* uploads finished after another upload of the blob had stored it */
    uint64_t max_bytes;
} cv_content_stats;

#define CV_CONTENT_STORE_DEFAULT_MAX_BYTES (UINT64_C(1) << 30)
#define CV_CONTENT_STORE_DEFAULT_UPLOAD_WAIT_MS 30000u

/* Opens (creating) a store in `dir` with a size limit (0: 1 GiB). Indexes the
 * blobs already there, oldest use first; removes leftover temporaries and any
 * file under objects/ whose name is not a valid lowercase hash in its right
 * folder; evicts down to the limit if it shrank. CV_ERROR_BAD_STATE if another
 * open store (this process or another) holds the directory. */
cv_result cv_content_store_open(const char *dir, uint64_t max_bytes, cv_content_store **out);
/* Every blob must have been released and every upload finished or aborted. */
void cv_content_store_close(cv_content_store *s);
/* How long a begin waits, in all, for another upload of the same blob before
 * receiving it beside that one (0: at once) [CV_CONTENT_STORE_DEFAULT_UPLOAD_WAIT_MS]. */
void cv_content_store_set_upload_wait(cv_content_store *s, uint32_t wait_ms);

/* Whether the blob is stored and intact (hashed on its first use since open
 * and whenever its file changed since its last hash; a damaged one is dropped
 * and answered false). Counts a hit or a miss; a hit makes the blob the most
 * recently used. */
bool cv_content_store_has(cv_content_store *s, const uint8_t sha[32]);

/* Starts receiving a blob of `size` bytes (0 allowed). CV_ERROR_ALREADY_EXISTS
 * if stored (the caller skips the upload; counts as a use for the LRU). If
 * another upload is receiving it, waits (see "Threads" above): then
 * CV_ERROR_ALREADY_EXISTS if that one stored it, else this upload starts.
 * CV_ERROR_LIMIT_EXCEEDED if size > max_bytes ("blob <hash> of <size> bytes
 * is larger than the store's limit of <max> bytes") or pinned blobs and other
 * uploads leave no room. */
cv_result cv_content_upload_begin(cv_content_store *s, const uint8_t sha[32], uint64_t size, cv_content_upload **out);
/* Appends the next bytes: `offset` must equal the bytes received so far
 * (CV_ERROR_INVALID_ARGUMENT) and offset + len <= size (CV_ERROR_OUT_OF_RANGE).
 * On any error (CV_ERROR_IO included) the upload is unchanged and the same
 * chunk may be written again. */
cv_result cv_content_upload_write(cv_content_upload *u, uint64_t offset, const void *data, size_t len);
/* Completes the upload and frees `u`, whatever the result. All bytes must have
 * arrived (else CV_ERROR_BAD_STATE) and their SHA-256 must equal the key (else
 * CV_ERROR_HASH_MISMATCH, message with both hashes); on success the blob
 * becomes visible at once, as the most recently used (or, if a parallel
 * upload stored it first, this copy is discarded and the result is CV_OK
 * too). On failure nothing is stored and no temporary is left. */
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
