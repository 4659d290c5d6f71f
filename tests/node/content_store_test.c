/* The content store: uploads in chunks and reads back, rejected chunks and
 * hashes, aborts, LRU eviction around pinned blobs, the size limit, restarts
 * (blobs and their order kept), damaged and stray files on disk, file modes,
 * blobs changed on disk while open, eight threads on overlapping hashes and
 * on one hash, a waiter whose first uploader aborts or stalls, hashes that
 * share the index's key, and the counters after each of those. Every
 * test works in its own mkdtemp directory and removes it. */
#include <dirent.h>
#include <ftw.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "check.h"
#include "content_store.h"
#include "corvid/sha256.h"

/* ---- helpers ---- */

typedef struct blob {
    uint8_t *data;
    size_t size;
    uint8_t sha[32];
} blob;

static blob make_blob(uint32_t seed, size_t size) {
    blob b = { .data = malloc(size ? size : 1), .size = size };
    uint64_t x = seed * UINT64_C(0x9e3779b97f4a7c15) + 1;
    for (size_t i = 0; i < size; i++) {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        b.data[i] = (uint8_t)x;
    }
    cv_sha256(b.data, size, b.sha);
    return b;
}

static void free_blob(blob *b) { free(b->data); }

/* begin, writes of `chunk` bytes, finish; the first failure's result. */
static cv_result upload(cv_content_store *s, const blob *b, size_t chunk) {
    cv_content_upload *u;
    cv_result r = cv_content_upload_begin(s, b->sha, b->size, &u);
    if (r != CV_OK)
        return r;
    for (size_t off = 0; off < b->size; off += chunk) {
        size_t n = b->size - off < chunk ? b->size - off : chunk;
        r = cv_content_upload_write(u, off, b->data + off, n);
        if (r != CV_OK) {
            cv_content_upload_abort(u);
            return r;
        }
    }
    return cv_content_upload_finish(u);
}

/* get, compare every byte, release. */
static bool get_matches(cv_content_store *s, const blob *b) {
    cv_content_blob *cb;
    if (cv_content_store_get(s, b->sha, &cb) != CV_OK)
        return false;
    bool same = cv_content_blob_size(cb) == b->size && cv_content_blob_data(cb) != NULL &&
                memcmp(cv_content_blob_data(cb), b->data, b->size) == 0;
    cv_content_blob_release(cb);
    return same;
}

static char *path_of(const char *dir, const blob *b, char out[512]) {
    char hex[CV_SHA256_HEX_SIZE];
    cv_sha256_hex(b->sha, hex);
    snprintf(out, 512, "%s/objects/%.2s/%s", dir, hex, hex);
    return out;
}

/* Whether the blob's file exists: looks without touching the LRU or counters. */
static bool on_disk(const char *dir, const blob *b) {
    char path[512];
    return access(path_of(dir, b, path), F_OK) == 0;
}

static int entries_in(const char *dir, const char *sub) {
    char path[512];
    snprintf(path, sizeof path, "%s/%s", dir, sub);
    DIR *d = opendir(path);
    if (d == NULL)
        return -1;
    int n = 0;
    for (struct dirent *e = readdir(d); e; e = readdir(d))
        n += strcmp(e->d_name, ".") != 0 && strcmp(e->d_name, "..") != 0;
    closedir(d);
    return n;
}

static char *make_dir(char out[64]) {
    strcpy(out, "/tmp/corvid-content-XXXXXX");
    if (mkdtemp(out) == NULL) {
        perror("mkdtemp");
        exit(1);
    }
    return out;
}

static int remove_one(const char *path, const struct stat *st, int flag, struct FTW *ftw) {
    (void)st, (void)flag, (void)ftw;
    return remove(path);
}

static void remove_dir(const char *dir) {
    CHECK_EQ_INT(nftw(dir, remove_one, 16, FTW_DEPTH | FTW_PHYS), 0);
    CHECK(access(dir, F_OK) != 0);
}

static void write_file(const char *path, const void *data, size_t size) {
    FILE *f = fopen(path, "wb");
    CHECK(f != NULL);
    if (f) {
        CHECK_EQ_INT(fwrite(data, 1, size, f), size);
        fclose(f);
    }
}

/* ---- tests ---- */

