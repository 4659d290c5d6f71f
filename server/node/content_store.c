/* The content-addressed upload cache (see content_store.h).
 *
 * Index: every blob stored or being uploaded has an entry, found by its hash
 * in a cv_hash_map from the hash's first 8 bytes (seeded per store at random
 * so that clients choosing hashes cannot pile them onto one probe run); the
 * rare hashes that share those bytes are chained from the entry the map
 * holds, and compared in full. Stored entries are also on a doubly linked LRU list,
 * newest first. An entry leaves the table when its blob is evicted, dropped
 * or its uploads end without storing it; a dropped entry that is still pinned
 * (or that a late second upload refers to) lives on, outside the table, until
 * the last of those lets go. */
#include "content_store.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <inttypes.h>
#include <limits.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/file.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "corvid/clock.h"
#include "corvid/hash_map.h"
#include "corvid/log.h"
#include "corvid/sha256.h"

#define OBJECT_NAME_SIZE (3 + CV_SHA256_HEX_SIZE) /* "xx/" + 64 digits + NUL */
#define TEMP_NAME_SIZE (CV_SHA256_HEX_SIZE + 24)  /* 64 digits + ".<n>" + NUL */

typedef enum entry_state {
    ENTRY_UPLOADING, /* in the table, not on the LRU list; each upload reserves its own size */
    ENTRY_STORED,    /* in the table and on the LRU list, its size in bytes */
    ENTRY_DROPPED,   /* found damaged while held: in neither, freed when no pin or upload holds it */
} entry_state;

typedef struct entry {
    uint8_t sha[32];
    uint64_t size;                /* once stored */
    struct timespec used;         /* last use */
    struct timespec used_on_disk; /* the blob file's mtime: `used`, or up to a second older */
    uint32_t pins;
    uint32_t uploaders; /* uploads receiving this blob: one, or more after a waiter gave up waiting */
    entry_state state;
    /* The content was hashed, and the file then was this inode with mtime
     * used_on_disk: a file that still is needs no new hash. */
    bool verified;
    dev_t dev;
    ino_t ino;
    struct entry *newer, *older; /* LRU list */
    struct entry *same_key;      /* the next entry whose hash starts with the same 8 bytes */
} entry;

struct cv_content_store {
    pthread_mutex_t lock;
    pthread_cond_t upload_ended; /* broadcast whenever an upload ends: its waiters look again */
    uint32_t upload_wait_ms;
    int dir_fd, objects_fd, tmp_fd, lock_fd;
    uint64_t max_bytes;
    uint64_t reserved; /* sizes of uploads in progress */
    cv_hash_map table; /* the first 8 bytes of a hash -> entry * (the head of its same_key chain) */
    entry *newest, *oldest;
    struct timespec last_stamp; /* uses get strictly increasing times */
    uint64_t temp_counter;
    uint32_t live_uploads, live_blobs;
    cv_content_stats stats;
};

struct cv_content_upload {
    cv_content_store *store;
    entry *entry;
    uint64_t size; /* this upload's: a second upload of the entry may claim another */
    uint64_t received;
    int fd;
    cv_sha256_ctx sha;
    char temp_name[TEMP_NAME_SIZE];
};

struct cv_content_blob {
    cv_content_store *store;
    entry *entry;
    const void *data;
    uint64_t size;
};

/* ---- names ---- */

static void object_name(const uint8_t sha[32], char out[OBJECT_NAME_SIZE]) {
    char hex[CV_SHA256_HEX_SIZE];
    cv_sha256_hex(sha, hex);
    snprintf(out, OBJECT_NAME_SIZE, "%.2s/%s", hex, hex);
}

static bool is_lower_hex(const char *s, size_t n) {
    for (size_t i = 0; i < n; i++) {
        if (!((s[i] >= '0' && s[i] <= '9') || (s[i] >= 'a' && s[i] <= 'f')))
            return false;
    }
    return s[n] == '\0';
}

/* ---- hash table ---- */

static uint64_t table_key(const uint8_t sha[32]) {
    uint64_t k;
    memcpy(&k, sha, sizeof k);
    return k;
}

static entry *table_head(const cv_content_store *s, uint64_t key) {
    uint64_t value;
    return cv_hash_map_get(&s->table, key, &value) ? (entry *)(uintptr_t)value : NULL;
}

static entry *table_find(const cv_content_store *s, const uint8_t sha[32]) {
    entry *e = table_head(s, table_key(sha));
    while (e && memcmp(e->sha, sha, 32) != 0)
        e = e->same_key;
    return e;
}

/* False when out of memory (nothing changed). */
static bool table_insert(cv_content_store *s, entry *e) {
    uint64_t key = table_key(e->sha);
    e->same_key = table_head(s, key);
    return cv_hash_map_put(&s->table, key, (uint64_t)(uintptr_t)e) == CV_OK;
}

static void table_remove(cv_content_store *s, entry *e) {
    uint64_t key = table_key(e->sha);
    entry *head = table_head(s, key);
    if (head == e && e->same_key)
        cv_hash_map_put(&s->table, key, (uint64_t)(uintptr_t)e->same_key); /* a present key: cannot fail */
    else if (head == e)
        cv_hash_map_remove(&s->table, key, NULL);
    for (entry *at = head; at && at != e; at = at->same_key)
        if (at->same_key == e)
            at->same_key = e->same_key;
    e->same_key = NULL;
}

/* ---- LRU list and use times ---- */

static void lru_unlink(cv_content_store *s, entry *e) {
    *(e->newer ? &e->newer->older : &s->newest) = e->older;
    *(e->older ? &e->older->newer : &s->oldest) = e->newer;
    e->newer = e->older = NULL;
}

