/* Cross-device transfers through host staging memory (see transfer.h).
 * Works between any two backends because it only uses the device read/write
 * calls; both sides are checked before any byte moves. Transfers larger than
 * one chunk are pipelined: a reader thread fills one staging slot from the
 * source device while the calling thread empties the other into the
 * destination, so reading and writing overlap. */
#include "corvid/transfer.h"

#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#define CHUNK_BYTES (4u << 20)   /* bench_transfer measures this size (bench/README.md) */
_Static_assert((uint64_t)CV_MAX_TEXTURE_DIM * 16 <= CHUNK_BYTES, "a texture row fits one staging slot");

static double now_ms(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec * 1e3 + ts.tv_nsec / 1e6;
}

/* Staging slots are kept between transfers (a few, process-wide): freeing
 * them let glibc hand the pages back to the kernel, and faulting them in again
 * made every other multi-chunk transfer 4-5x slower (bench_transfer). */
#define CACHED_SLOTS 4
static pthread_mutex_t slot_lock = PTHREAD_MUTEX_INITIALIZER;
static void *slot_cache[CACHED_SLOTS];
static uint32_t slot_cached;

static void *slot_take(void) {
    pthread_mutex_lock(&slot_lock);
    void *slot = slot_cached ? slot_cache[--slot_cached] : NULL;
    pthread_mutex_unlock(&slot_lock);
    return slot ? slot : malloc(CHUNK_BYTES);
}

static void slot_give(void *slot) {
    if (!slot)
        return;
    pthread_mutex_lock(&slot_lock);
    if (slot_cached < CACHED_SLOTS) {
        slot_cache[slot_cached++] = slot;
        slot = NULL;
    }
    pthread_mutex_unlock(&slot_lock);
    free(slot);
}

/* Moves `chunks` pieces through two staging slots: io(job, i, slot, read). */
typedef cv_result (*chunk_io)(void *job, uint64_t chunk, void *slot, bool read);

typedef struct pipeline {
    chunk_io io;
    void *job;
    uint64_t chunks;
    uint8_t *slots[2];
    pthread_mutex_t lock;
    pthread_cond_t changed;
    uint64_t filled;      /* chunks read so far */
    uint64_t emptied;     /* chunks written so far */
    cv_result read_result;
    char read_error[512];
    bool stop;            /* the writer failed: the reader must stop */
    double read_ms;
} pipeline;

static void *reader(void *arg) {
    pipeline *p = arg;
    for (uint64_t i = 0; i < p->chunks; i++) {
        pthread_mutex_lock(&p->lock);
        while (i >= p->emptied + 2 && !p->stop)   /* both slots hold unwritten chunks */
            pthread_cond_wait(&p->changed, &p->lock);
        bool stop = p->stop;
        pthread_mutex_unlock(&p->lock);
        if (stop)
            return NULL;
        double t0 = now_ms();
        cv_result r = p->io(p->job, i, p->slots[i % 2], true);
        pthread_mutex_lock(&p->lock);
        p->read_ms += now_ms() - t0;
        if (r != CV_OK) {
            p->read_result = r;
            snprintf(p->read_error, sizeof(p->read_error), "%s", cv_last_error());
        } else {
            p->filled = i + 1;
        }
        pthread_cond_broadcast(&p->changed);
        pthread_mutex_unlock(&p->lock);
        if (r != CV_OK)
            return NULL;
    }
    return NULL;
}