static void test_upload_and_get(void) {
    char dir[64];
    make_dir(dir);
    cv_content_store *s;
    CHECK_OK(cv_content_store_open(dir, 0, &s));
    CHECK_EQ_INT(cv_content_store_stats(s).max_bytes, UINT64_C(1) << 30);
    blob a = make_blob(1, 100000), empty = make_blob(2, 0);

    CHECK(!cv_content_store_has(s, a.sha));
    cv_content_upload *u;
    CHECK_OK(cv_content_upload_begin(s, a.sha, a.size, &u));
    CHECK_EQ_INT(cv_content_upload_received(u), 0);
    CHECK_EQ_INT(entries_in(dir, "tmp"), 1);
    for (size_t off = 0; off < a.size; off += 7919) {
        size_t n = a.size - off < 7919 ? a.size - off : 7919;
        CHECK_OK(cv_content_upload_write(u, off, a.data + off, n));
        CHECK_EQ_INT(cv_content_upload_received(u), off + n);
    }
    CHECK(!cv_content_store_has(s, a.sha)); /* not visible before finish */
    CHECK_OK(cv_content_upload_finish(u));
    CHECK(cv_content_store_has(s, a.sha));
    CHECK(on_disk(dir, &a));
    CHECK_EQ_INT(entries_in(dir, "tmp"), 0);
    CHECK(get_matches(s, &a));

    CHECK_RESULT(cv_content_upload_begin(s, a.sha, a.size, &u), CV_ERROR_ALREADY_EXISTS);

    /* Past 4 MiB blobs are mapped rather than read: the same outcome. */
    blob big = make_blob(5, (5u << 20) + 3);
    CHECK_OK(upload(s, &big, 1u << 20));
    CHECK(get_matches(s, &big));

    CHECK_OK(upload(s, &empty, 1)); /* the empty blob is a blob too */
    cv_content_blob *b;
    CHECK_OK(cv_content_store_get(s, empty.sha, &b));
    CHECK(cv_content_blob_data(b) != NULL);
    CHECK_EQ_INT(cv_content_blob_size(b), 0);
    cv_content_blob_release(b);

    uint8_t absent[32] = { 0 };
    CHECK_RESULT(cv_content_store_get(s, absent, &b), CV_ERROR_NOT_FOUND);

    cv_content_stats st = cv_content_store_stats(s);
    CHECK_EQ_INT(st.hits, 1);
    CHECK_EQ_INT(st.misses, 2);
    CHECK_EQ_INT(st.uploads, 3);
    CHECK_EQ_INT(st.entries, 3);
    CHECK_EQ_INT(st.bytes, a.size + big.size);
    CHECK_EQ_INT(st.evictions, 0);
    CHECK_EQ_INT(st.rejected, 0);
    CHECK_EQ_INT(st.dropped, 0);
    cv_content_store_close(s);

    /* After a restart a mapped blob is hashed on first use too: one flipped byte drops it. */
    char path[512];
    FILE *f = fopen(path_of(dir, &big, path), "r+b");
    CHECK(f != NULL);
    if (f) {
        fseek(f, 5000000, SEEK_SET);
        fputc(big.data[5000000] ^ 1, f);
        fclose(f);
    }
    CHECK_OK(cv_content_store_open(dir, 0, &s));
    CHECK(get_matches(s, &a));
    CHECK_RESULT(cv_content_store_get(s, big.sha, &b), CV_ERROR_NOT_FOUND);
    CHECK(!on_disk(dir, &big));
    CHECK_EQ_INT(cv_content_store_stats(s).dropped, 1);
    cv_content_store_close(s);
    free_blob(&a);
    free_blob(&big);
    free_blob(&empty);
    remove_dir(dir);
}