static void lru_push_newest(cv_content_store *s, entry *e) {
    e->newer = NULL;
    e->older = s->newest;
    *(s->newest ? &s->newest->newer : &s->oldest) = e;
    s->newest = e;
}

static struct timespec next_stamp(cv_content_store *s) {
    struct timespec now;
    clock_gettime(CLOCK_REALTIME, &now);
    struct timespec last = s->last_stamp;
    if (now.tv_sec < last.tv_sec || (now.tv_sec == last.tv_sec && now.tv_nsec <= last.tv_nsec)) {
        now = last;
        if (++now.tv_nsec == 1000000000) {
            now.tv_sec++;
            now.tv_nsec = 0;
        }
    }
    s->last_stamp = now;
    return now;
}

/* ---- file identity ---- */

/* What a blob's file was when its content was last hashed. A write changes
 * the file's mtime and a replacement its inode, so a file that still matches
 * needs no new hash; one that does not is hashed again before it is used. */
typedef struct file_id {
    bool hashed;
    dev_t dev;
    ino_t ino;
    uint64_t size;
    struct timespec mtime;
} file_id;

static file_id entry_file(const entry *e) {
    file_id f = { .hashed = e->verified, .dev = e->dev, .ino = e->ino, .size = e->size, .mtime = e->used_on_disk };
    return f;
}

static bool is_file(const file_id *f, const struct stat *st) {
    return f->hashed && st->st_dev == f->dev && st->st_ino == f->ino && (uint64_t)st->st_size == f->size &&
           st->st_mtim.tv_sec == f->mtime.tv_sec && st->st_mtim.tv_nsec == f->mtime.tv_nsec;
}

/* The entry's content was hashed from the file `st` describes. */
static void record_hashed(entry *e, const struct stat *st) {
    e->verified = true;
    e->dev = st->st_dev;
    e->ino = st->st_ino;
    e->used_on_disk = st->st_mtim;
}

/* Whether the file is still the one last hashed (a stat, lock held). */
static bool file_unchanged(cv_content_store *s, const entry *e) {
    char name[OBJECT_NAME_SIZE];
    object_name(e->sha, name);
    file_id known = entry_file(e);
    struct stat st;
    return fstatat(s->objects_fd, name, &st, AT_SYMLINK_NOFOLLOW) == 0 && is_file(&known, &st);
}

/* Sets the file's mtime to the last use. A file changed since its hash is
 * left alone and hashed on its next use: stamping it would hide the change. */
static void stamp_file(cv_content_store *s, entry *e) {
    if (e->verified && !file_unchanged(s, e)) {
        e->verified = false;
        return;
    }
    char name[OBJECT_NAME_SIZE];
    object_name(e->sha, name);
    struct timespec times[2] = { e->used, e->used };
    if (utimensat(s->objects_fd, name, times, 0) == 0)
        e->used_on_disk = e->used;
}

/* Records a use, in memory and, for the order after a restart, as the file's
 * mtime. Setting the mtime is a metadata write (tens of microseconds in the
 * test VM), so a file is stamped at most once a second while the store runs
 * and brought up to date at close: a clean restart keeps the exact order, a
 * crash loses the order of uses less than a second apart. The newest blob is
 * already the newest: nothing to record. */
static void touch(cv_content_store *s, entry *e) {
    if (s->newest == e)
        return;
    lru_unlink(s, e);
    lru_push_newest(s, e);
    e->used = next_stamp(s);
    if (e->used.tv_sec > e->used_on_disk.tv_sec + 1 ||
        (e->used.tv_sec == e->used_on_disk.tv_sec + 1 && e->used.tv_nsec >= e->used_on_disk.tv_nsec))
        stamp_file(s, e);
}

/* ---- removal ---- */

static void remove_stored(cv_content_store *s, entry *e) {
    char name[OBJECT_NAME_SIZE];
    object_name(e->sha, name);
    unlinkat(s->objects_fd, name, 0);
    lru_unlink(s, e);
    table_remove(s, e);
    s->stats.bytes -= e->size;
    s->stats.entries--;
}

/* A damaged blob: gone from disk and index at once, the entry itself freed
 * by the last unpin. */
static void drop(cv_content_store *s, entry *e) {
    if (e->state != ENTRY_STORED)
        return;
    remove_stored(s, e);
    e->state = ENTRY_DROPPED;
    s->stats.dropped++;
}

/* A dropped entry lives until no pin and no upload holds it. */
static void free_if_unheld(entry *e) {
    if (e->state == ENTRY_DROPPED && e->pins == 0 && e->uploaders == 0)
        free(e);
}

static void unpin(entry *e) {
    e->pins--;
    free_if_unheld(e);
}

/* Evicts least recently used unpinned blobs until `need` more bytes fit.
 * False (after evicting what it could) if pinned blobs and reservations leave
 * no room. */
static bool make_room(cv_content_store *s, uint64_t need) {
    entry *e = s->oldest;
    while (s->stats.bytes + s->reserved + need > s->max_bytes) {
        while (e && (e->pins || e->uploaders)) /* uploaders: a late second upload still points at it */
            e = e->newer;
        if (e == NULL)
            return false;
        entry *victim = e;
        e = e->newer;
        remove_stored(s, victim);
        s->stats.evictions++;
        free(victim);
    }
    return true;
}

/* ---- reading blob files ---- */

typedef enum read_outcome { READ_OK, READ_DAMAGED, READ_FAILED } read_outcome;