/* Each chunk is at most CHUNK_BYTES, the size of a staging slot. */
static cv_result run_pipeline(chunk_io io, void *job, uint64_t chunks, cv_transfer_stats *st) {
    pipeline p = { .io = io, .job = job, .chunks = chunks };
    double t0 = now_ms(), write_ms = 0.0;
    p.slots[0] = slot_take();
    p.slots[1] = chunks > 1 ? slot_take() : NULL;
    if (!p.slots[0] || (chunks > 1 && !p.slots[1])) {
        slot_give(p.slots[0]);
        slot_give(p.slots[1]);
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "transfer: staging of %u bytes", CHUNK_BYTES);
    }
    cv_result r = CV_OK;
    if (chunks == 1) {   /* nothing to overlap */
        r = io(job, 0, p.slots[0], true);
        double t1 = now_ms();
        p.read_ms = t1 - t0;
        if (r == CV_OK)
            r = io(job, 0, p.slots[0], false);
        write_ms = now_ms() - t1;
    } else {
        pthread_mutex_init(&p.lock, NULL);
        pthread_cond_init(&p.changed, NULL);
        pthread_t thread;
        if (pthread_create(&thread, NULL, reader, &p) != 0) {
            r = cv_error(CV_ERROR_OUT_OF_MEMORY, "transfer: cannot start the reader thread");
        } else {
            for (uint64_t i = 0; i < chunks && r == CV_OK; i++) {
                pthread_mutex_lock(&p.lock);
                while (p.filled <= i && p.read_result == CV_OK)
                    pthread_cond_wait(&p.changed, &p.lock);
                cv_result read_result = p.filled > i ? CV_OK : p.read_result;
                pthread_mutex_unlock(&p.lock);
                if (read_result != CV_OK) {
                    r = cv_error(read_result, "%s", p.read_error);
                    break;
                }
                double tw = now_ms();
                r = io(job, i, p.slots[i % 2], false);
                write_ms += now_ms() - tw;
                pthread_mutex_lock(&p.lock);
                p.emptied = i + 1;
                p.stop = r != CV_OK;
                pthread_cond_broadcast(&p.changed);
                pthread_mutex_unlock(&p.lock);
            }
            pthread_join(thread, NULL);
        }
        pthread_cond_destroy(&p.changed);
        pthread_mutex_destroy(&p.lock);
    }
    slot_give(p.slots[0]);
    slot_give(p.slots[1]);
    if (r == CV_OK && st) {
        st->read_ms = p.read_ms;
        st->write_ms = write_ms;
        st->total_ms = now_ms() - t0;
    }
    return r;
}

typedef struct buffer_job {
    cv_device *src, *dst;
    cv_buffer src_buffer, dst_buffer;
    uint64_t src_offset, dst_offset, size;
} buffer_job;

static cv_result buffer_chunk(void *arg, uint64_t i, void *slot, bool read) {
    const buffer_job *j = arg;
    uint64_t at = i * CHUNK_BYTES, n = j->size - at < CHUNK_BYTES ? j->size - at : CHUNK_BYTES;
    return read ? cv_device_read_buffer(j->src, j->src_buffer, j->src_offset + at, n, slot)
                : cv_device_write_buffer(j->dst, j->dst_buffer, j->dst_offset + at, n, slot);
}

typedef struct texture_job {
    cv_device *src, *dst;
    cv_texture src_texture, dst_texture;
    cv_rect src_rect;
    uint32_t dst_x, dst_y, rows_per_chunk;
} texture_job;

static cv_result texture_chunk(void *arg, uint64_t i, void *slot, bool read) {
    const texture_job *j = arg;
    uint32_t first = (uint32_t)i * j->rows_per_chunk;
    uint32_t rows = j->src_rect.height - first < j->rows_per_chunk ? j->src_rect.height - first : j->rows_per_chunk;
    return read ? cv_device_read_texture(j->src, j->src_texture,
                                         (cv_rect){ j->src_rect.x, j->src_rect.y + first, j->src_rect.width, rows }, slot)
                : cv_device_write_texture(j->dst, j->dst_texture,
                                          (cv_rect){ j->dst_x, j->dst_y + first, j->src_rect.width, rows }, slot);
}

