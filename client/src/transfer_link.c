/* Staging memory for the SHARED and HOST_IMPORT transfer paths (see
 * transfer_link.h). The stagings themselves are the backends' (cached by
 * them until their device goes); this file asks for them and owns the one
 * host allocation of HOST_IMPORT: page-aligned anonymous memory, touched once
 * when it is made (first touch of fresh pages is slow, NOTES-STACK) and kept
 * for the life of the process, because the devices that imported it keep it
 * in their caches. */
#include <pthread.h>
#include <string.h>
#include <sys/mman.h>
#include <unistd.h>

#include "device_internal.h"
#include "transfer_link.h"

#define SLOT_BYTES (8ull << 20)
#define STAGING_BYTES (2 * SLOT_BYTES)

/* process-wide: devices import the one host region and cache the stagings they made (by key) for their whole
 * life, whatever their context, so the region is never unmapped and one lock serialises the link transfers
 * that reuse it. */
static pthread_mutex_t link_lock = PTHREAD_MUTEX_INITIALIZER;
static void *host_region; /* STAGING_BYTES at host_alignment; never unmapped */
static uint64_t host_alignment;

static cv_result host_memory(uint64_t alignment, void **out) {
    if (host_region && alignment <= host_alignment) {
        *out = host_region;
        return CV_OK;
    }
    /* (A device asking for more than the current region's alignment gets a
     * new region; the old one stays mapped for the devices that imported it.) */
    size_t span = STAGING_BYTES + alignment;
    void *raw = mmap(NULL, span, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (raw == MAP_FAILED)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "transfer: %llu bytes of host memory to import into devices",
                        (unsigned long long)span);
    char *aligned = (char *)(((uintptr_t)raw + alignment - 1) / alignment * alignment);
    memset(aligned, 0, STAGING_BYTES); /* fault every page in now, once */
    host_region = aligned;
    host_alignment = alignment;
    *out = aligned;
    return CV_OK;
}

cv_result transfer_link_acquire(cv_device *src, cv_device *dst, cv_transfer_path path, transfer_link *out) {
    memset(out, 0, sizeof(*out));
    out->slot_bytes = SLOT_BYTES;
    pthread_mutex_lock(&link_lock);
    cv_result r;
    if (path == CV_TRANSFER_SHARED) {
        cv_staging_desc exported = { .kind = CV_STAGING_EXPORT, .size = STAGING_BYTES, .fd = -1 };
        r = cv_device_link_staging(src, &exported, &out->src_staging);
        if (r == CV_OK) {
            cv_staging_desc imported = exported;
            imported.kind = CV_STAGING_IMPORT;
            r = cv_device_link_staging(dst, &imported, &out->dst_staging);
            if (imported.fd >= 0)
                close(imported.fd);
        }
    } else {
        cv_link_caps a, b;
        cv_device_link_caps(src, &a);
        cv_device_link_caps(dst, &b);
        uint64_t alignment = 4096;
        if (a.host_alignment > alignment)
            alignment = a.host_alignment;
        if (b.host_alignment > alignment)
            alignment = b.host_alignment;
        void *host = NULL;
        r = host_memory(alignment, &host);
        cv_staging_desc d = { .kind = CV_STAGING_HOST, .size = STAGING_BYTES, .fd = -1, .host = host };
        if (r == CV_OK)
            r = cv_device_link_staging(src, &d, &out->src_staging);
        if (r == CV_OK)
            r = cv_device_link_staging(dst, &d, &out->dst_staging);
    }
    if (r != CV_OK) {
        pthread_mutex_unlock(&link_lock);
        return r;
    }
    out->held = true;
    return CV_OK;
}

void transfer_link_release(transfer_link *link) {
    if (link->held)
        pthread_mutex_unlock(&link_lock);
    link->held = false;
}