/* Blobs up to this size are read into memory, larger ones mapped: unmapping
 * costs a TLB flush (an inter-processor interrupt per CPU the process ran on,
 * dear in a VM) and a page fault per page, which made get() of a 64 KiB blob
 * twenty times slower than read() on the test machine (bench_content_store). */
#define READ_INTO_MEMORY_MAX (UINT64_C(4) << 20)

static bool is_mapped(uint64_t size) { return size > READ_INTO_MEMORY_MAX; }

static void unload_blob(const void *data, uint64_t size) {
    if (is_mapped(size))
        munmap((void *)data, (size_t)size);
    else
        free((void *)data);
}

static read_outcome read_fd(int fd, uint64_t size, const char *hex, void **out) {
    if (size == 0) {
        *out = NULL;
        return READ_OK;
    }
    if (is_mapped(size)) {
        void *map = mmap(NULL, (size_t)size, PROT_READ, MAP_SHARED | MAP_POPULATE, fd, 0);
        if (map == MAP_FAILED) {
            cv_error(CV_ERROR_IO, "content store: blob %s: mmap of %" PRIu64 " bytes: %s", hex, size,
                     strerror(errno));
            return READ_FAILED;
        }
        *out = map;
        return READ_OK;
    }
    uint8_t *buffer = malloc((size_t)size);
    if (buffer == NULL) {
        cv_error(CV_ERROR_OUT_OF_MEMORY, "content store: blob %s: buffer of %" PRIu64 " bytes", hex, size);
        return READ_FAILED;
    }
    for (uint64_t done = 0; done < size;) {
        ssize_t n = pread(fd, buffer + done, (size_t)(size - done), (off_t)done);
        if (n < 0 && errno == EINTR)
            continue;
        if (n <= 0) {
            free(buffer);
            if (n == 0) {
                cv_error(CV_ERROR_NOT_FOUND,
                         "content store: blob %s: file ends at %" PRIu64 " of %" PRIu64 " bytes; dropped", hex, done,
                         size);
                return READ_DAMAGED;
            }
            cv_error(CV_ERROR_IO, "content store: blob %s: read: %s", hex, strerror(errno));
            return READ_FAILED;
        }
        done += (uint64_t)n;
    }
    *out = buffer;
    return READ_OK;
}

/* Loads a pinned entry's file (outside the lock), checking its size and,
 * unless the file is still `known` (what it was at its last hash, read under
 * the lock), its hash. *seen: the file's stat; *hashed: whether it was
 * hashed (and matched). *data is NULL for an empty blob; unload_blob frees it. */
static read_outcome load_blob(cv_content_store *s, const entry *e, const file_id *known, const void **data,
                              struct stat *seen, bool *hashed) {
    char name[OBJECT_NAME_SIZE], hex[CV_SHA256_HEX_SIZE];
    object_name(e->sha, name);
    cv_sha256_hex(e->sha, hex);
    *data = NULL;
    int fd = openat(s->objects_fd, name, O_RDONLY | O_CLOEXEC);
    if (fd < 0) {
        if (errno == ENOENT) {
            cv_error(CV_ERROR_NOT_FOUND, "content store: blob %s: its file is gone", hex);
            return READ_DAMAGED;
        }
        cv_error(CV_ERROR_IO, "content store: blob %s: open: %s", hex, strerror(errno));
        return READ_FAILED;
    }
    struct stat st;
    *hashed = false;
    if (fstat(fd, &st) != 0) {
        cv_error(CV_ERROR_IO, "content store: blob %s: fstat: %s", hex, strerror(errno));
        close(fd);
        return READ_FAILED;
    }
    if ((uint64_t)st.st_size != e->size) {
        cv_error(CV_ERROR_NOT_FOUND,
                 "content store: blob %s: file has %" PRIu64 " bytes, indexed with %" PRIu64 "; dropped", hex,
                 (uint64_t)st.st_size, e->size);
        close(fd);
        return READ_DAMAGED;
    }
    void *bytes;
    read_outcome m = read_fd(fd, e->size, hex, &bytes);
    close(fd);
    if (m != READ_OK)
        return m;
    *seen = st;
    if (!is_file(known, &st)) {
        uint8_t actual[32];
        m = cv_sha256(bytes, (size_t)e->size, actual) == CV_OK ? READ_OK : READ_FAILED;
        if (m == READ_OK && memcmp(actual, e->sha, 32) != 0) {
            char actual_hex[CV_SHA256_HEX_SIZE];
            cv_sha256_hex(actual, actual_hex);
            cv_error(CV_ERROR_NOT_FOUND, "content store: blob %s: file content hashes to %s; dropped", hex,
                     actual_hex);
            m = READ_DAMAGED;
        }
        if (m != READ_OK) {
            unload_blob(bytes, e->size);
            return m;
        }
        *hashed = true;
    }
    *data = bytes;
    return READ_OK;
}

/* ---- open and close ---- */

typedef struct found_blob {
    uint8_t sha[32];
    uint64_t size;
    struct timespec mtime;
} found_blob;

static int older_first(const void *a, const void *b) {
    const found_blob *x = a, *y = b;
    if (x->mtime.tv_sec != y->mtime.tv_sec)
        return x->mtime.tv_sec < y->mtime.tv_sec ? -1 : 1;
    if (x->mtime.tv_nsec != y->mtime.tv_nsec)
        return x->mtime.tv_nsec < y->mtime.tv_nsec ? -1 : 1;
    return memcmp(x->sha, y->sha, 32);
}

/* The store's folders are 0700 and its files 0600, whatever the umask:
 * uploaded scenes are the clients' data, not the machine's. Folders and blob
 * files of an older store are brought to those modes at open. */
