/* Cross-device transfers (see transfer.h): checks, the choice of path, and
 * the pipeline every path runs on. Both sides are checked before any byte
 * moves. Transfers larger than one chunk are pipelined over two staging
 * slots: a reader thread fills one slot from the source device while the
 * calling thread empties the other into the destination, so reading and
 * writing overlap. The slots are host memory (STAGED: the device read/write
 * calls, any two backends) or memory both devices reach (SHARED, HOST_IMPORT:
 * the backends' link calls, GPU copies on each side, transfer_link.c). */
#include "corvid/transfer.h"

#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "corvid/clock.h"
#include "device_internal.h"
#include "transfer_job.h"
#include "transfer_link.h"
#include "transfer_peer.h"

#define CHUNK_BYTES (4u << 20) /* bench_transfer measures this size (bench/README.md) */
_Static_assert((uint64_t)CV_MAX_TEXTURE_DIM * 16 <= CHUNK_BYTES, "a texture row fits one staging slot");

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

/* Moves `chunks` pieces through two staging slots: io(job, i, slot 0 or 1, read). */
typedef cv_result (*chunk_io)(void *job, uint64_t chunk, uint32_t slot, bool read);

typedef struct pipeline {
    chunk_io io;
    void *job;
    uint64_t chunks;
    pthread_mutex_t lock;
    pthread_cond_t changed;
    uint64_t filled;  /* chunks read so far */
    uint64_t emptied; /* chunks written so far */
    cv_result read_result;
    char read_error[512];
    bool stop; /* the writer failed: the reader must stop */
    double read_ms;
} pipeline;

