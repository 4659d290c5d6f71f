/* The core device object, shared by device.c, validate.c and transfer.c. */
#ifndef CORVID_DEVICE_INTERNAL_H
#define CORVID_DEVICE_INTERNAL_H

#include <pthread.h>
#include <stdatomic.h>

#include "corvid/backend.h"
#include "corvid/device.h"

/* Staging slots a device keeps for STAGED transfers (see cv_device.slots). */
#define CV_DEVICE_CACHED_SLOTS 4

/* One table of representations per handle type, indexed by slot, grown on demand. */
typedef struct resource_table {
    cv_device_resource *slots;
    uint32_t capacity;
} resource_table;

/* A list compiled for this device (indexed by cmdlist slot). */
typedef struct compiled_list {
    uint64_t id;          /* cmdlist handle, 0 = none */
    uint32_t version;     /* list version it was compiled from */
    uint64_t epoch;       /* device resource epoch it was validated against */
    void *obj;            /* backend's compiled form */
    uint64_t last_ticket; /* latest submission, 0 = never submitted */
} compiled_list;

/* Something to release once the GPU has finished ticket `after`. */
typedef struct deferred_release {
    cv_handle_type type; /* CV_HANDLE_CMDLIST = a compiled list */
    void *obj;
    uint64_t after;
} deferred_release;

/* An encoder stream open on the device's machine (device_encode.c). */
typedef struct encoder_stream {
    uint32_t id;
    cv_codec codec;
    uint32_t width, height;
} encoder_stream;

struct cv_device {
    pthread_mutex_t lock;
    cv_context *ctx;
    const cv_backend *backend;
    cv_backend_device *bd;
    cv_device_info info;
    char label[CV_LABEL_MAX];
    resource_table tables[CV_HANDLE_TYPE_COUNT];
    compiled_list *compiled;
    uint32_t compiled_capacity;
    deferred_release *deferred;
    uint32_t deferred_count, deferred_capacity;
    /* Highest ticket submitted: written under the lock, read atomically by
     * cv_device_wait, which must not queue behind a host wait holding the lock
     * (a watchdog waits that way: cv_device_abandon). */
    _Atomic uint64_t last_ticket;
    atomic_bool abandoned; /* cv_device_abandon: host waits give up */
    uint64_t epoch;        /* bumps whenever a representation goes away */
    uint32_t loaded;       /* representations loaded (resources + compiled lists) */
    /* Host staging slots of STAGED transfers from this device (transfer.c), kept between transfers and freed
     * with the device. Their own lock: a transfer takes them without holding the device's. */
    pthread_mutex_t slots_lock;
    void *slots[CV_DEVICE_CACHED_SLOTS];
    uint32_t slot_count;
    /* Encoder streams open on the device's machine (under lock). */
    encoder_stream *streams;
    uint32_t stream_count, stream_capacity, last_stream;
};

/* Waits until no submitted work uses the resource (lock held), as host reads and
 * writes do (backend.h: orders_host_access); CV_ERROR_DEVICE_LOST once abandoned. */
cv_result cv_device_wait_for_resource(cv_device *dev, cv_device_resource *s);
/* Closes the encoder streams still open (lock held; device_encode.c), before the
 * backend's device goes. */
void cv_device_close_encoders(cv_device *dev);

/* Validates a list against this device's resources (lock held). validate.c */
cv_result cv_validate_list(cv_device *dev, const cv_command_list *list);

/* The representation of id if loaded; otherwise a cv_error saying why
 * (null, wrong type, stale, not loaded), naming `what`. Lock held. */
cv_result cv_device_require(cv_device *dev, uint64_t id, cv_handle_type type, const char *what,
                            cv_device_resource **out);

/* Cross-device link calls for transfer.c (backend.h: link_*), each under the
 * device lock. link_copy looks the resource up again (it may have gone since
 * the transfer checked it), waits until no submitted work uses it, and copies
 * `size` bytes at `offset` of a buffer, or `rect` of a texture. */
bool cv_device_link_caps(cv_device *dev, cv_link_caps *out); /* false: the backend has no links */
cv_result cv_device_link_staging(cv_device *dev, cv_staging_desc *desc, void **out);
cv_result cv_device_link_copy(cv_device *dev, void *staging, uint64_t staging_offset, uint64_t id, uint64_t offset,
                              uint64_t size, cv_rect rect, bool to_staging);
/* Asynchronous link copies (backend.h: link_copy_async, link_release).
 * cv_device_link_async: whether the device has them. link_copy_async submits
 * the copy after everything submitted to dev, waiting on the GPU first for
 * `after` to reach after_ticket (after NULL or ticket 0: no wait), and returns
 * its ticket on dev at once; the resource stays in flight until it. Release
 * an owned staging only once no submitted copy uses it. */
bool cv_device_link_async(cv_device *dev);
cv_result cv_device_link_copy_async(cv_device *dev, void *staging, uint64_t staging_offset, uint64_t id,
                                    uint64_t offset, uint64_t size, cv_rect rect, bool to_staging, cv_device *after,
                                    uint64_t after_ticket, uint64_t *ticket);
void cv_device_link_release(cv_device *dev, void *staging);
/* Direct copies within one device group (backend.h: link_copy_device): whether
 * the pair can, and one copy of `region` from src's resource src_id to dst's
 * dst_id (both devices' locks taken, in address order), returning its tickets
 * on both devices at once. */
bool cv_device_link_same_group(cv_device *src, cv_device *dst);
cv_result cv_device_link_copy_device(cv_device *src, uint64_t src_id, cv_device *dst, uint64_t dst_id,
                                     const cv_link_region *region, uint64_t *src_ticket, uint64_t *dst_ticket);

#endif