static cv_result make_private(int fd, mode_t mode, const char *dir, const char *name) {
    struct stat st;
    if (fstat(fd, &st) != 0)
        return cv_error(CV_ERROR_IO, "content store '%s': stat %s: %s", dir, name, strerror(errno));
    if ((st.st_mode & 07777) != mode && fchmod(fd, mode) != 0)
        return cv_error(CV_ERROR_IO, "content store '%s': chmod %04o %s: %s", dir, (unsigned)mode, name,
                        strerror(errno));
    return CV_OK;
}

/* Creates (0700) and opens a folder; *out < 0 is closed by the caller. */
static cv_result open_subdir(int parent, const char *dir, const char *name, int *out) {
    if (mkdirat(parent, name, 0700) != 0 && errno != EEXIST)
        return cv_error(CV_ERROR_IO, "content store '%s': mkdir %s: %s", dir, name, strerror(errno));
    *out = openat(parent, name, O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
    if (*out < 0)
        return cv_error(CV_ERROR_IO, "content store '%s': open %s: %s", dir, name, strerror(errno));
    return make_private(*out, 0700, dir, name);
}

/* Removes a file or an empty folder; a folder with something in it stays. */
static void remove_stray(int parent, const char *name) {
    if (unlinkat(parent, name, 0) != 0 && (errno == EISDIR || errno == EPERM))
        unlinkat(parent, name, AT_REMOVEDIR);
}

/* Leftover temporaries: uploads that a previous run never finished. */
static cv_result clean_temporaries(cv_content_store *s, const char *dir) {
    int fd = dup(s->tmp_fd);
    DIR *d = fd < 0 ? NULL : fdopendir(fd);
    if (d == NULL) {
        if (fd >= 0)
            close(fd);
        return cv_error(CV_ERROR_IO, "content store '%s': reading tmp/: %s", dir, strerror(errno));
    }
    for (struct dirent *de = readdir(d); de; de = readdir(d)) {
        if (strcmp(de->d_name, ".") != 0 && strcmp(de->d_name, "..") != 0)
            remove_stray(s->tmp_fd, de->d_name);
    }
    closedir(d);
    return CV_OK;
}

static bool push_found(found_blob **list, size_t *count, size_t *capacity, const found_blob *b) {
    if (*count == *capacity) {
        size_t grown_capacity = *capacity ? *capacity * 2 : 256;
        found_blob *grown = realloc(*list, grown_capacity * sizeof *grown);
        if (grown == NULL)
            return false;
        *list = grown;
        *capacity = grown_capacity;
    }
    (*list)[(*count)++] = *b;
    return true;
}

/* Lists objects/<xx>/<hash> files, removing whatever else is there. */
static cv_result scan_objects(cv_content_store *s, const char *dir, found_blob **list, size_t *count) {
    size_t capacity = 0;
    int fd = dup(s->objects_fd);
    DIR *top = fd < 0 ? NULL : fdopendir(fd);
    if (top == NULL) {
        if (fd >= 0)
            close(fd);
        return cv_error(CV_ERROR_IO, "content store '%s': reading objects/: %s", dir, strerror(errno));
    }
    cv_result r = CV_OK;
    for (struct dirent *de = readdir(top); de && r == CV_OK; de = readdir(top)) {
        const char *prefix = de->d_name;
        if (strcmp(prefix, ".") == 0 || strcmp(prefix, "..") == 0)
            continue;
        int sub_fd = is_lower_hex(prefix, 2) ? openat(s->objects_fd, prefix, O_RDONLY | O_DIRECTORY | O_CLOEXEC) : -1;
        DIR *sub = sub_fd < 0 ? NULL : fdopendir(sub_fd);
        if (sub == NULL) {
            if (sub_fd >= 0)
                close(sub_fd);
            remove_stray(s->objects_fd, prefix);
            continue;
        }
        for (struct dirent *fe = readdir(sub); fe; fe = readdir(sub)) {
            const char *name = fe->d_name;
            if (strcmp(name, ".") == 0 || strcmp(name, "..") == 0)
                continue;
            found_blob b;
            struct stat st;
            bool valid = is_lower_hex(name, 64) && memcmp(name, prefix, 2) == 0 && cv_sha256_parse_hex(name, b.sha) &&
                         fstatat(sub_fd, name, &st, AT_SYMLINK_NOFOLLOW) == 0 && S_ISREG(st.st_mode);
            if (!valid) {
                remove_stray(sub_fd, name);
                continue;
            }
            if ((st.st_mode & 07777) != 0600 && fchmodat(sub_fd, name, 0600, 0) != 0) {
                r = cv_error(CV_ERROR_IO, "content store '%s': chmod 0600 objects/%s/%s: %s", dir, prefix, name,
                             strerror(errno));
                break;
            }
            b.size = (uint64_t)st.st_size;
            b.mtime = st.st_mtim;
            if (!push_found(list, count, &capacity, &b)) {
                r = cv_error(CV_ERROR_OUT_OF_MEMORY, "content store '%s': index of %zu blobs", dir, *count);
                break;
            }
        }
        closedir(sub);
    }
    closedir(top);
    return r;
}

static cv_result index_objects(cv_content_store *s, const char *dir) {
    found_blob *found = NULL;
    size_t count = 0;
    cv_result r = scan_objects(s, dir, &found, &count);
    if (r == CV_OK && count > 0)
        qsort(found, count, sizeof *found, older_first);
    for (size_t i = 0; i < count && r == CV_OK; i++) {
        entry *e = calloc(1, sizeof *e);
        if (e) {
            memcpy(e->sha, found[i].sha, 32);
            e->size = found[i].size;
            e->used = e->used_on_disk = found[i].mtime;
            e->state = ENTRY_STORED;
        }
        if (e == NULL || !table_insert(s, e)) {
            free(e);
            r = cv_error(CV_ERROR_OUT_OF_MEMORY, "content store '%s': index of %zu blobs", dir, count);
            break;
        }
        lru_push_newest(s, e);
        s->stats.bytes += e->size;
        s->stats.entries++;
        s->last_stamp = e->used;
    }
    free(found);
    return r;
}

static void free_store(cv_content_store *s) {
    uint32_t cursor = 0;
    uint64_t value;
    while (cv_hash_map_next(&s->table, &cursor, NULL, &value)) {
        for (entry *e = (entry *)(uintptr_t)value, *next; e; e = next) {
            next = e->same_key;
            free(e);
        }
    }
    cv_hash_map_finish(&s->table);
    int fds[] = { s->tmp_fd, s->objects_fd, s->dir_fd, s->lock_fd }; /* closing lock_fd unlocks */
    for (size_t i = 0; i < sizeof fds / sizeof fds[0]; i++) {
        if (fds[i] >= 0)
            close(fds[i]);
    }
    pthread_cond_destroy(&s->upload_ended);
    pthread_mutex_destroy(&s->lock);
    free(s);
}

/* objects/<xx>, 0700, in two system calls (a store opens 256 of them):
 * anything there that is not a folder is scan_objects' to remove. */
static cv_result make_prefix_dir(int objects_fd, const char *dir, const char *name) {
    struct stat st;
    bool made = mkdirat(objects_fd, name, 0700) == 0;
    if (!made && errno != EEXIST)
        return cv_error(CV_ERROR_IO, "content store '%s': mkdir objects/%s: %s", dir, name, strerror(errno));
    if (!made && (fstatat(objects_fd, name, &st, AT_SYMLINK_NOFOLLOW) != 0 || !S_ISDIR(st.st_mode) ||
                  (st.st_mode & 07777) == 0700))
        return CV_OK;
    if (fchmodat(objects_fd, name, 0700, 0) != 0) /* made: the umask may have taken bits off */
        return cv_error(CV_ERROR_IO, "content store '%s': chmod 0700 objects/%s: %s", dir, name, strerror(errno));
    return CV_OK;
}

static cv_result open_dirs(cv_content_store *s, const char *dir) {
    if (mkdir(dir, 0700) != 0 && errno != EEXIST)
        return cv_error(CV_ERROR_IO, "content store '%s': mkdir: %s", dir, strerror(errno));
    s->dir_fd = open(dir, O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (s->dir_fd < 0)
        return cv_error(CV_ERROR_IO, "content store '%s': open: %s", dir, strerror(errno));
    /* The top folder may be one the operator made (a volume, owned by
     * someone else): it is made 0700 only if this user owns it; objects/ and
     * tmp/, always the store's own, are 0700 in any case. */
    struct stat st;
    cv_result r = CV_OK;
    if (fstat(s->dir_fd, &st) == 0 && st.st_uid == geteuid())
        r = make_private(s->dir_fd, 0700, dir, ".");
    s->lock_fd = r == CV_OK ? openat(s->dir_fd, "lock", O_RDWR | O_CREAT | O_NOFOLLOW | O_CLOEXEC, 0600) : -1;
    if (r == CV_OK && s->lock_fd < 0)
        return cv_error(CV_ERROR_IO, "content store '%s': open lock: %s", dir, strerror(errno));
    if (r == CV_OK)
        r = make_private(s->lock_fd, 0600, dir, "lock");
    if (r != CV_OK)
        return r;
    if (flock(s->lock_fd, LOCK_EX | LOCK_NB) != 0) {
        if (errno == EWOULDBLOCK)
            return cv_error(CV_ERROR_BAD_STATE, "content store '%s': already open (by this or another process)", dir);
        return cv_error(CV_ERROR_IO, "content store '%s': flock: %s", dir, strerror(errno));
    }
    r = open_subdir(s->dir_fd, dir, "objects", &s->objects_fd);
    if (r == CV_OK)
        r = open_subdir(s->dir_fd, dir, "tmp", &s->tmp_fd);
    for (unsigned i = 0; i < 256 && r == CV_OK; i++) {
        char name[3];
        snprintf(name, sizeof name, "%02x", i);
        r = make_prefix_dir(s->objects_fd, dir, name);
    }
    return r;
}

cv_result cv_content_store_open(const char *dir, uint64_t max_bytes, cv_content_store **out) {
    if (dir == NULL || dir[0] == '\0' || out == NULL)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "content store: open needs a directory and an out pointer");
    cv_content_store *s = calloc(1, sizeof *s);
    if (s == NULL)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "content store '%s'", dir);
    pthread_mutex_init(&s->lock, NULL);
    cv_cond_init(&s->upload_ended); /* waits must not jump with the wall clock */
    s->upload_wait_ms = CV_CONTENT_STORE_DEFAULT_UPLOAD_WAIT_MS;
    s->dir_fd = s->objects_fd = s->tmp_fd = s->lock_fd = -1;
    s->max_bytes = max_bytes ? max_bytes : CV_CONTENT_STORE_DEFAULT_MAX_BYTES;
    s->stats.max_bytes = s->max_bytes;
    cv_hash_map_init(&s->table, cv_hash_map_random_seed());

    /* Steps: folders and the lock; discard unfinished uploads; index the blobs
     * (oldest use first); shrink to the limit; start use times after the newest. */
    cv_result r = open_dirs(s, dir);
    if (r == CV_OK)
        r = clean_temporaries(s, dir);
    if (r == CV_OK)
        r = index_objects(s, dir);
    if (r != CV_OK) {
        free_store(s);
        return r;
    }
    make_room(s, 0);
    next_stamp(s);
    *out = s;
    return CV_OK;
}