static void *reader(void *arg) {
    pipeline *p = arg;
    for (uint64_t i = 0; i < p->chunks; i++) {
        pthread_mutex_lock(&p->lock);
        while (i >= p->emptied + 2 && !p->stop) /* both slots hold unwritten chunks */
            pthread_cond_wait(&p->changed, &p->lock);
        bool stop = p->stop;
        pthread_mutex_unlock(&p->lock);
        if (stop)
            return NULL;
        double t0 = cv_now_ms();
        cv_result r = p->io(p->job, i, (uint32_t)(i % 2), true);
        pthread_mutex_lock(&p->lock);
        p->read_ms += cv_now_ms() - t0;
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

/* Each chunk fits one staging slot of the path. */
static cv_result run_pipeline(chunk_io io, void *job, uint64_t chunks, cv_transfer_stats *st) {
    pipeline p = { .io = io, .job = job, .chunks = chunks };
    double t0 = cv_now_ms(), write_ms = 0.0;
    cv_result r = CV_OK;
    if (chunks == 1) { /* nothing to overlap */
        r = io(job, 0, 0, true);
        double t1 = cv_now_ms();
        p.read_ms = t1 - t0;
        if (r == CV_OK)
            r = io(job, 0, 0, false);
        write_ms = cv_now_ms() - t1;
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
                double tw = cv_now_ms();
                r = io(job, i, (uint32_t)(i % 2), false);
                write_ms += cv_now_ms() - tw;
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
    if (r == CV_OK && st) {
        st->read_ms = p.read_ms;
        st->write_ms = write_ms;
        st->total_ms = cv_now_ms() - t0;
    }
    return r;
}

/* ---- the moves: one job per transfer, one chunk at a time ---------------------- */

/* Chunk i as a buffer range (offset from the start of the transfer, size) or as rows. */
static void chunk_extent(const transfer_job *j, uint64_t i, uint64_t *at, uint64_t *n, uint32_t *first,
                         uint32_t *rows) {
    *at = i * j->chunk_bytes;
    *n = j->size - *at < j->chunk_bytes ? j->size - *at : j->chunk_bytes;
    if (j->texture) {
        *first = (uint32_t)i * j->rows_per_chunk;
        *rows = j->src_rect.height - *first < j->rows_per_chunk ? j->src_rect.height - *first : j->rows_per_chunk;
    }
}

static cv_result staged_chunk(void *arg, uint64_t i, uint32_t slot, bool read) {
    const transfer_job *j = arg;
    uint64_t at, n;
    uint32_t first = 0, rows = 0;
    chunk_extent(j, i, &at, &n, &first, &rows);
    if (j->texture)
        return read ? cv_device_read_texture(j->src, (cv_texture){ j->src_id },
                                             (cv_rect){ j->src_rect.x, j->src_rect.y + first, j->src_rect.width,
                                                        rows },
                                             j->host[slot])
                    : cv_device_write_texture(j->dst, (cv_texture){ j->dst_id },
                                              (cv_rect){ j->dst_x, j->dst_y + first, j->src_rect.width, rows },
                                              j->host[slot]);
    return read ? cv_device_read_buffer(j->src, (cv_buffer){ j->src_id }, j->src_offset + at, n, j->host[slot])
                : cv_device_write_buffer(j->dst, (cv_buffer){ j->dst_id }, j->dst_offset + at, n, j->host[slot]);
}

static cv_result link_chunk(void *arg, uint64_t i, uint32_t slot, bool read) {
    const transfer_job *j = arg;
    uint64_t at, n;
    uint32_t first = 0, rows = 0;
    chunk_extent(j, i, &at, &n, &first, &rows);
    uint64_t where = slot * j->chunk_bytes;
    if (j->texture)
        return read ? cv_device_link_copy(j->src, j->link.src_staging, where, j->src_id, 0, 0,
                                          (cv_rect){ j->src_rect.x, j->src_rect.y + first, j->src_rect.width, rows },
                                          true)
                    : cv_device_link_copy(j->dst, j->link.dst_staging, where, j->dst_id, 0, 0,
                                          (cv_rect){ j->dst_x, j->dst_y + first, j->src_rect.width, rows }, false);
    return read ? cv_device_link_copy(j->src, j->link.src_staging, where, j->src_id, j->src_offset + at, n,
                                      (cv_rect){ 0 }, true)
                : cv_device_link_copy(j->dst, j->link.dst_staging, where, j->dst_id, j->dst_offset + at, n,
                                      (cv_rect){ 0 }, false);
}

/* Runs a checked job on the path chosen for the pair. */
static cv_result run_job(transfer_job *j, cv_transfer_stats *stats) {
    cv_transfer_path path;
    cv_result r = cv_transfer_choose_path(j->src, j->dst, &path);
    if (r != CV_OK)
        return r;
    if (path == CV_TRANSFER_PEER) /* node to node, in stream order: transfer_peer.c */
        return cv_transfer_peer_run(&(cv_transfer_peer_region){ j->src, j->dst, j->src_id, j->dst_id, j->texture,
                                                                j->src_rect, j->dst_x, j->dst_y, j->src_offset,
                                                                j->dst_offset, j->size },
                                    stats);
    cv_transfer_stats st = { .bytes = j->size, .path = path };
    if (path == CV_TRANSFER_DEVICE) { /* one GPU copy between instances of one device, then a host wait */
        double start = cv_now_ms();
        uint64_t ts, td;
        r = transfer_job_device(j, &ts, &td);
        if (r == CV_OK)
            r = cv_device_wait(j->dst, td, UINT64_MAX);
        st.total_ms = st.write_ms = cv_now_ms() - start;
        if (r == CV_OK && stats)
            *stats = st;
        return r;
    }
    if (path == CV_TRANSFER_STAGED) {
        j->chunk_bytes = CHUNK_BYTES;
    } else {
        r = transfer_link_acquire(j->src, j->dst, path, &j->link);
        if (r != CV_OK)
            return r;
        j->chunk_bytes = j->link.slot_bytes;
    }
    uint64_t chunks;
    if (j->texture) {
        /* A row is at most CV_MAX_TEXTURE_DIM * 16 bytes = 256 KiB, well under a chunk. */
        j->rows_per_chunk = (uint32_t)(j->chunk_bytes / j->row_bytes);
        if (j->rows_per_chunk > j->src_rect.height)
            j->rows_per_chunk = j->src_rect.height;
        chunks = (j->src_rect.height + j->rows_per_chunk - 1) / j->rows_per_chunk;
        j->chunk_bytes = (uint64_t)j->rows_per_chunk * j->row_bytes;
    } else {
        chunks = (j->size + j->chunk_bytes - 1) / j->chunk_bytes;
    }
    if (path == CV_TRANSFER_STAGED) {
        j->host[0] = slot_take();
        j->host[1] = chunks > 1 ? slot_take() : NULL;
        if (!j->host[0] || (chunks > 1 && !j->host[1]))
            r = cv_error(CV_ERROR_OUT_OF_MEMORY, "transfer: staging of %u bytes", CHUNK_BYTES);
        if (r == CV_OK)
            r = run_pipeline(staged_chunk, j, chunks, &st);
        slot_give(j->host[0]);
        slot_give(j->host[1]);
    } else {
        r = run_pipeline(link_chunk, j, chunks, &st);
        transfer_link_release(&j->link);
    }
    if (r == CV_OK && stats)
        *stats = st;
    return r;
}

cv_result transfer_job_device(const transfer_job *j, uint64_t *src_ticket, uint64_t *dst_ticket) {
    cv_link_region region = { .src_offset = j->src_offset,
                              .dst_offset = j->dst_offset,
                              .size = j->size,
                              .src_rect = j->src_rect,
                              .dst_x = j->dst_x,
                              .dst_y = j->dst_y };
    return cv_device_link_copy_device(j->src, j->src_id, j->dst, j->dst_id, &region, src_ticket, dst_ticket);
}

cv_result transfer_buffer_job(cv_device *src, cv_buffer src_buffer, uint64_t src_offset, cv_device *dst,
                              cv_buffer dst_buffer, uint64_t dst_offset, uint64_t size, transfer_job *out) {
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
    if (sd.type != CV_HANDLE_BUFFER || dd.type != CV_HANDLE_BUFFER)
        return cv_error(CV_ERROR_WRONG_HANDLE_TYPE,
                        "transfer: cv_transfer_buffer needs buffer handles, got a %s "
                        "on '%s' and a %s on '%s'",
                        cv_handle_type_name(sd.type), cv_device_label(src), cv_handle_type_name(dd.type),
                        cv_device_label(dst));
    if (size == 0 || src_offset > sd.buffer.size || size > sd.buffer.size - src_offset ||
        dst_offset > dd.buffer.size || size > dd.buffer.size - dst_offset)
        return cv_error(CV_ERROR_OUT_OF_RANGE,
                        "transfer of %llu bytes from '%s'+%llu (%llu bytes) to '%s'+%llu (%llu bytes) is out of "
                        "range",
                        (unsigned long long)size, sd.buffer.label, (unsigned long long)src_offset,
                        (unsigned long long)sd.buffer.size, dd.buffer.label, (unsigned long long)dst_offset,
                        (unsigned long long)dd.buffer.size);
    *out = (transfer_job){ .src = src,
                           .dst = dst,
                           .src_id = src_buffer.id,
                           .dst_id = dst_buffer.id,
                           .src_offset = src_offset,
                           .dst_offset = dst_offset,
                           .size = size };
    return CV_OK;
}

cv_result cv_transfer_buffer(cv_device *src, cv_buffer src_buffer, uint64_t src_offset, cv_device *dst,
                             cv_buffer dst_buffer, uint64_t dst_offset, uint64_t size, cv_transfer_stats *stats) {
    transfer_job j;
    cv_result r = transfer_buffer_job(src, src_buffer, src_offset, dst, dst_buffer, dst_offset, size, &j);
    return r == CV_OK ? run_job(&j, stats) : r;
}

cv_result transfer_texture_job(cv_device *src, cv_texture src_texture, cv_rect src_rect, cv_device *dst,
                               cv_texture dst_texture, uint32_t dst_x, uint32_t dst_y, transfer_job *out) {
    if (!src || !dst)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_transfer_texture: NULL device");
    if (!cv_device_has(src, cv_any(src_texture)) || !cv_device_has(dst, cv_any(dst_texture)))
        return cv_error(CV_ERROR_NOT_LOADED,
                        "transfer: texture 0x%016llx not loaded on '%s' or 0x%016llx not on '%s'",
                        (unsigned long long)src_texture.id, cv_device_label(src), (unsigned long long)dst_texture.id,
                        cv_device_label(dst));
    cv_resource_desc sd, dd;
    cv_result r = cv_context_describe(cv_device_context(src), cv_any(src_texture), &sd);
    if (r == CV_OK)
        r = cv_context_describe(cv_device_context(dst), cv_any(dst_texture), &dd);
    if (r != CV_OK)
        return r;
    if (sd.type != CV_HANDLE_TEXTURE || dd.type != CV_HANDLE_TEXTURE)
        return cv_error(CV_ERROR_WRONG_HANDLE_TYPE,
                        "transfer: cv_transfer_texture needs texture handles, got a %s "
                        "on '%s' and a %s on '%s'",
                        cv_handle_type_name(sd.type), cv_device_label(src), cv_handle_type_name(dd.type),
                        cv_device_label(dst));
    if (sd.texture.format != dd.texture.format)
        return cv_error(CV_ERROR_FORMAT_MISMATCH, "transfer: '%s' is %s but '%s' is %s", sd.texture.label,
                        cv_format_name(sd.texture.format), dd.texture.label, cv_format_name(dd.texture.format));
    if (src_rect.width == 0 || src_rect.height == 0 || src_rect.x > sd.texture.width ||
        src_rect.width > sd.texture.width - src_rect.x || src_rect.y > sd.texture.height ||
        src_rect.height > sd.texture.height - src_rect.y || dst_x > dd.texture.width ||
        src_rect.width > dd.texture.width - dst_x || dst_y > dd.texture.height ||
        src_rect.height > dd.texture.height - dst_y)
        return cv_error(CV_ERROR_OUT_OF_RANGE,
                        "transfer of %ux%u from '%s' (%ux%u) at (%u,%u) to '%s' (%ux%u) at "
                        "(%u,%u) is out of range",
                        src_rect.width, src_rect.height, sd.texture.label, sd.texture.width, sd.texture.height,
                        src_rect.x, src_rect.y, dd.texture.label, dd.texture.width, dd.texture.height, dst_x, dst_y);
    uint64_t row = (uint64_t)src_rect.width * cv_format_bytes(sd.texture.format);
    *out = (transfer_job){ .src = src,
                           .dst = dst,
                           .src_id = src_texture.id,
                           .dst_id = dst_texture.id,
                           .texture = true,
                           .src_rect = src_rect,
                           .dst_x = dst_x,
                           .dst_y = dst_y,
                           .row_bytes = row,
                           .size = row * src_rect.height };
    return CV_OK;
}

cv_result cv_transfer_texture(cv_device *src, cv_texture src_texture, cv_rect src_rect, cv_device *dst,
                              cv_texture dst_texture, uint32_t dst_x, uint32_t dst_y, cv_transfer_stats *stats) {
    transfer_job j;
    cv_result r = transfer_texture_job(src, src_texture, src_rect, dst, dst_texture, dst_x, dst_y, &j);
    return r == CV_OK ? run_job(&j, stats) : r;
}
