/* bench_content_store: the node's content store against plain files, side by
 * side in one run.
 *
 * For blob sizes from 64 KiB to 16 MiB, a set of distinct blobs (128 MiB in
 * all by default) goes through:
 *   upload      cv_content_upload_begin, _write in 1 MiB chunks, _finish
 *               (SHA-256 of every byte, pwrite into tmp/, rename, index), against
 *   write()     open, write() in the same chunks, close, of the same bytes to
 *               files in a plain folder on the same file system;
 *   get         cv_content_store_get, a read of every byte, _release (mmap of
 *               a blob hashed on arrival), against
 *   read()      open, read() of the whole file into a buffer, close, and the
 *               same pass over the bytes;
 *   get, cold   the same gets after closing and reopening the store: the first
 *               use hashes each blob (the check for damage done while closed).
 * Then one large blob (256 MiB by default) measures what the check against
 * blob files changed on disk costs: has() and get() of a file unchanged since
 * its hash (a stat), against get() of a file whose mtime changed (hashed
 * again), which is what hashing on every read would cost.
 * The SHA-256 rate of one thread over memory is printed for reference. Files
 * are not fsync()ed by either side, so this measures the page cache and the
 * code, not the disk. Each round uses fresh folders; the contenders run
 * interleaved, round by round, and the median round is reported. */
#include <fcntl.h>
#include <ftw.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "bench_util.h"
#include "content_store.h"
#include "corvid/sha256.h"

#define MAX_ROUNDS 50
#define CHUNK (1u << 20)

enum { UPLOAD, WRITE, GET, READ, GET_COLD, CONTENDERS };
static const char *const names[CONTENDERS] = { "upload", "write()", "get", "read()", "get cold" };

typedef struct options {
    uint64_t total, large;
    uint32_t rounds;
    const char *dir;
} options;

static void usage(FILE *f) {
    fprintf(f,
            "usage: bench_content_store [options]\n"
            "Uploads blobs into a content store and reads them back, against write() and read() of\n"
            "the same bytes to plain files.\n"
            "  --total MIB    bytes per blob size (default 128)\n"
            "  --rounds N     rounds, the median is reported (default 5, at most %d)\n"
            "  --large MIB    the large blob of the change-check figures (default 256)\n"
            "  --dir PATH     where the scratch folders go (default /tmp)\n"
            "  --quick        smoke run: 16 MiB, 1 round\n"
            "  --help         this text\n",
            MAX_ROUNDS);
}

static bool parse(int argc, char **argv, options *o) {
    *o = (options){ .total = 128u << 20, .large = 256u << 20, .rounds = 5, .dir = "/tmp" };
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (strcmp(a, "--help") == 0) {
            usage(stdout);
            exit(0);
        } else if (strcmp(a, "--quick") == 0) {
            o->total = 16u << 20;
            o->large = 32u << 20;
            o->rounds = 1;
        } else if (strcmp(a, "--total") == 0 && v) {
            o->total = strtoull(v, NULL, 10) << 20;
            i++;
        } else if (strcmp(a, "--rounds") == 0 && v) {
            o->rounds = (uint32_t)strtoul(v, NULL, 10);
            i++;
        } else if (strcmp(a, "--large") == 0 && v) {
            o->large = strtoull(v, NULL, 10) << 20;
            i++;
        } else if (strcmp(a, "--dir") == 0 && v) {
            o->dir = v;
            i++;
        } else {
            return false;
        }
    }
    return o->total > 0 && o->large > 0 && o->rounds > 0 && o->rounds <= MAX_ROUNDS;
}

static void fill(uint8_t *p, size_t n, uint64_t seed) {
    uint64_t x = seed * 0x9e3779b97f4a7c15ull + 1;
    for (size_t i = 0; i + 8 <= n; i += 8) {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        memcpy(p + i, &x, 8);
    }
}

/* Reads every byte, as a consumer of the blob would (and so that mmap's page
 * faults are paid). */
static uint64_t consume(const uint8_t *p, size_t n) {
    uint64_t sum = 0;
    for (size_t i = 0; i + 8 <= n; i += 8) {
        uint64_t w;
        memcpy(&w, p + i, 8);
        sum += w;
    }
    return sum;
}

static int remove_one(const char *path, const struct stat *st, int flag, struct FTW *ftw) {
    (void)st, (void)flag, (void)ftw;
    return remove(path);
}

static void fail(const char *what) {
    fprintf(stderr, "bench_content_store: %s failed: %s\n", what, cv_last_error());
    exit(1);
}

/* One round over `count` blobs of `size` bytes in data (count * size bytes);
 * fills seconds[contender]. */