void cv_content_store_close(cv_content_store *s) {
    if (s == NULL)
        return;
    if (s->live_uploads || s->live_blobs)
        cv_log(CV_LOG_WARNING, "node", "content store closed with %u uploads and %u pinned blobs still open",
               s->live_uploads, s->live_blobs);
    for (entry *e = s->newest; e; e = e->older) {
        if (e->used.tv_sec != e->used_on_disk.tv_sec || e->used.tv_nsec != e->used_on_disk.tv_nsec)
            stamp_file(s, e);
    }
    free_store(s);
}

/* ---- queries ---- */

bool cv_content_store_has(cv_content_store *s, const uint8_t sha[32]) {
    pthread_mutex_lock(&s->lock);
    entry *e = table_find(s, sha);
    if (e == NULL || e->state != ENTRY_STORED) {
        s->stats.misses++;
        pthread_mutex_unlock(&s->lock);
        return false;
    }
    if (e->verified && file_unchanged(s, e)) {
        touch(s, e);
        s->stats.hits++;
        pthread_mutex_unlock(&s->lock);
        return true;
    }
    e->pins++;
    pthread_mutex_unlock(&s->lock);

    /* Not hashed since the open, or changed on disk since: hash it now, so
     * that a damaged blob is answered absent and the client uploads it. */
    const void *data;
    struct stat seen;
    bool hashed;
    file_id unknown = { .hashed = false };
    read_outcome m = load_blob(s, e, &unknown, &data, &seen, &hashed);
    if (m == READ_OK)
        unload_blob(data, e->size);

    pthread_mutex_lock(&s->lock);
    /* A check that could not run (no memory, no descriptors) proves nothing
     * either way: the blob counts as present and get() checks it again. */
    bool present = m != READ_DAMAGED && e->state == ENTRY_STORED;
    if (m == READ_OK && e->state == ENTRY_STORED)
        record_hashed(e, &seen);
    else if (m == READ_DAMAGED)
        drop(s, e);
    if (present) {
        touch(s, e);
        s->stats.hits++;
    } else {
        s->stats.misses++;
    }
    unpin(e);
    pthread_mutex_unlock(&s->lock);
    return present;
}

