/* The backend interface: what a device implementation provides.
 *
 * A backend is a const table of function pointers. The core (client/src/device.c)
 * does everything that is the same for all backends: handle tables, load and
 * unload bookkeeping, validation of command lists, tracking of in-flight use and
 * deferred destruction, ticket numbering. A backend only creates its objects
 * and runs commands. Contracts:
 *
 * - Every function that returns cv_result reports failure with cv_error() and
 *   leaves no partial state behind.
 * - resource_destroy / list_release are called only once the core knows no
 *   submitted work uses the object any more (completed() passed its last use).
 * - list_compile gets a list that client/src/validate.c already accepted for this device;
 *   it may look resources up with cv_device_lookup() and trust what it finds.
 * - submit must give the submission the ticket it is passed; tickets increase
 *   by one per submit; completed() returns the highest finished ticket.
 * - buffer/texture read and write are synchronous and are called only when no
 *   submitted work uses the resource, unless the backend sets
 *   orders_host_access: then they are called at once, and the backend itself
 *   runs them after the work submitted before them (a remote node, which
 *   processes requests in order, saves a round trip per read or write).
 * - device_destroy is called after every object was destroyed; it waits idle.
 * - accel_write builds the device's acceleration structure from a flat BVH
 *   (types.h, cv_accel_desc); it is synchronous like the other writes. A
 *   backend without it (NULL) cannot trace rays.
 * - link_caps / link_staging / link_copy (all three or none) let transfer.c
 *   move bytes between two devices without a host copy (transfer.h's SHARED
 *   and HOST_IMPORT paths). link_staging gives a "staging": memory the device
 *   can copy resources into and out of on its own queue, either exported as a
 *   file descriptor, imported from one, or imported from host memory. The
 *   backend owns stagings (caching them by key) until device_destroy. link_copy
 *   is synchronous like buffer_read/write and is called under the same rule:
 *   when no submitted work uses the resource (or at once, orders_host_access).
 *   Its writes are available to the other device when it returns.
 * - link_copy_async / link_release (optional, both or neither; need the three
 *   above) are the asynchronous form: link_copy_async records the same copy,
 *   submits it on the device's queue ordered after everything submitted there
 *   (like a submit, it is given the next ticket and signals it when the copy
 *   is done) and returns at once. If wait->device is set, the copy first waits
 *   on the GPU until that device (same backend) reached wait->ticket; the
 *   backend must not touch wait->device after that ticket finished or once it
 *   began destroying itself. The core calls it at once (no host wait) and
 *   keeps the resource alive until the ticket. Stagings made with
 *   desc->owned are the caller's: never cached nor shared, freed by
 *   link_release once no submitted copy uses them (or at device_destroy).
 * - link_copy_device (optional; needs link_caps) copies straight from a
 *   resource of one device to a resource of another when both report the same
 *   nonzero cv_link_caps.device_group (instances sharing one device, e.g. one
 *   VkDevice: transfer.h's DEVICE path). It records the copy on bd's (the
 *   source's) queue, submitted with `ticket` after ticket-1 and after dst_bd
 *   reached `dst_wait` (the destination resource's last use there; 0: none),
 *   then submits on dst_bd, with `dst_ticket` after dst_ticket-1, a wait for
 *   the copy, so dst_bd's later work follows it. The core holds both devices'
 *   locks and marks the source resource used by `ticket`, the destination
 *   resource by `dst_ticket`.
 * - resource_alias (optional) creates bd's object for texture `id` over the
 *   memory of src_obj, src_bd's object of the same handle (cv_device_load_alias):
 *   both devices then share the texels. The core checked that the pair is
 *   eligible as far as link_caps tells (same backend, shared_memory on both,
 *   equal UUIDs) and holds both devices' locks; the backend refuses
 *   (CV_ERROR_UNSUPPORTED) an object it cannot share. Each object keeps the
 *   memory alive on its own.
 * - link_wait (optional; needs link_caps) submits on bd, with `ticket` after
 *   ticket-1, a GPU-side wait until wait->device reached wait->ticket (same
 *   rules as link_copy_async's wait), so bd's later work follows it.
 * - peer_capable / peer_move (optional, both or neither) are transfer.h's PEER
 *   path: devices of one backend that move data between each other without
 *   the client, such as proxy devices on different corvid-node sessions.
 *   peer_capable says whether bd can send or receive now; peer_move starts one
 *   move between two capable devices of the backend, already checked by
 *   transfer.c, and returns without waiting for it; transfer ids increase from
 *   call to call across the process. The core stays free of gRPC. */
#ifndef CORVID_BACKEND_H
#define CORVID_BACKEND_H

#include "corvid/context.h"
#include "corvid/device_info.h"
#include "corvid/encode_types.h"

typedef struct cv_backend_device cv_backend_device; /* each backend's own */

