/* Asynchronous transfers through a ring of staging slots (transfer.h); on the
 * DEVICE path a ring has no slots and each transfer is one direct copy. The
 * slots are one staging per device over the same memory (SHARED: the
 * source's exported device memory, imported by the destination; HOST_IMPORT:
 * a host allocation of the ring's own, imported by both), made `owned` so the
 * backends neither cache nor share them. Per slot the ring remembers the
 * destination's ticket of its last read: the next write into the slot waits
 * for it on the GPU. Nothing here waits on the host except destroy. */
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <unistd.h>

#include "corvid/transfer.h"

#include "device_internal.h"
#include "transfer_job.h"

#define RING_MAX_SLOTS 64u

struct cv_transfer_ring {
    cv_device *src, *dst;
    cv_transfer_path path;
    uint64_t slot_bytes;
    uint32_t slots, next;
    void *src_staging, *dst_staging;
    void *host; /* HOST_IMPORT: the mapping (host_span bytes) */
    size_t host_span;
    uint64_t read[RING_MAX_SLOTS]; /* per slot: dst's ticket of its last read (0: none) */
    uint64_t src_last, dst_last;   /* the latest tickets of the ring's copies */
};

static cv_result ring_stagings(cv_transfer_ring *g) {
    uint64_t bytes = g->slot_bytes * g->slots;
    if (g->path == CV_TRANSFER_SHARED) {
        cv_staging_desc exported = { .kind = CV_STAGING_EXPORT, .size = bytes, .fd = -1, .owned = true };
        cv_result r = cv_device_link_staging(g->src, &exported, &g->src_staging);
        if (r != CV_OK)
            return r;
        cv_staging_desc imported = exported;
        imported.kind = CV_STAGING_IMPORT;
        r = cv_device_link_staging(g->dst, &imported, &g->dst_staging);
        if (imported.fd >= 0)
            close(imported.fd);
        return r;
    }
    cv_link_caps a, b;
    cv_device_link_caps(g->src, &a);
    cv_device_link_caps(g->dst, &b);
    uint64_t align = 4096;
    align = a.host_alignment > align ? a.host_alignment : align;
    align = b.host_alignment > align ? b.host_alignment : align;
    bytes = (bytes + align - 1) / align * align;
    g->host_span = bytes + align;
    void *raw = mmap(NULL, g->host_span, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (raw == MAP_FAILED) {
        g->host = NULL;
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "transfer ring '%s' -> '%s': %llu bytes of host memory",
                        cv_device_label(g->src), cv_device_label(g->dst), (unsigned long long)g->host_span);
    }
    g->host = raw;
    char *aligned = (char *)(((uintptr_t)raw + align - 1) / align * align);
    memset(aligned, 0, bytes); /* fault the pages in now, not during a frame */
    cv_staging_desc d = { .kind = CV_STAGING_HOST, .size = bytes, .fd = -1, .host = aligned, .owned = true };
    cv_result r = cv_device_link_staging(g->src, &d, &g->src_staging);
    if (r == CV_OK)
        r = cv_device_link_staging(g->dst, &d, &g->dst_staging);
    return r;
}

static void ring_free(cv_transfer_ring *g) {
    if (g->src_staging)
        cv_device_link_release(g->src, g->src_staging);
    if (g->dst_staging)
        cv_device_link_release(g->dst, g->dst_staging);
    if (g->host)
        munmap(g->host, g->host_span);
    free(g);
}

/* With imported-semaphore waits forced on either device (CORVID_CROSS_WAIT=import),
 * the pair must be able to wait on each other that way (backend.h, cv_link_caps). */