cv_result cv_content_store_get(cv_content_store *s, const uint8_t sha[32], cv_content_blob **out) {
    if (s == NULL || sha == NULL || out == NULL)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "content store: get needs a store, a hash and an out pointer");
    cv_content_blob *b = malloc(sizeof *b);
    if (b == NULL)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "content store: blob handle");
    char hex[CV_SHA256_HEX_SIZE];
    pthread_mutex_lock(&s->lock);
    entry *e = table_find(s, sha);
    if (e == NULL || e->state != ENTRY_STORED) {
        bool uploading = e != NULL;
        pthread_mutex_unlock(&s->lock);
        free(b);
        cv_sha256_hex(sha, hex);
        return cv_error(CV_ERROR_NOT_FOUND, "content store: blob %s %s", hex,
                        uploading ? "is still being uploaded" : "is not stored");
    }
    e->pins++;
    touch(s, e);
    file_id known = entry_file(e);
    pthread_mutex_unlock(&s->lock);

    const void *data;
    struct stat seen;
    bool hashed;
    read_outcome m = load_blob(s, e, &known, &data, &seen, &hashed);

    pthread_mutex_lock(&s->lock);
    if (m == READ_OK) {
        if (hashed && e->state == ENTRY_STORED)
            record_hashed(e, &seen);
        s->live_blobs++;
    } else {
        if (m == READ_DAMAGED)
            drop(s, e);
        unpin(e);
    }
    pthread_mutex_unlock(&s->lock);
    if (m != READ_OK) {
        free(b);
        return m == READ_DAMAGED ? CV_ERROR_NOT_FOUND : CV_ERROR_IO; /* map_blob set the message */
    }
    *b = (cv_content_blob){ .store = s, .entry = e, .data = data ? data : "", .size = e->size };
    *out = b;
    return CV_OK;
}

const void *cv_content_blob_data(const cv_content_blob *b) { return b->data; }

uint64_t cv_content_blob_size(const cv_content_blob *b) { return b->size; }

void cv_content_blob_release(cv_content_blob *b) {
    if (b == NULL)
        return;
    if (b->size > 0)
        unload_blob(b->data, b->size);
    cv_content_store *s = b->store;
    pthread_mutex_lock(&s->lock);
    unpin(b->entry);
    s->live_blobs--;
    pthread_mutex_unlock(&s->lock);
    free(b);
}

cv_content_stats cv_content_store_stats(cv_content_store *s) {
    pthread_mutex_lock(&s->lock);
    cv_content_stats stats = s->stats;
    pthread_mutex_unlock(&s->lock);
    return stats;
}

/* ---- uploads ---- */

void cv_content_store_set_upload_wait(cv_content_store *s, uint32_t wait_ms) {
    pthread_mutex_lock(&s->lock);
    s->upload_wait_ms = wait_ms;
    pthread_mutex_unlock(&s->lock);
}

/* Lock held: makes an upload of `size` bytes of fresh->sha an uploader of
 * the blob's entry (`fresh`, put in the table, if it has none). While another
 * upload receives the blob this waits, up to upload_wait_ms in all: for it to
 * store the blob (then CV_ERROR_ALREADY_EXISTS) or end without storing it
 * (then this one takes its place). A waiter that runs out of time receives the
 * blob beside it, and the first of the two to finish stores it: a stalled
 * first upload delays the others, it never fails them. */