static void round_once(const options *o, const uint8_t *data, size_t size, size_t count, const uint8_t (*sha)[32],
                       double *seconds, uint64_t *checksum) {
    char store_dir[512], plain_dir[512], path[600];
    snprintf(store_dir, sizeof store_dir, "%s/corvid-bench-store-XXXXXX", o->dir);
    snprintf(plain_dir, sizeof plain_dir, "%s/corvid-bench-plain-XXXXXX", o->dir);
    if (!mkdtemp(store_dir) || !mkdtemp(plain_dir))
        fail("mkdtemp");
    uint64_t limit = (uint64_t)size * count * 2;
    cv_content_store *s;
    if (cv_content_store_open(store_dir, limit, &s) != CV_OK)
        fail("open");

    double t = bench_now();
    for (size_t i = 0; i < count; i++) {
        cv_content_upload *u;
        const uint8_t *blob = data + i * size;
        if (cv_content_upload_begin(s, sha[i], size, &u) != CV_OK)
            fail("upload_begin");
        for (size_t off = 0; off < size; off += CHUNK) {
            size_t n = size - off < CHUNK ? size - off : CHUNK;
            if (cv_content_upload_write(u, off, blob + off, n) != CV_OK)
                fail("upload_write");
        }
        if (cv_content_upload_finish(u) != CV_OK)
            fail("upload_finish");
    }
    seconds[UPLOAD] = bench_now() - t;

    t = bench_now();
    for (size_t i = 0; i < count; i++) {
        snprintf(path, sizeof path, "%s/%zu", plain_dir, i);
        int fd = open(path, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
        const uint8_t *blob = data + i * size;
        for (size_t off = 0; fd >= 0 && off < size; off += CHUNK) {
            size_t n = size - off < CHUNK ? size - off : CHUNK;
            if (write(fd, blob + off, n) != (ssize_t)n)
                fail("write");
        }
        if (fd < 0 || close(fd) != 0)
            fail("open/close for write");
    }
    seconds[WRITE] = bench_now() - t;

    t = bench_now();
    for (size_t i = 0; i < count; i++) {
        cv_content_blob *b;
        if (cv_content_store_get(s, sha[i], &b) != CV_OK)
            fail("get");
        *checksum += consume(cv_content_blob_data(b), cv_content_blob_size(b));
        cv_content_blob_release(b);
    }
    seconds[GET] = bench_now() - t;

    uint8_t *buffer = malloc(size);
    t = bench_now();
    for (size_t i = 0; i < count; i++) {
        snprintf(path, sizeof path, "%s/%zu", plain_dir, i);
        int fd = open(path, O_RDONLY | O_CLOEXEC);
        if (fd < 0 || read(fd, buffer, size) != (ssize_t)size)
            fail("read");
        close(fd);
        *checksum -= consume(buffer, size);
    }
    seconds[READ] = bench_now() - t;
    free(buffer);

    cv_content_store_close(s);
    if (cv_content_store_open(store_dir, limit, &s) != CV_OK)
        fail("reopen");
    t = bench_now();
    for (size_t i = 0; i < count; i++) {
        cv_content_blob *b;
        if (cv_content_store_get(s, sha[i], &b) != CV_OK)
            fail("get after reopen");
        *checksum += consume(cv_content_blob_data(b), cv_content_blob_size(b));
        cv_content_blob_release(b);
    }
    seconds[GET_COLD] = bench_now() - t;
    cv_content_store_close(s);

    nftw(store_dir, remove_one, 16, FTW_DEPTH | FTW_PHYS);
    nftw(plain_dir, remove_one, 16, FTW_DEPTH | FTW_PHYS);
}

static int by_value(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

static double get_seconds(cv_content_store *s, const uint8_t sha[32], uint64_t *checksum) {
    double t = bench_now();
    cv_content_blob *b;
    if (cv_content_store_get(s, sha, &b) != CV_OK)
        fail("get");
    *checksum += consume(cv_content_blob_data(b), cv_content_blob_size(b));
    cv_content_blob_release(b);
    return bench_now() - t;
}

/* What the check for blob files changed on disk costs, on one large blob:
 * has() and get() of an unchanged file (a stat), and get() after its mtime
 * changed (the file is hashed again; what hashing on every read would cost). */
static void change_check(const options *o, uint64_t *checksum) {
    char dir[512], path[700], hex[CV_SHA256_HEX_SIZE];
    snprintf(dir, sizeof dir, "%s/corvid-bench-large-XXXXXX", o->dir);
    uint8_t *data = malloc(o->large), sha[32];
    if (!mkdtemp(dir) || data == NULL)
        fail("mkdtemp/malloc");
    fill(data, o->large, 7);
    cv_sha256(data, o->large, sha);
    cv_content_store *s;
    cv_content_upload *u;
    if (cv_content_store_open(dir, o->large * 2, &s) != CV_OK ||
        cv_content_upload_begin(s, sha, o->large, &u) != CV_OK)
        fail("open/upload_begin");
    for (uint64_t off = 0; off < o->large; off += CHUNK) {
        size_t n = o->large - off < CHUNK ? (size_t)(o->large - off) : CHUNK;
        if (cv_content_upload_write(u, off, data + off, n) != CV_OK)
            fail("upload_write");
    }
    if (cv_content_upload_finish(u) != CV_OK)
        fail("upload_finish");
    cv_sha256_hex(sha, hex);
    snprintf(path, sizeof path, "%s/objects/%.2s/%s", dir, hex, hex);

    enum { HAS_CALLS = 10000 };
    double t = bench_now();
    for (int i = 0; i < HAS_CALLS; i++)
        if (!cv_content_store_has(s, sha))
            fail("has");
    double has_us = (bench_now() - t) / HAS_CALLS * 1e6;
    double same[MAX_ROUNDS], changed[MAX_ROUNDS];
    for (uint32_t r = 0; r < o->rounds; r++) {
        same[r] = get_seconds(s, sha, checksum);
        struct timespec times[2] = { { 1000000000 + r, 0 }, { 1000000000 + r, 0 } };
        if (utimensat(AT_FDCWD, path, times, 0) != 0) /* "changed": the content stays right */
            fail("utimensat");
        changed[r] = get_seconds(s, sha, checksum);
    }
    qsort(same, o->rounds, sizeof(double), by_value);
    qsort(changed, o->rounds, sizeof(double), by_value);
    cv_content_stats st = cv_content_store_stats(s);
    if (st.dropped != 0)
        fail("an intact blob was dropped");
    printf(
        "\nOne %llu MiB blob (mapped): has(), file unchanged since its hash: %.1f us;\n"
        "get() + read + release, file unchanged: %.1f ms; file changed (hashed again): %.1f ms\n",
        (unsigned long long)(o->large >> 20), has_us, same[o->rounds / 2] * 1e3, changed[o->rounds / 2] * 1e3);
    cv_content_store_close(s);
    nftw(dir, remove_one, 16, FTW_DEPTH | FTW_PHYS);
    free(data);
}

int main(int argc, char **argv) {
    options o;
    if (!parse(argc, argv, &o)) {
        usage(stderr);
        return 2;
    }
    char machine[512];
    bench_machine(machine, sizeof machine);
    printf("bench_content_store: %s; scratch in %s; %llu MiB per size, %u rounds, median; not fsync()ed\n", machine,
           o.dir, (unsigned long long)(o.total >> 20), o.rounds);

    uint8_t *data = malloc(o.total);
    if (data == NULL)
        fail("malloc");
    fill(data, o.total, 1);
    uint8_t sha_check[32];
    double t = bench_now();
    cv_sha256(data, o.total, sha_check);
    printf("SHA-256 of one thread over memory: %.0f MB/s\n\n", (double)o.total / (bench_now() - t) / 1e6);

    printf("%10s %6s |", "blob", "blobs");
    for (int c = 0; c < CONTENDERS; c++)
        printf(" %10s", names[c]);
    printf(" | upload/write() get/read()\n");
    static const size_t sizes[] = { 64u << 10, 1u << 20, 16u << 20 };
    uint64_t checksum = 0;
    for (size_t si = 0; si < sizeof sizes / sizeof sizes[0]; si++) {
        size_t size = sizes[si], count = (size_t)(o.total / size);
        if (count == 0)
            continue;
        uint8_t(*sha)[32] = malloc(count * sizeof *sha);
        for (size_t i = 0; i < count; i++)
            cv_sha256(data + i * size, size, sha[i]);
        double seconds[CONTENDERS][MAX_ROUNDS];
        for (uint32_t r = 0; r < o.rounds; r++) {
            double one[CONTENDERS];
            round_once(&o, data, size, count, (const uint8_t(*)[32])sha, one, &checksum);
            for (int c = 0; c < CONTENDERS; c++)
                seconds[c][r] = one[c];
        }
        double mbs[CONTENDERS];
        for (int c = 0; c < CONTENDERS; c++) {
            qsort(seconds[c], o.rounds, sizeof(double), by_value);
            mbs[c] = (double)size * (double)count / seconds[c][o.rounds / 2] / 1e6;
        }
        printf("%7zu KiB %6zu |", size >> 10, count);
        for (int c = 0; c < CONTENDERS; c++)
            printf(" %10.0f", mbs[c]);
        printf(" | %13.2f %10.2f\n", mbs[UPLOAD] / mbs[WRITE], mbs[GET] / mbs[READ]);
        free(sha);
    }
    change_check(&o, &checksum);
    printf("\n(MB/s; checksum %llx)\n", (unsigned long long)checksum);
    free(data);
    return 0;
}