cv_result cv_transfer_buffer(cv_device *src, cv_buffer src_buffer, uint64_t src_offset, cv_device *dst,
                             cv_buffer dst_buffer, uint64_t dst_offset, uint64_t size, cv_transfer_stats *stats) {
    if (!src || !dst)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_transfer_buffer: NULL device");
    if (!cv_device_has(src, cv_any(src_buffer)) || !cv_device_has(dst, cv_any(dst_buffer)))
        return cv_error(CV_ERROR_NOT_LOADED, "transfer: buffer 0x%016llx not loaded on '%s' or 0x%016llx not on '%s'",
                        (unsigned long long)src_buffer.id, cv_device_label(src), (unsigned long long)dst_buffer.id,
                        cv_device_label(dst));
    cv_resource_desc sd, dd;
    cv_result r = cv_context_describe(cv_device_context(src), cv_any(src_buffer), &sd);
    if (r == CV_OK)
        r = cv_context_describe(cv_device_context(dst), cv_any(dst_buffer), &dd);
    if (r != CV_OK)
        return r;
    if (size == 0 || src_offset > sd.buffer.size || size > sd.buffer.size - src_offset ||
        dst_offset > dd.buffer.size || size > dd.buffer.size - dst_offset)
        return cv_error(CV_ERROR_OUT_OF_RANGE,
                        "transfer of %llu bytes from '%s'+%llu (%llu bytes) to '%s'+%llu (%llu bytes) is out of range",
                        (unsigned long long)size, sd.buffer.label, (unsigned long long)src_offset,
                        (unsigned long long)sd.buffer.size, dd.buffer.label, (unsigned long long)dst_offset,
                        (unsigned long long)dd.buffer.size);
    buffer_job job = { src, dst, src_buffer, dst_buffer, src_offset, dst_offset, size };
    uint64_t chunks = (size + CHUNK_BYTES - 1) / CHUNK_BYTES;
    cv_transfer_stats st = { .bytes = size };
    r = run_pipeline(buffer_chunk, &job, chunks, &st);
    if (r == CV_OK && stats)
        *stats = st;
    return r;
}

cv_result cv_transfer_texture(cv_device *src, cv_texture src_texture, cv_rect src_rect, cv_device *dst,
                              cv_texture dst_texture, uint32_t dst_x, uint32_t dst_y, cv_transfer_stats *stats) {
    if (!src || !dst)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_transfer_texture: NULL device");
    if (!cv_device_has(src, cv_any(src_texture)) || !cv_device_has(dst, cv_any(dst_texture)))
        return cv_error(CV_ERROR_NOT_LOADED, "transfer: texture 0x%016llx not loaded on '%s' or 0x%016llx not on '%s'",
                        (unsigned long long)src_texture.id, cv_device_label(src),
                        (unsigned long long)dst_texture.id, cv_device_label(dst));
    cv_resource_desc sd, dd;
    cv_result r = cv_context_describe(cv_device_context(src), cv_any(src_texture), &sd);
    if (r == CV_OK)
        r = cv_context_describe(cv_device_context(dst), cv_any(dst_texture), &dd);
    if (r != CV_OK)
        return r;
    if (sd.texture.format != dd.texture.format)
        return cv_error(CV_ERROR_FORMAT_MISMATCH, "transfer: '%s' is %s but '%s' is %s", sd.texture.label,
                        cv_format_name(sd.texture.format), dd.texture.label, cv_format_name(dd.texture.format));
    if (src_rect.width == 0 || src_rect.height == 0 || src_rect.x > sd.texture.width ||
        src_rect.width > sd.texture.width - src_rect.x || src_rect.y > sd.texture.height ||
        src_rect.height > sd.texture.height - src_rect.y || dst_x > dd.texture.width ||
        src_rect.width > dd.texture.width - dst_x || dst_y > dd.texture.height ||
        src_rect.height > dd.texture.height - dst_y)
        return cv_error(CV_ERROR_OUT_OF_RANGE, "transfer of %ux%u from '%s' (%ux%u) at (%u,%u) to '%s' (%ux%u) at "
                        "(%u,%u) is out of range", src_rect.width, src_rect.height, sd.texture.label,
                        sd.texture.width, sd.texture.height, src_rect.x, src_rect.y, dd.texture.label,
                        dd.texture.width, dd.texture.height, dst_x, dst_y);
    uint64_t row = (uint64_t)src_rect.width * cv_format_bytes(sd.texture.format);
    /* A row is at most CV_MAX_TEXTURE_DIM * 16 bytes = 256 KiB, well under a chunk. */
    uint32_t rows_per_chunk = (uint32_t)(CHUNK_BYTES / row);
    if (rows_per_chunk > src_rect.height)
        rows_per_chunk = src_rect.height;
    texture_job job = { src, dst, src_texture, dst_texture, src_rect, dst_x, dst_y, rows_per_chunk };
    uint64_t chunks = (src_rect.height + rows_per_chunk - 1) / rows_per_chunk;
    cv_transfer_stats st = { .bytes = row * src_rect.height };
    cv_result res = run_pipeline(texture_chunk, &job, chunks, &st);
    if (res == CV_OK && stats)
        *stats = st;
    return res;
}