static cv_result claim_blob(cv_content_store *s, entry *fresh, uint64_t size, const char *hex, entry **out) {
    bool waiting = false, gave_up = false;
    uint64_t deadline = 0;
    for (;;) {
        entry *e = table_find(s, fresh->sha);
        if (e && e->state == ENTRY_STORED) {
            touch(s, e);
            return cv_error(CV_ERROR_ALREADY_EXISTS, "content store: blob %s is already stored", hex);
        }
        if (e && !gave_up && s->upload_wait_ms > 0) {
            if (!waiting) {
                waiting = true;
                s->stats.waits++;
                deadline = cv_deadline_after_ms(s->upload_wait_ms);
            }
            gave_up = cv_cond_wait_until(&s->upload_ended, &s->lock, deadline) == ETIMEDOUT;
            continue; /* look again: stored, ended, or still going */
        }
        if (!make_room(s, size)) {
            s->stats.rejected++;
            return cv_error(CV_ERROR_LIMIT_EXCEEDED,
                            "content store: no room for blob %s of %" PRIu64 " bytes: %" PRIu64
                            " of the limit of %" PRIu64 " bytes are pinned or reserved by other uploads",
                            hex, size, s->stats.bytes + s->reserved, s->max_bytes);
        }
        if (e == NULL) {
            if (!table_insert(s, fresh))
                return cv_error(CV_ERROR_OUT_OF_MEMORY, "content store: index entry for %s", hex);
            e = fresh;
        }
        e->uploaders++;
        s->reserved += size;
        s->live_uploads++;
        *out = e;
        return CV_OK;
    }
}

/* Lock held: an upload of `size` bytes lets go of its entry (stored by it or
 * not); an entry that nobody stored and nobody receives leaves the index. */
static void release_claim(cv_content_store *s, entry *e, uint64_t size) {
    e->uploaders--;
    s->reserved -= size;
    s->live_uploads--;
    if (e->state == ENTRY_UPLOADING && e->uploaders == 0) {
        table_remove(s, e);
        free(e);
    } else {
        free_if_unheld(e);
    }
    pthread_cond_broadcast(&s->upload_ended);
}

/* A temporary only this user can read (0600 whatever the umask). */
static cv_result open_temporary(cv_content_upload *u) {
    cv_content_store *s = u->store;
    u->fd = openat(s->tmp_fd, u->temp_name, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0600);
    if (u->fd < 0)
        return cv_error(CV_ERROR_IO, "content store: creating tmp/%s: %s", u->temp_name, strerror(errno));
    cv_result r = CV_OK;
    if (fchmod(u->fd, 0600) != 0)
        r = cv_error(CV_ERROR_IO, "content store: chmod 0600 tmp/%s: %s", u->temp_name, strerror(errno));
    else
        r = cv_sha256_init(&u->sha);
    if (r != CV_OK) {
        close(u->fd);
        unlinkat(s->tmp_fd, u->temp_name, 0);
    }
    return r;
}

cv_result cv_content_upload_begin(cv_content_store *s, const uint8_t sha[32], uint64_t size,
                                  cv_content_upload **out) {
    if (s == NULL || sha == NULL || out == NULL)
        return cv_error(CV_ERROR_INVALID_ARGUMENT,
                        "content store: upload_begin needs a store, a hash and an out pointer");
    char hex[CV_SHA256_HEX_SIZE];
    cv_sha256_hex(sha, hex);
    if (size > s->max_bytes) {
        pthread_mutex_lock(&s->lock);
        s->stats.rejected++;
        pthread_mutex_unlock(&s->lock);
        return cv_error(CV_ERROR_LIMIT_EXCEEDED,
                        "content store: blob %s of %" PRIu64 " bytes is larger than the store's limit of %" PRIu64
                        " bytes",
                        hex, size, s->max_bytes);
    }
    cv_content_upload *u = calloc(1, sizeof *u);
    entry *fresh = calloc(1, sizeof *fresh);
    if (u == NULL || fresh == NULL) {
        free(u);
        free(fresh);
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "content store: upload of %s", hex);
    }
    memcpy(fresh->sha, sha, 32);
    fresh->size = size;
    fresh->state = ENTRY_UPLOADING;

    pthread_mutex_lock(&s->lock);
    entry *e = NULL;
    cv_result r = claim_blob(s, fresh, size, hex, &e);
    if (r == CV_OK)
        snprintf(u->temp_name, sizeof u->temp_name, "%s.%" PRIu64, hex, ++s->temp_counter);
    pthread_mutex_unlock(&s->lock);
    if (e != fresh)
        free(fresh); /* already there, another upload's, or refused */
    if (r != CV_OK) {
        free(u);
        return r;
    }

    u->store = s;
    u->entry = e;
    u->size = size;
    r = open_temporary(u);
    if (r != CV_OK) {
        pthread_mutex_lock(&s->lock);
        release_claim(s, e, size);
        pthread_mutex_unlock(&s->lock);
        free(u);
        return r;
    }
    *out = u;
    return CV_OK;
}