static void test_rejected_uploads(void) {
    char dir[64];
    make_dir(dir);
    cv_content_store *s;
    CHECK_OK(cv_content_store_open(dir, 0, &s));
    blob a = make_blob(3, 5000), b = make_blob(4, 5000);

    /* Content of a under the key of b. */
    cv_content_upload *u;
    CHECK_OK(cv_content_upload_begin(s, b.sha, a.size, &u));
    CHECK_OK(cv_content_upload_write(u, 0, a.data, a.size));
    CHECK_RESULT(cv_content_upload_finish(u), CV_ERROR_HASH_MISMATCH);
    char hex_a[CV_SHA256_HEX_SIZE], hex_b[CV_SHA256_HEX_SIZE];
    cv_sha256_hex(a.sha, hex_a);
    cv_sha256_hex(b.sha, hex_b);
    CHECK(strstr(cv_last_error(), hex_a) != NULL);
    CHECK(strstr(cv_last_error(), hex_b) != NULL);
    CHECK(!cv_content_store_has(s, b.sha));
    CHECK(!cv_content_store_has(s, a.sha));
    CHECK(!on_disk(dir, &a) && !on_disk(dir, &b));
    CHECK_EQ_INT(entries_in(dir, "tmp"), 0);

    /* Finished early: nothing stored either. */
    CHECK_OK(cv_content_upload_begin(s, a.sha, a.size, &u));
    CHECK_OK(cv_content_upload_write(u, 0, a.data, 100));
    CHECK_RESULT(cv_content_upload_finish(u), CV_ERROR_BAD_STATE);
    CHECK(!on_disk(dir, &a));
    CHECK_EQ_INT(entries_in(dir, "tmp"), 0);

    /* Chunks out of order or past the end change nothing. */
    CHECK_OK(cv_content_upload_begin(s, a.sha, a.size, &u));
    CHECK_OK(cv_content_upload_write(u, 0, a.data, 1000));
    CHECK_RESULT(cv_content_upload_write(u, 500, a.data + 500, 100), CV_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(cv_content_upload_write(u, 2000, a.data + 2000, 100), CV_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(cv_content_upload_write(u, 1000, a.data + 1000, a.size - 1000 + 1), CV_ERROR_OUT_OF_RANGE);
    CHECK_RESULT(cv_content_upload_write(u, 1000, NULL, 10), CV_ERROR_INVALID_ARGUMENT);
    CHECK_EQ_INT(cv_content_upload_received(u), 1000);
    /* A second upload of the same hash meanwhile (not waiting: upload wait 0)
     * receives it beside the first; the blob is not readable yet. The first
     * to finish stores it, the second's copy is discarded and it succeeds. */
    cv_content_store_set_upload_wait(s, 0);
    cv_content_upload *second;
    CHECK_OK(cv_content_upload_begin(s, a.sha, a.size, &second));
    CHECK_EQ_INT(entries_in(dir, "tmp"), 2);
    cv_content_blob *cb;
    CHECK_RESULT(cv_content_store_get(s, a.sha, &cb), CV_ERROR_NOT_FOUND);
    CHECK_OK(cv_content_upload_write(u, 1000, a.data + 1000, 0));
    CHECK_OK(cv_content_upload_write(u, 1000, a.data + 1000, a.size - 1000));
    CHECK_RESULT(cv_content_upload_write(u, a.size, a.data, 1), CV_ERROR_OUT_OF_RANGE);
    CHECK_OK(cv_content_upload_finish(u));
    CHECK(get_matches(s, &a));
    CHECK_OK(cv_content_upload_write(second, 0, a.data, a.size));
    CHECK_OK(cv_content_upload_finish(second));
    CHECK_EQ_INT(entries_in(dir, "tmp"), 0);
    CHECK(get_matches(s, &a));
    CHECK_EQ_INT(cv_content_store_stats(s).duplicates, 1);

    /* Abort leaves nothing, and the hash can be uploaded afterwards. */
    CHECK_OK(cv_content_upload_begin(s, b.sha, b.size, &u));
    CHECK_OK(cv_content_upload_write(u, 0, b.data, 2500));
    CHECK_EQ_INT(entries_in(dir, "tmp"), 1);
    cv_content_upload_abort(u);
    CHECK_EQ_INT(entries_in(dir, "tmp"), 0);
    CHECK(!on_disk(dir, &b));
    CHECK(!cv_content_store_has(s, b.sha));
    CHECK_OK(upload(s, &b, 4096));
    CHECK(get_matches(s, &b));

    cv_content_stats st = cv_content_store_stats(s);
    CHECK_EQ_INT(st.uploads, 2);
    CHECK_EQ_INT(st.rejected, 2); /* the mismatch and the early finish */
    CHECK_EQ_INT(st.entries, 2);
    CHECK_EQ_INT(st.bytes, a.size + b.size);
    CHECK_EQ_INT(st.hits, 0);
    CHECK_EQ_INT(st.misses, 3);
    cv_content_store_close(s);
    free_blob(&a);
    free_blob(&b);
    remove_dir(dir);
}

/* Blobs of S bytes in a store of 4 S: the fifth evicts the least recently
 * used one that is not pinned; has() and get() count as uses, and the order
 * survives a restart. */
static void test_lru_and_restart(void) {
    enum { S = 10000 };
    char dir[64];
    make_dir(dir);
    cv_content_store *s;
    CHECK_OK(cv_content_store_open(dir, 4 * S, &s));
    blob b[8];
    for (int i = 0; i < 8; i++)
        b[i] = make_blob(10 + (uint32_t)i, S);
    enum { A, B, C, D, E, F, G, H };

    for (int i = A; i <= D; i++)
        CHECK_OK(upload(s, &b[i], 3000));     /* oldest first: A B C D */
    CHECK(cv_content_store_has(s, b[A].sha)); /* B C D A */
    cv_content_blob *pinned_b;
    CHECK_OK(cv_content_store_get(s, b[B].sha, &pinned_b)); /* C D A B, B pinned */
    CHECK_OK(upload(s, &b[E], S));                          /* evicts C: D A B E */
    CHECK(!on_disk(dir, &b[C]));
    CHECK(on_disk(dir, &b[A]) && on_disk(dir, &b[B]) && on_disk(dir, &b[D]) && on_disk(dir, &b[E]));
    CHECK(get_matches(s, &b[D]));  /* A B E D */
    CHECK(get_matches(s, &b[A]));  /* B E D A */
    CHECK_OK(upload(s, &b[F], S)); /* B is oldest but pinned: evicts E */
    CHECK(on_disk(dir, &b[B]) && !on_disk(dir, &b[E]));
    CHECK(memcmp(cv_content_blob_data(pinned_b), b[B].data, S) == 0);
    cv_content_blob_release(pinned_b); /* B D A F */

    /* Larger than the whole store; and no room while everything is pinned. */
    cv_content_upload *u;
    CHECK_RESULT(cv_content_upload_begin(s, b[G].sha, 4 * S + 1, &u), CV_ERROR_LIMIT_EXCEEDED);
    CHECK(strstr(cv_last_error(), "40001") != NULL && strstr(cv_last_error(), "40000") != NULL);
    cv_content_blob *pins[4];
    int order_now[4] = { B, D, A, F };
    for (int i = 0; i < 4; i++)
        CHECK_OK(cv_content_store_get(s, b[order_now[i]].sha, &pins[i])); /* pinning in order keeps it */
    CHECK_RESULT(cv_content_upload_begin(s, b[G].sha, S, &u), CV_ERROR_LIMIT_EXCEEDED);
    for (int i = 0; i < 4; i++)
        cv_content_blob_release(pins[i]);

    cv_content_stats st = cv_content_store_stats(s);
    CHECK_EQ_INT(st.evictions, 2);
    CHECK_EQ_INT(st.uploads, 6);
    CHECK_EQ_INT(st.rejected, 2);
    CHECK_EQ_INT(st.entries, 4);
    CHECK_EQ_INT(st.bytes, 4 * S);
    CHECK_EQ_INT(st.hits, 1);

    /* A second store on the same directory is refused while this one is open. */
    cv_content_store *other;
    CHECK_RESULT(cv_content_store_open(dir, 4 * S, &other), CV_ERROR_BAD_STATE);

    /* Restart: the blobs and the order B D A F come back. */
    cv_content_store_close(s);
    CHECK_OK(cv_content_store_open(dir, 4 * S, &s));
    st = cv_content_store_stats(s);
    CHECK_EQ_INT(st.entries, 4);
    CHECK_EQ_INT(st.bytes, 4 * S);
    CHECK_EQ_INT(st.uploads, 0);
    CHECK_OK(upload(s, &b[G], S)); /* evicts B: D A F G */
    CHECK(!on_disk(dir, &b[B]) && on_disk(dir, &b[D]));
    CHECK(cv_content_store_has(s, b[D].sha)); /* A F G D */
    CHECK_OK(upload(s, &b[H], S));            /* evicts A: F G D H */
    CHECK(!on_disk(dir, &b[A]));
    for (int i = 0; i < 8; i++) {
        bool expected = i == F || i == G || i == D || i == H;
        CHECK(on_disk(dir, &b[i]) == expected);
    }
    CHECK(get_matches(s, &b[F]) && get_matches(s, &b[G]) && get_matches(s, &b[D]) && get_matches(s, &b[H]));
    cv_content_store_close(s);

    /* Reopened with a smaller limit: shrinks at once, least recently used first (F G D H). */
    CHECK_OK(cv_content_store_open(dir, 2 * S, &s));
    st = cv_content_store_stats(s);
    CHECK_EQ_INT(st.entries, 2);
    CHECK_EQ_INT(st.evictions, 2);
    CHECK(!on_disk(dir, &b[F]) && !on_disk(dir, &b[G]) && on_disk(dir, &b[D]) && on_disk(dir, &b[H]));
    cv_content_store_close(s);

    for (int i = 0; i < 8; i++)
        free_blob(&b[i]);
    remove_dir(dir);
}

/* Files damaged while the store was closed are dropped on first use; strays
 * are removed at open. */
static void test_damage_and_strays(void) {
    char dir[64], path[512], stray[600];
    make_dir(dir);
    cv_content_store *s;
    CHECK_OK(cv_content_store_open(dir, 0, &s));
    blob a = make_blob(20, 3000), b = make_blob(21, 3000), c = make_blob(22, 3000), d = make_blob(23, 3000);
    CHECK_OK(upload(s, &a, 3000));
    CHECK_OK(upload(s, &b, 3000));
    CHECK_OK(upload(s, &c, 3000));
    CHECK_OK(upload(s, &d, 3000));
    cv_content_store_close(s);

    CHECK_EQ_INT(truncate(path_of(dir, &a, path), 1500), 0); /* a: truncated */
    FILE *f = fopen(path_of(dir, &b, path), "r+b");          /* b: one byte flipped */
    CHECK(f != NULL);
    if (f) {
        fseek(f, 1234, SEEK_SET);
        fputc(b.data[1234] ^ 0x40, f);
        fclose(f);
    }
    CHECK_EQ_INT(truncate(path_of(dir, &d, path), 2999), 0); /* d: truncated */
    snprintf(stray, sizeof stray, "%s/tmp/leftover.1", dir);
    write_file(stray, "x", 1);
    snprintf(stray, sizeof stray, "%s/objects/ab/not-a-hash", dir);
    write_file(stray, "x", 1);
    snprintf(stray, sizeof stray, "%s/objects/zz", dir);
    CHECK_EQ_INT(mkdir(stray, 0755), 0);
    char hex[CV_SHA256_HEX_SIZE];
    cv_sha256_hex(c.sha, hex);
    snprintf(stray, sizeof stray, "%s/objects/%s", dir, hex); /* a hash in the wrong folder */
    write_file(stray, c.data, c.size);
    snprintf(stray, sizeof stray, "%s/objects/%.2s/%.63s", dir, hex, hex); /* one digit short */
    write_file(stray, c.data, c.size);
    hex[10] = hex[10] >= 'a' ? (char)(hex[10] - 'a' + 'A') : 'A'; /* upper case */
    snprintf(stray, sizeof stray, "%s/objects/%.2s/%s", dir, hex, hex);
    write_file(stray, c.data, c.size);

    CHECK_OK(cv_content_store_open(dir, 0, &s));
    CHECK_EQ_INT(entries_in(dir, "tmp"), 0);
    CHECK_EQ_INT(entries_in(dir, "objects"), 256); /* the 256 prefix folders only */
    CHECK_EQ_INT(entries_in(dir, "objects/ab"), 0);
    cv_sha256_hex(c.sha, hex);
    snprintf(stray, sizeof stray, "objects/%.2s", hex);
    CHECK_EQ_INT(entries_in(dir, stray), 1);            /* c's own file */
    CHECK_EQ_INT(cv_content_store_stats(s).entries, 4); /* damage not yet seen */

    cv_content_blob *cb;
    CHECK_RESULT(cv_content_store_get(s, a.sha, &cb), CV_ERROR_NOT_FOUND);
    CHECK(!on_disk(dir, &a));
    CHECK(!cv_content_store_has(s, b.sha));
    CHECK(!on_disk(dir, &b));
    CHECK(!cv_content_store_has(s, d.sha));
    CHECK(!on_disk(dir, &d));
    CHECK(get_matches(s, &c));
    CHECK_RESULT(cv_content_store_get(s, b.sha, &cb), CV_ERROR_NOT_FOUND);
    cv_content_stats st = cv_content_store_stats(s);
    CHECK_EQ_INT(st.dropped, 3);
    CHECK_EQ_INT(st.entries, 1);
    CHECK_EQ_INT(st.bytes, c.size);
    CHECK_EQ_INT(st.misses, 2);

    /* Damage after the first check shows as a wrong size on the next get. */
    CHECK_EQ_INT(truncate(path_of(dir, &c, path), 100), 0);
    CHECK_RESULT(cv_content_store_get(s, c.sha, &cb), CV_ERROR_NOT_FOUND);
    CHECK(!on_disk(dir, &c));
    CHECK_EQ_INT(cv_content_store_stats(s).dropped, 4);
    CHECK_EQ_INT(cv_content_store_stats(s).entries, 0);

    /* A dropped blob can be uploaded again. */
    CHECK_OK(upload(s, &b, 1000));
    CHECK(get_matches(s, &b));
    cv_content_store_close(s);
    free_blob(&a);
    free_blob(&b);
    free_blob(&c);
    free_blob(&d);
    remove_dir(dir);
}

static mode_t mode_of(const char *dir, const char *sub) { /* sub "" names dir itself */
    char path[700];
    snprintf(path, sizeof path, "%s/%s", dir, sub);
    struct stat st;
    if (stat(path, &st) != 0)
        return (mode_t)-1;
    return st.st_mode & 07777;
}

/* Folders 0700 and files 0600 whatever the umask, and an older store's
 * modes tightened at open. */
static void test_permissions(void) {
    char dir[64], path[512], sub[600];
    make_dir(dir);
    CHECK_EQ_INT(chmod(dir, 0755), 0);
    mode_t old_umask = umask(0); /* the widest: modes come from the store alone */
    cv_content_store *s;
    CHECK_OK(cv_content_store_open(dir, 0, &s));
    blob a = make_blob(30, 3000);
    cv_content_upload *u;
    CHECK_OK(cv_content_upload_begin(s, a.sha, a.size, &u));
    DIR *d = NULL;
    snprintf(sub, sizeof sub, "%s/tmp", dir);
    d = opendir(sub);
    for (struct dirent *e = d ? readdir(d) : NULL; e; e = readdir(d)) {
        if (e->d_name[0] != '.') {
            snprintf(sub, sizeof sub, "tmp/%s", e->d_name);
            CHECK_EQ_INT(mode_of(dir, sub), 0600); /* an upload being received */
        }
    }
    if (d)
        closedir(d);
    CHECK_OK(cv_content_upload_write(u, 0, a.data, a.size));
    CHECK_OK(cv_content_upload_finish(u));
    CHECK_EQ_INT(mode_of(dir, ""), 0700);
    CHECK_EQ_INT(mode_of(dir, "objects"), 0700);
    CHECK_EQ_INT(mode_of(dir, "tmp"), 0700);
    CHECK_EQ_INT(mode_of(dir, "objects/00"), 0700);
    CHECK_EQ_INT(mode_of(dir, "objects/ff"), 0700);
    CHECK_EQ_INT(mode_of(dir, "lock"), 0600);
    struct stat st;
    CHECK_EQ_INT(stat(path_of(dir, &a, path), &st), 0);
    CHECK_EQ_INT(st.st_mode & 07777, 0600);
    cv_content_store_close(s);

    /* A store left with open modes (an older version's) is closed up at open. */
    CHECK_EQ_INT(chmod(path, 0644), 0);
    snprintf(sub, sizeof sub, "%s/objects/7f", dir);
    CHECK_EQ_INT(chmod(sub, 0755), 0);
    snprintf(sub, sizeof sub, "%s/objects", dir);
    CHECK_EQ_INT(chmod(sub, 0755), 0);
    snprintf(sub, sizeof sub, "%s/lock", dir);
    CHECK_EQ_INT(chmod(sub, 0644), 0);
    CHECK_EQ_INT(chmod(dir, 0755), 0);
    CHECK_OK(cv_content_store_open(dir, 0, &s));
    CHECK_EQ_INT(mode_of(dir, ""), 0700);
    CHECK_EQ_INT(mode_of(dir, "objects"), 0700);
    CHECK_EQ_INT(mode_of(dir, "objects/7f"), 0700);
    CHECK_EQ_INT(mode_of(dir, "lock"), 0600);
    CHECK_EQ_INT(stat(path, &st), 0);
    CHECK_EQ_INT(st.st_mode & 07777, 0600);
    CHECK(get_matches(s, &a));
    cv_content_store_close(s);
    umask(old_umask);
    free_blob(&a);
    remove_dir(dir);
}

static void flip_byte(const char *path, long at) {
    FILE *f = fopen(path, "r+b");
    CHECK(f != NULL);
    if (f) {
        fseek(f, at, SEEK_SET);
        int c = fgetc(f);
        fseek(f, at, SEEK_SET);
        fputc(c ^ 0x01, f);
        fclose(f);
    }
}

/* A blob changed on disk while the store is open (after its hash) is never
 * used: the next has() or get() sees the file changed, hashes it again and
 * drops it; it can be uploaded again. A file replaced by one with the same
 * content passes the new hash and stays. */
static void test_changed_while_open(void) {
    char dir[64], path[512], other[600];
    make_dir(dir);
    cv_content_store *s;
    CHECK_OK(cv_content_store_open(dir, 0, &s));
    blob a = make_blob(40, 70000), big = make_blob(41, (5u << 20) + 11), c = make_blob(42, 3000);
    CHECK_OK(upload(s, &a, 8192));
    CHECK_OK(upload(s, &big, 1u << 20));
    CHECK_OK(upload(s, &c, 3000));
    CHECK(get_matches(s, &a) && get_matches(s, &big) && cv_content_store_has(s, c.sha));

    flip_byte(path_of(dir, &a, path), 12345); /* same size, other bytes */
    CHECK(!cv_content_store_has(s, a.sha));
    CHECK(!on_disk(dir, &a));
    CHECK_EQ_INT(cv_content_store_stats(s).dropped, 1);
    CHECK_OK(upload(s, &a, 8192));
    CHECK(get_matches(s, &a));

    flip_byte(path_of(dir, &big, path), 4000000); /* a mapped one, found by get() */
    cv_content_blob *cb;
    CHECK_RESULT(cv_content_store_get(s, big.sha, &cb), CV_ERROR_NOT_FOUND);
    CHECK(strstr(cv_last_error(), "dropped") != NULL);
    CHECK(!on_disk(dir, &big));
    CHECK_EQ_INT(cv_content_store_stats(s).dropped, 2);

    /* Replaced by a copy of the same bytes (another inode): hashed again, kept. */
    snprintf(other, sizeof other, "%s/tmp/copy", dir);
    write_file(other, c.data, c.size);
    CHECK_EQ_INT(rename(other, path_of(dir, &c, path)), 0);
    CHECK(cv_content_store_has(s, c.sha));
    CHECK(get_matches(s, &c));
    CHECK_EQ_INT(cv_content_store_stats(s).dropped, 2);
    cv_content_store_close(s);
    free_blob(&a);
    free_blob(&big);
    free_blob(&c);
    remove_dir(dir);
}

/* ---- threads ---- */

enum { THREADS = 8, HASHES = 24, ITERATIONS = 150 };

typedef struct shared {
    cv_content_store *store;
    blob blobs[HASHES];
} shared;

typedef struct worker {
    shared *sh;
    uint32_t seed;
    uint64_t has_calls, finished, gets_ok, gets_missing, aborts, busy, existed, bad;
} worker;

static void *work(void *p) {
    worker *w = p;
    uint32_t x = w->seed;
    for (int it = 0; it < ITERATIONS; it++) {
        x = x * 1664525u + 1013904223u;
        const blob *b = &w->sh->blobs[(x >> 8) % HASHES];
        w->has_calls++;
        if (cv_content_store_has(w->sh->store, b->sha)) {
            cv_content_blob *cb;
            cv_result r = cv_content_store_get(w->sh->store, b->sha, &cb);
            if (r == CV_OK) {
                w->gets_ok++;
                if (cv_content_blob_size(cb) != b->size || memcmp(cv_content_blob_data(cb), b->data, b->size) != 0)
                    w->bad++;
                cv_content_blob_release(cb);
            } else if (r == CV_ERROR_NOT_FOUND) {
                w->gets_missing++; /* evicted since has() */
            } else {
                w->bad++;
            }
            continue;
        }
        cv_content_upload *u;
        cv_result r = cv_content_upload_begin(w->sh->store, b->sha, b->size, &u);
        if (r == CV_ERROR_ALREADY_EXISTS) {
            w->existed++;
            continue;
        }
        if (r == CV_ERROR_BAD_STATE) {
            w->busy++;
            continue;
        }
        if (r != CV_OK) {
            w->bad++;
            continue;
        }
        bool abort_it = (x >> 20) % 8 == 0;
        for (size_t off = 0; off < b->size && r == CV_OK; off += 4096) {
            size_t n = b->size - off < 4096 ? b->size - off : 4096;
            r = cv_content_upload_write(u, off, b->data + off, n);
            if (abort_it && off >= b->size / 2)
                break;
        }
        if (r != CV_OK)
            w->bad++;
        if (abort_it || r != CV_OK) {
            cv_content_upload_abort(u);
            w->aborts++;
        } else if (cv_content_upload_finish(u) == CV_OK) {
            w->finished++;
        } else {
            w->bad++;
        }
    }
    return NULL;
}

static void test_threads(void) {
    char dir[64];
    make_dir(dir);
    shared sh;
    uint64_t max_bytes = 0, total = 0;
    for (int i = 0; i < HASHES; i++) {
        sh.blobs[i] = make_blob(100 + (uint32_t)i, 4096 + (size_t)i * 3001);
        total += sh.blobs[i].size;
    }
    /* Room for two thirds of them, and more than the pins and reservations
     * of 8 threads (each holds at most one blob) can take: begin always
     * finds something to evict. */
    max_bytes = total * 2 / 3;
    CHECK(max_bytes > 8 * sh.blobs[HASHES - 1].size);
    CHECK_OK(cv_content_store_open(dir, max_bytes, &sh.store));

    worker w[THREADS];
    pthread_t tid[THREADS];
    for (int i = 0; i < THREADS; i++) {
        w[i] = (worker){ .sh = &sh, .seed = 7u + (uint32_t)i * 7919u };
        CHECK_EQ_INT(pthread_create(&tid[i], NULL, work, &w[i]), 0);
    }
    worker sum = { 0 };
    for (int i = 0; i < THREADS; i++) {
        pthread_join(tid[i], NULL);
        sum.has_calls += w[i].has_calls;
        sum.finished += w[i].finished;
        sum.gets_ok += w[i].gets_ok;
        sum.gets_missing += w[i].gets_missing;
        sum.aborts += w[i].aborts;
        sum.bad += w[i].bad;
    }
    CHECK_EQ_INT(sum.bad, 0);
    CHECK(sum.finished > 0 && sum.gets_ok > 0 && sum.aborts > 0);

    cv_content_stats st = cv_content_store_stats(sh.store);
    CHECK_EQ_INT(st.hits + st.misses, sum.has_calls);
    CHECK_EQ_INT(st.uploads, sum.finished);
    CHECK_EQ_INT(st.rejected, 0);
    CHECK_EQ_INT(st.dropped, 0);
    CHECK_EQ_INT(st.evictions, st.uploads - st.entries);
    CHECK(st.bytes <= max_bytes);
    CHECK(st.evictions > 0);
    uint64_t bytes_on_disk = 0, entries_on_disk = 0;
    for (int i = 0; i < HASHES; i++) {
        if (on_disk(dir, &sh.blobs[i])) {
            bytes_on_disk += sh.blobs[i].size;
            entries_on_disk++;
            CHECK(get_matches(sh.store, &sh.blobs[i]));
        }
    }
    CHECK_EQ_INT(bytes_on_disk, st.bytes);
    CHECK_EQ_INT(entries_on_disk, st.entries);
    CHECK_EQ_INT(entries_in(dir, "tmp"), 0);
    printf(
        "threads: %llu has (%llu hits), %llu uploads, %llu aborts, %llu gets, %llu evicted between has and get, "
        "%llu evictions\n",
        (unsigned long long)sum.has_calls, (unsigned long long)st.hits, (unsigned long long)sum.finished,
        (unsigned long long)sum.aborts, (unsigned long long)sum.gets_ok, (unsigned long long)sum.gets_missing,
        (unsigned long long)st.evictions);
    cv_content_store_close(sh.store);
    for (int i = 0; i < HASHES; i++)
        free_blob(&sh.blobs[i]);
    remove_dir(dir);
}

/* ---- one blob, several uploaders ---- */

typedef struct same_blob {
    cv_content_store *store;
    const blob *b;
    pthread_barrier_t *start; /* NULL: go at once */
    cv_result begin, finish;
} same_blob;

static void *upload_same(void *p) {
    same_blob *w = p;
    if (w->start)
        pthread_barrier_wait(w->start);
    cv_content_upload *u;
    w->begin = cv_content_upload_begin(w->store, w->b->sha, w->b->size, &u);
    w->finish = CV_OK;
    if (w->begin != CV_OK)
        return NULL;
    for (size_t off = 0; off < w->b->size && w->finish == CV_OK; off += 65536) {
        size_t n = w->b->size - off < 65536 ? w->b->size - off : 65536;
        w->finish = cv_content_upload_write(u, off, w->b->data + off, n);
    }
    if (w->finish == CV_OK)
        w->finish = cv_content_upload_finish(u);
    else
        cv_content_upload_abort(u);
    return NULL;
}

/* Eight threads upload one blob at the same moment: every one succeeds
 * (stored, or told it already is), and the blob is stored once. */
static void test_same_blob_threads(void) {
    char dir[64];
    make_dir(dir);
    cv_content_store *s;
    CHECK_OK(cv_content_store_open(dir, 0, &s));
    blob b = make_blob(50, (2u << 20) + 5);
    pthread_barrier_t start;
    pthread_barrier_init(&start, NULL, THREADS);
    same_blob w[THREADS];
    pthread_t tid[THREADS];
    for (int i = 0; i < THREADS; i++) {
        w[i] = (same_blob){ .store = s, .b = &b, .start = &start };
        CHECK_EQ_INT(pthread_create(&tid[i], NULL, upload_same, &w[i]), 0);
    }
    int stored = 0;
    for (int i = 0; i < THREADS; i++) {
        pthread_join(tid[i], NULL);
        CHECK(w[i].begin == CV_OK || w[i].begin == CV_ERROR_ALREADY_EXISTS);
        CHECK_OK(w[i].finish);
        stored += w[i].begin == CV_OK;
    }
    pthread_barrier_destroy(&start);
    cv_content_stats st = cv_content_store_stats(s);
    CHECK(stored >= 1);
    CHECK_EQ_INT(st.uploads, 1);
    CHECK_EQ_INT(st.uploads + st.duplicates, stored);
    CHECK_EQ_INT(st.entries, 1);
    CHECK_EQ_INT(st.bytes, b.size);
    CHECK_EQ_INT(st.rejected, 0);
    CHECK(get_matches(s, &b));
    CHECK_EQ_INT(entries_in(dir, "tmp"), 0);
    printf("same blob: %d threads, %llu waited, %d received it\n", THREADS, (unsigned long long)st.waits, stored);
    cv_content_store_close(s);
    free_blob(&b);
    remove_dir(dir);
}

/* Polls (bounded) until `waits` begins have started waiting. */
static bool await_waits(cv_content_store *s, uint64_t waits) {
    for (int i = 0; i < 2000; i++) {
        if (cv_content_store_stats(s).waits >= waits)
            return true;
        usleep(5000);
    }
    return false;
}

/* A waiter whose first uploader aborts receives the blob itself; one whose
 * first uploader stalls past the upload wait receives it beside it, and
 * whichever finishes first stores it; a late copy replaces a stored copy
 * found damaged meanwhile. */
static void test_waiter_after_abort_and_stall(void) {
    char dir[64];
    make_dir(dir);
    cv_content_store *s;
    CHECK_OK(cv_content_store_open(dir, 0, &s));
    blob a = make_blob(60, 300000), b = make_blob(61, 300000);

    cv_content_upload *first;
    CHECK_OK(cv_content_upload_begin(s, a.sha, a.size, &first));
    CHECK_OK(cv_content_upload_write(first, 0, a.data, 1000));
    same_blob w = { .store = s, .b = &a };
    pthread_t tid;
    CHECK_EQ_INT(pthread_create(&tid, NULL, upload_same, &w), 0);
    CHECK(await_waits(s, 1));
    cv_content_upload_abort(first); /* the first uploader's session ended */
    pthread_join(tid, NULL);
    CHECK_OK(w.begin);
    CHECK_OK(w.finish);
    CHECK(get_matches(s, &a));

    cv_content_store_set_upload_wait(s, 100);
    CHECK_OK(cv_content_upload_begin(s, b.sha, b.size, &first));
    CHECK_OK(cv_content_upload_write(first, 0, b.data, 1000)); /* ... and nothing more for a while */
    w = (same_blob){ .store = s, .b = &b };
    CHECK_EQ_INT(pthread_create(&tid, NULL, upload_same, &w), 0);
    pthread_join(tid, NULL);
    CHECK_OK(w.begin);
    CHECK_OK(w.finish);
    CHECK(get_matches(s, &b));
    CHECK_OK(cv_content_upload_write(first, 1000, b.data + 1000, b.size - 1000));
    CHECK_OK(cv_content_upload_finish(first)); /* stored already: its copy goes */
    CHECK(get_matches(s, &b));

    /* A late copy of a blob that was stored and then found damaged takes its place. */
    blob c = make_blob(62, 5000);
    char path[512];
    cv_content_store_set_upload_wait(s, 0);
    cv_content_upload *late;
    CHECK_OK(cv_content_upload_begin(s, c.sha, c.size, &first));
    CHECK_OK(cv_content_upload_begin(s, c.sha, c.size, &late));
    CHECK_OK(cv_content_upload_write(first, 0, c.data, c.size));
    CHECK_OK(cv_content_upload_finish(first));
    flip_byte(path_of(dir, &c, path), 100);
    CHECK(!cv_content_store_has(s, c.sha));
    CHECK_OK(cv_content_upload_write(late, 0, c.data, c.size));
    CHECK_OK(cv_content_upload_finish(late));
    CHECK(get_matches(s, &c));

    cv_content_stats st = cv_content_store_stats(s);
    CHECK_EQ_INT(st.waits, 2);
    CHECK_EQ_INT(st.uploads, 4);
    CHECK_EQ_INT(st.duplicates, 1);
    CHECK_EQ_INT(st.dropped, 1);
    CHECK_EQ_INT(st.entries, 3);
    CHECK_EQ_INT(st.bytes, a.size + b.size + c.size);
    CHECK_EQ_INT(entries_in(dir, "tmp"), 0);
    cv_content_store_close(s);
    free_blob(&a);
    free_blob(&b);
    free_blob(&c);
    remove_dir(dir);
}

/* Hashes that share their first 8 bytes (the index's key) live side by side: uploads of two such
 * made-up hashes beside a stored blob, ended in every order, leave the blob found and whole. */
static void test_shared_key(void) {
    char dir[64];
    make_dir(dir);
    cv_content_store *s;
    CHECK_OK(cv_content_store_open(dir, 0, &s));
    blob a = make_blob(11, 1000);
    CHECK_OK(upload(s, &a, 1000));
    uint8_t x[32], y[32];
    memcpy(x, a.sha, 32);
    memcpy(y, a.sha, 32);
    x[31] ^= 1;
    y[20] ^= 1;
    cv_content_upload *ux, *uy;
    CHECK_OK(cv_content_upload_begin(s, x, 10, &ux));
    CHECK_OK(cv_content_upload_begin(s, y, 10, &uy));
    CHECK(cv_content_store_has(s, a.sha) && !cv_content_store_has(s, x) && !cv_content_store_has(s, y));
    cv_content_upload_abort(ux); /* the middle of the three */
    CHECK(get_matches(s, &a));
    CHECK_OK(cv_content_upload_begin(s, x, 10, &ux));
    CHECK_OK(cv_content_upload_write(uy, 0, a.data, 10));
    CHECK_RESULT(cv_content_upload_finish(uy), CV_ERROR_HASH_MISMATCH); /* the middle again */
    cv_content_upload_abort(ux);                                        /* the first, the blob after it */
    CHECK(get_matches(s, &a));
    CHECK_RESULT(cv_content_upload_begin(s, a.sha, a.size, &ux), CV_ERROR_ALREADY_EXISTS);
    CHECK_EQ_INT(cv_content_store_stats(s).entries, 1);
    cv_content_store_close(s);
    free_blob(&a);
    remove_dir(dir);
}

int main(void) {
    test_upload_and_get();
    test_rejected_uploads();
    test_lru_and_restart();
    test_damage_and_strays();
    test_permissions();
    test_changed_while_open();
    test_threads();
    test_same_blob_threads();
    test_waiter_after_abort_and_stall();
    test_shared_key();
    return check_report("content_store");
}