/* What a device offers for cross-device links (backend.h contract above). */
typedef struct cv_link_caps {
    uint8_t driver_uuid[16], device_uuid[16]; /* equal on both devices = one adapter, one driver */
    bool shared_memory;                       /* can export and import memory as opaque file descriptors */
    bool host_import;                         /* can import host allocations */
    uint64_t host_alignment;                  /* host_import: required alignment of pointer and size */
    char shared_missing[64];                  /* !shared_memory: what the device lacks (an extension name) */
    char host_missing[64];                    /* !host_import: likewise */
    /* GPU waits on the other device of a pair (link_copy_async's wait): */
    bool wait_import;          /* directly on its imported semaphore, when both have this and equal UUIDs */
    bool wait_import_required; /* forced (CORVID_CROSS_WAIT=import): a ring of a pair without it is refused */
    char wait_missing[96];     /* !wait_import: why (an extension or feature) */
    /* Nonzero: the device shares one device with every device of equal value in
     * the process (link_copy_device copies between their resources). */
    uint64_t device_group;
} cv_link_caps;

/* What link_copy_device moves: a buffer range, or a texture rectangle. */
typedef struct cv_link_region {
    uint64_t src_offset, dst_offset, size; /* buffers */
    cv_rect src_rect;                      /* textures */
    uint32_t dst_x, dst_y;
} cv_link_region;

typedef enum cv_staging_kind {
    CV_STAGING_EXPORT = 1, /* device memory of this device, exported: fd gets a new descriptor */
    CV_STAGING_IMPORT = 2, /* the memory another device exported (fd, key, memory_type, allocation_size) */
    CV_STAGING_HOST = 3,   /* the host allocation at `host` (page-aligned, host_alignment multiples) */
} cv_staging_kind;

typedef struct cv_staging_desc {
    cv_staging_kind kind;
    uint64_t size;            /* bytes usable for copies */
    uint64_t key;             /* process-unique name of the memory; EXPORT sets it, IMPORT/HOST pass it */
    int fd;                   /* EXPORT: out, the caller closes it. IMPORT: in; set to -1 when the
                                      backend took ownership (else the caller closes it) */
    void *host;               /* HOST: the allocation */
    uint32_t memory_type;     /* EXPORT: out; IMPORT: in (backend facts passed back unchanged) */
    uint64_t allocation_size; /* likewise */
    bool owned;               /* a staging of its own (not cached), freed by link_release */
} cv_staging_desc;

/* One PEER move (peer_move), checked by transfer.c: a texture rect to (dst_x, dst_y), or a buffer range. */
typedef struct cv_transfer_peer_region {
    cv_device *src, *dst;
    uint64_t src_id, dst_id;
    bool texture;
    cv_rect src_rect;
    uint32_t dst_x, dst_y;
    uint64_t src_offset, dst_offset, size; /* size: bytes either way */
} cv_transfer_peer_region;

/* A GPU-side wait on another device's ticket (link_copy_async). */
typedef struct cv_link_wait {
    cv_backend_device *device; /* NULL: no wait */
    uint64_t ticket;
} cv_link_wait;

struct cv_backend {
    const char *name;
    bool orders_host_access; /* reads/writes are ordered after earlier submissions by the backend */
    cv_result (*device_create)(const cv_device_desc *desc, cv_device_info *info, cv_backend_device **out);
    void (*device_destroy)(cv_backend_device *bd);

    /* Creates the device object for a buffer, texture, sampler, pipeline or accel
     * (pipeline: desc->pipeline.name resolved to `pipeline` from the registry). */
    cv_result (*resource_create)(cv_backend_device *bd, uint64_t id, const cv_resource_desc *desc,
                                 const cv_pipeline_info *pipeline, void **out_obj);
    void (*resource_destroy)(cv_backend_device *bd, cv_handle_type type, void *obj);

    cv_result (*buffer_write)(cv_backend_device *bd, void *buf, uint64_t offset, uint64_t size, const void *data);
    cv_result (*buffer_read)(cv_backend_device *bd, void *buf, uint64_t offset, uint64_t size, void *out);
    cv_result (*texture_write)(cv_backend_device *bd, void *tex, const cv_texture_desc *desc, cv_rect rect,
                               const void *data);
    cv_result (*texture_read)(cv_backend_device *bd, void *tex, const cv_texture_desc *desc, cv_rect rect, void *out);
    cv_result (*accel_write)(cv_backend_device *bd, void *accel, const cv_accel_desc *desc, const void *nodes,
                             const void *triangles);