cv_result cv_content_upload_write(cv_content_upload *u, uint64_t offset, const void *data, size_t len) {
    if (u == NULL || (data == NULL && len > 0))
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "content store: upload_write needs an upload and data");
    const char *name = u->temp_name; /* "<hash>.<n>" */
    if (offset != u->received)
        return cv_error(CV_ERROR_INVALID_ARGUMENT,
                        "content store: upload of %.64s: chunk at offset %" PRIu64 ", expected the next at %" PRIu64
                        " (chunks go in order)",
                        name, offset, u->received);
    if (len > u->size - u->received)
        return cv_error(CV_ERROR_OUT_OF_RANGE,
                        "content store: upload of %.64s: chunk of %zu bytes at %" PRIu64
                        " runs past the blob's %" PRIu64 " bytes",
                        name, len, offset, u->size);
    /* pwrite at the chunk's own offset: if it fails part way, a retry of the
     * same chunk overwrites whatever got written. */
    const uint8_t *p = data;
    for (size_t done = 0; done < len;) {
        ssize_t n = pwrite(u->fd, p + done, len - done, (off_t)(offset + done));
        if (n < 0 && errno == EINTR)
            continue;
        if (n <= 0)
            return cv_error(CV_ERROR_IO, "content store: upload of %.64s: writing %zu bytes at %" PRIu64 ": %s", name,
                            len, offset, n < 0 ? strerror(errno) : "no progress");
        done += (size_t)n;
    }
    cv_sha256_update(&u->sha, data, len);
    u->received += len;
    return CV_OK;
}

uint64_t cv_content_upload_received(const cv_content_upload *u) { return u->received; }

/* Ends an upload that stores nothing. */
static void discard_upload(cv_content_upload *u, bool rejected) {
    cv_content_store *s = u->store;
    if (u->fd >= 0)
        close(u->fd);
    unlinkat(s->tmp_fd, u->temp_name, 0);
    cv_sha256_discard(&u->sha);
    pthread_mutex_lock(&s->lock);
    if (rejected)
        s->stats.rejected++;
    release_claim(s, u->entry, u->size);
    pthread_mutex_unlock(&s->lock);
    free(u);
}

void cv_content_upload_abort(cv_content_upload *u) {
    if (u)
        discard_upload(u, false);
}

/* Lock held: a complete, hash-checked temporary becomes the blob's file, or,
 * if another upload of the blob stored it first, goes. */
static cv_result store_upload(cv_content_upload *u, const struct stat *st, const char *key_hex) {
    cv_content_store *s = u->store;
    /* Normally this upload's own entry. It may instead be stored by another
     * upload already (this copy goes), or have been dropped since another
     * stored it (then the hash's entry now, or a new one, takes this copy). */
    entry *e = table_find(s, u->entry->sha);
    if (e == NULL) {
        e = calloc(1, sizeof *e);
        if (e)
            memcpy(e->sha, u->entry->sha, 32); /* ENTRY_UPLOADING, no uploader: stored below or removed */
        if (e == NULL || !table_insert(s, e)) {
            free(e);
            unlinkat(s->tmp_fd, u->temp_name, 0);
            s->stats.rejected++;
            return cv_error(CV_ERROR_OUT_OF_MEMORY, "content store: index entry for %s", key_hex);
        }
    }
    if (e->state == ENTRY_STORED) {
        unlinkat(s->tmp_fd, u->temp_name, 0);
        s->stats.duplicates++;
        return CV_OK;
    }
    char name[OBJECT_NAME_SIZE];
    object_name(e->sha, name);
    if (renameat(s->tmp_fd, u->temp_name, s->objects_fd, name) != 0) {
        cv_result r = cv_error(CV_ERROR_IO, "content store: upload of %s: rename into objects/: %s", key_hex,
                               strerror(errno));
        unlinkat(s->tmp_fd, u->temp_name, 0);
        s->stats.rejected++;
        if (e->uploaders == 0) { /* the entry made just above */
            table_remove(s, e);
            free(e);
        }
        return r;
    }
    e->size = u->size;
    e->state = ENTRY_STORED;
    record_hashed(e, st);
    e->used = next_stamp(s);
    stamp_file(s, e);
    lru_push_newest(s, e);
    s->stats.bytes += e->size;
    s->stats.entries++;
    s->stats.uploads++;
    return CV_OK;
}

cv_result cv_content_upload_finish(cv_content_upload *u) {
    if (u == NULL)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "content store: upload_finish needs an upload");
    cv_content_store *s = u->store;
    char key_hex[CV_SHA256_HEX_SIZE];
    cv_sha256_hex(u->entry->sha, key_hex);
    if (u->received != u->size) {
        cv_result r = cv_error(CV_ERROR_BAD_STATE,
                               "content store: upload of %s finished after %" PRIu64 " of its %" PRIu64
                               " bytes; nothing stored",
                               key_hex, u->received, u->size);
        discard_upload(u, true);
        return r;
    }
    uint8_t actual[32];
    cv_result r = cv_sha256_final(&u->sha, actual);
    if (r == CV_OK && memcmp(actual, u->entry->sha, 32) != 0) {
        char actual_hex[CV_SHA256_HEX_SIZE];
        cv_sha256_hex(actual, actual_hex);
        r = cv_error(CV_ERROR_HASH_MISMATCH,
                     "content store: upload keyed %s has content hashing to %s; nothing stored", key_hex, actual_hex);
    }
    struct stat st; /* the file's identity, for the checks on use (file_id) */
    if (r == CV_OK && fstat(u->fd, &st) != 0)
        r = cv_error(CV_ERROR_IO, "content store: upload of %s: fstat: %s", key_hex, strerror(errno));
    if (r == CV_OK && close(u->fd) != 0) {
        u->fd = -1;
        r = cv_error(CV_ERROR_IO, "content store: upload of %s: close: %s", key_hex, strerror(errno));
    }
    if (r != CV_OK) {
        discard_upload(u, true);
        return r;
    }
    u->fd = -1;

    pthread_mutex_lock(&s->lock);
    r = store_upload(u, &st, key_hex);
    release_claim(s, u->entry, u->size);
    pthread_mutex_unlock(&s->lock);
    free(u);
    return r;
}