static cv_result ring_wait_check(cv_device *src, cv_device *dst) {
    cv_link_caps a, b;
    cv_device_link_caps(src, &a);
    cv_device_link_caps(dst, &b);
    if (!a.wait_import_required && !b.wait_import_required)
        return CV_OK;
    const char *why = !a.wait_import ? a.wait_missing : !b.wait_import ? b.wait_missing : NULL;
    cv_device *lacking = !a.wait_import ? src : dst;
    if (why)
        return cv_error(CV_ERROR_UNSUPPORTED,
                        "transfer ring '%s' -> '%s': CORVID_CROSS_WAIT=import, but '%s' lacks %s",
                        cv_device_label(src), cv_device_label(dst), cv_device_label(lacking), why);
    if (memcmp(a.driver_uuid, b.driver_uuid, 16) || memcmp(a.device_uuid, b.device_uuid, 16))
        return cv_error(CV_ERROR_UNSUPPORTED,
                        "transfer ring '%s' -> '%s': CORVID_CROSS_WAIT=import, but the devices are on different "
                        "adapters or drivers (semaphores are imported within one physical device only)",
                        cv_device_label(src), cv_device_label(dst));
    return CV_OK;
}

cv_result cv_transfer_ring_create(cv_device *src, cv_device *dst, uint64_t slot_bytes, uint32_t slots,
                                  cv_transfer_ring **out) {
    if (!src || !dst || !out)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_transfer_ring_create: NULL argument");
    *out = NULL;
    if (src == dst)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_transfer_ring_create: source and destination are both '%s'",
                        cv_device_label(src));
    if (slots < 2 || slots > RING_MAX_SLOTS || slot_bytes < 256 || slot_bytes % 256 ||
        slot_bytes > (UINT64_C(1) << 34) / slots)
        return cv_error(CV_ERROR_OUT_OF_RANGE,
                        "transfer ring '%s' -> '%s': %u slots of %llu bytes (2..%u slots, multiples of 256 bytes, "
                        "16 GiB in all)",
                        cv_device_label(src), cv_device_label(dst), slots, (unsigned long long)slot_bytes,
                        RING_MAX_SLOTS);
    cv_transfer_path path;
    cv_result r = cv_transfer_choose_path(src, dst, &path);
    if (r != CV_OK)
        return r;
    cv_device *without = !cv_device_link_async(src) ? src : !cv_device_link_async(dst) ? dst : NULL;
    if (path == CV_TRANSFER_DEVICE) /* one direct copy per transfer: no slots, no cross-device import */
        without = NULL;
    if (path == CV_TRANSFER_STAGED || without)
        return cv_error(CV_ERROR_UNSUPPORTED, "transfer ring '%s' -> '%s': %s", cv_device_label(src),
                        cv_device_label(dst),
                        without ? "a device has no asynchronous link copies" : "the pair's path is staged");
    r = path == CV_TRANSFER_DEVICE ? CV_OK : ring_wait_check(src, dst);
    if (r != CV_OK)
        return r;
    cv_transfer_ring *g = calloc(1, sizeof(*g));
    if (!g)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "transfer ring");
    *g = (cv_transfer_ring){ .src = src, .dst = dst, .path = path, .slot_bytes = slot_bytes, .slots = slots };
    r = path == CV_TRANSFER_DEVICE ? CV_OK : ring_stagings(g);
    if (r != CV_OK) {
        ring_free(g);
        return r;
    }
    *out = g;
    return CV_OK;
}

void cv_transfer_ring_destroy(cv_transfer_ring *g) {
    if (!g)
        return;
    /* Both devices must be done with the slots before they go (failures: a lost device, nothing to wait for). */
    if (g->src_last)
        cv_device_wait(g->src, g->src_last, UINT64_MAX);
    if (g->dst_last)
        cv_device_wait(g->dst, g->dst_last, UINT64_MAX);
    ring_free(g);
}

cv_transfer_path cv_transfer_ring_path(const cv_transfer_ring *g) { return g ? g->path : CV_TRANSFER_AUTO; }