    cv_result (*list_compile)(cv_backend_device *bd, cv_device *dev, const cv_command_list *list,
                              void **out_compiled);
    void (*list_release)(cv_backend_device *bd, void *compiled);
    cv_result (*submit)(cv_backend_device *bd, void *compiled, uint64_t ticket);
    cv_result (*wait)(cv_backend_device *bd, uint64_t ticket, uint64_t timeout_ns);
    uint64_t (*completed)(cv_backend_device *bd);
    /* Optional (NULL: nothing to report). Called by cv_device_wait once wait()
     * found `ticket` finished: the first command of a submission up to `ticket`
     * that the device refused while running it (a dispatch_indirect whose group
     * counts, read on the device, exceed its limits), as an error naming the
     * device, ticket and command. Each submission is reported at most once. */
    cv_result (*refused)(cv_backend_device *bd, uint64_t ticket);
    /* Whether the device is gone for good (a remote node died, the GPU was
     * lost): every later call on it fails. NULL: never lost. */
    bool (*lost)(cv_backend_device *bd);
    /* Timings of the latest finished submission of `compiled` (may be NULL: none). */
    cv_result (*timings)(cv_backend_device *bd, void *compiled, cv_pass_timing *out, uint32_t capacity,
                         uint32_t *count);

    /* Cross-device links (optional, NULL = staged transfers only). */
    void (*link_caps)(cv_backend_device *bd, cv_link_caps *out);
    cv_result (*link_staging)(cv_backend_device *bd, cv_staging_desc *desc, void **out_staging);
    /* Copies between a buffer range (offset, size) or a texture rectangle (rows
     * packed tightly) and the staging at staging_offset, on the GPU. */
    cv_result (*link_copy)(cv_backend_device *bd, void *staging, uint64_t staging_offset, cv_handle_type type,
                           void *obj, uint64_t offset, uint64_t size, cv_rect rect, bool to_staging);
    /* Asynchronous copies (optional, see the contract above). */
    cv_result (*link_copy_async)(cv_backend_device *bd, void *staging, uint64_t staging_offset, cv_handle_type type,
                                 void *obj, uint64_t offset, uint64_t size, cv_rect rect, bool to_staging,
                                 const cv_link_wait *wait, uint64_t ticket);
    void (*link_release)(cv_backend_device *bd, void *staging);
    /* Direct copies within one device group (optional, see the contract above). */
    cv_result (*link_copy_device)(cv_backend_device *bd, cv_backend_device *dst_bd, cv_handle_type type,
                                  void *src_obj, void *dst_obj, const cv_link_region *region, uint64_t dst_wait,
                                  uint64_t ticket, uint64_t dst_ticket);
    /* Zero-copy aliases and GPU-side waits (optional, see the contract above). */
    cv_result (*resource_alias)(cv_backend_device *bd, uint64_t id, const cv_resource_desc *desc,
                                cv_backend_device *src_bd, void *src_obj, void **out_obj);
    cv_result (*link_wait)(cv_backend_device *bd, const cv_link_wait *wait, uint64_t ticket);
    /* The PEER transfer path (optional, see the contract above). */
    bool (*peer_capable)(cv_backend_device *bd);
    cv_result (*peer_move)(const cv_transfer_peer_region *region, uint64_t transfer_id);
    /* Encoder streams on the device's machine (optional, see the contract above). */
    cv_result (*encoder_open)(cv_backend_device *bd, uint32_t stream, cv_codec codec, uint32_t width,
                              uint32_t height);
    cv_result (*encoder_send)(cv_backend_device *bd, uint32_t stream, void *tex, const cv_texture_desc *desc,
                              cv_rect rect, const cv_encode_params *params);
    cv_result (*encoder_receive)(cv_backend_device *bd, uint32_t stream, cv_encoded *out);
    void (*encoder_close)(cv_backend_device *bd, uint32_t stream);
};

/* A device's representation of one handle. */
typedef struct cv_device_resource {
    uint64_t id; /* 0 = slot not loaded */
    cv_resource_desc desc;
    const cv_pipeline_info *pipeline; /* pipelines only */
    void *obj;                        /* the backend's object */
    uint64_t last_use;                /* ticket of the last submission using it */
    bool ready;                       /* accels: data written, can be traced */
    bool alias;                       /* textures: loaded by cv_device_load_alias */
} cv_device_resource;

/* The loaded representation of id on dev, or NULL (not loaded, stale, wrong id).
 * Valid while the device lock is held (i.e. inside backend callbacks). */
const cv_device_resource *cv_device_lookup(const cv_device *dev, uint64_t id);
cv_backend_device *cv_device_backend_data(const cv_device *dev);

/* The rule for dispatch_indirect's group counts, which only the running list
 * knows (validation checks the argument buffer's usage, alignment and range):
 * they run if none exceeds max (the limits a direct dispatch is held to; zero
 * dispatches nothing), else the dispatch is skipped and the backend's refused()
 * reports this error: CV_ERROR_OUT_OF_RANGE naming the device, submission
 * ticket and command. One rule and one message for every backend. */
bool cv_indirect_counts_fit(const uint32_t counts[3], const uint32_t max[3]);
cv_result cv_indirect_refusal(const char *device, uint64_t ticket, uint32_t command, const uint32_t counts[3],
                              const uint32_t max[3]);

#endif