/* One piece through the next slot: the source's copy after the slot's last read, the destination's after it. */
static cv_result ring_piece(cv_transfer_ring *g, const transfer_job *j, uint64_t at, uint64_t n, uint32_t first,
                            uint32_t rows) {
    uint32_t slot = g->next;
    uint64_t where = slot * g->slot_bytes;
    cv_rect src_rect = { 0 }, dst_rect = { 0 };
    if (j->texture) {
        src_rect = (cv_rect){ j->src_rect.x, j->src_rect.y + first, j->src_rect.width, rows };
        dst_rect = (cv_rect){ j->dst_x, j->dst_y + first, j->src_rect.width, rows };
        n = 0;
    }
    uint64_t t_src = 0, t_dst = 0;
    cv_result r = cv_device_link_copy_async(g->src, g->src_staging, where, j->src_id, j->src_offset + at, n, src_rect,
                                            true, g->dst, g->read[slot], &t_src);
    if (r != CV_OK)
        return r;
    g->src_last = t_src;
    g->next = (slot + 1) % g->slots;
    r = cv_device_link_copy_async(g->dst, g->dst_staging, where, j->dst_id, j->dst_offset + at, n, dst_rect, false,
                                  g->src, t_src, &t_dst);
    if (r != CV_OK)
        return r;
    g->dst_last = t_dst;
    g->read[slot] = t_dst;
    return CV_OK;
}

static cv_result ring_run(cv_transfer_ring *g, const transfer_job *j, cv_transfer_async *out) {
    if (j->src != g->src || j->dst != g->dst) /* (the job was made from the ring's devices) */
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "transfer ring: wrong devices");
    cv_result r = CV_OK;
    if (g->path == CV_TRANSFER_DEVICE) {
        uint64_t ts, td;
        r = transfer_job_device(j, &ts, &td);
        if (r == CV_OK)
            g->src_last = ts, g->dst_last = td;
    } else if (j->texture) {
        uint32_t per = (uint32_t)(g->slot_bytes / j->row_bytes);
        if (per == 0)
            return cv_error(CV_ERROR_OUT_OF_RANGE,
                            "transfer ring '%s' -> '%s': a row of %llu bytes does not fit a %llu-byte slot",
                            cv_device_label(g->src), cv_device_label(g->dst), (unsigned long long)j->row_bytes,
                            (unsigned long long)g->slot_bytes);
        for (uint32_t first = 0; first < j->src_rect.height && r == CV_OK; first += per) {
            uint32_t rows = j->src_rect.height - first < per ? j->src_rect.height - first : per;
            r = ring_piece(g, j, 0, 0, first, rows);
        }
    } else {
        for (uint64_t at = 0; at < j->size && r == CV_OK; at += g->slot_bytes)
            r = ring_piece(g, j, at, j->size - at < g->slot_bytes ? j->size - at : g->slot_bytes, 0, 0);
    }
    if (r == CV_OK && out)
        *out = (cv_transfer_async){
            .bytes = j->size, .src_ticket = g->src_last, .dst_ticket = g->dst_last, .path = g->path
        };
    return r;
}

cv_result cv_transfer_buffer_async(cv_transfer_ring *g, cv_buffer src_buffer, uint64_t src_offset,
                                   cv_buffer dst_buffer, uint64_t dst_offset, uint64_t size, cv_transfer_async *out) {
    if (!g)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_transfer_buffer_async: NULL ring");
    transfer_job j;
    cv_result r = transfer_buffer_job(g->src, src_buffer, src_offset, g->dst, dst_buffer, dst_offset, size, &j);
    return r == CV_OK ? ring_run(g, &j, out) : r;
}

cv_result cv_transfer_texture_async(cv_transfer_ring *g, cv_texture src_texture, cv_rect src_rect,
                                    cv_texture dst_texture, uint32_t dst_x, uint32_t dst_y, cv_transfer_async *out) {
    if (!g)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_transfer_texture_async: NULL ring");
    transfer_job j;
    cv_result r = transfer_texture_job(g->src, src_texture, src_rect, g->dst, dst_texture, dst_x, dst_y, &j);
    return r == CV_OK ? ring_run(g, &j, out) : r;
}
