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
 *   submitted work uses the resource.
 * - device_destroy is called after every object was destroyed; it waits idle.
 * - accel_write builds the device's acceleration structure from a flat BVH
 *   (types.h, cv_accel_desc); it is synchronous like the other writes. A
 *   backend without it (NULL) cannot trace rays. */
#ifndef CORVID_BACKEND_H
#define CORVID_BACKEND_H

#include "corvid/device.h"

typedef struct cv_backend_device cv_backend_device;   /* each backend's own */

struct cv_backend {
    const char *name;
    cv_result (*device_create)(const cv_device_desc *desc, cv_device_info *info,
                               cv_backend_device **out);
    void (*device_destroy)(cv_backend_device *bd);

    /* Creates the device object for a buffer, texture, sampler, pipeline or accel
     * (pipeline: desc->pipeline.name resolved to `pipeline` from the registry). */
    cv_result (*resource_create)(cv_backend_device *bd, uint64_t id, const cv_resource_desc *desc,
                                 const cv_pipeline_info *pipeline, void **out_obj);
    void (*resource_destroy)(cv_backend_device *bd, cv_handle_type type, void *obj);

    cv_result (*buffer_write)(cv_backend_device *bd, void *buf, uint64_t offset, uint64_t size,
                              const void *data);
    cv_result (*buffer_read)(cv_backend_device *bd, void *buf, uint64_t offset, uint64_t size,
                             void *out);
    cv_result (*texture_write)(cv_backend_device *bd, void *tex, const cv_texture_desc *desc,
                               cv_rect rect, const void *data);
    cv_result (*texture_read)(cv_backend_device *bd, void *tex, const cv_texture_desc *desc,
                              cv_rect rect, void *out);
    cv_result (*accel_write)(cv_backend_device *bd, void *accel, const cv_accel_desc *desc,
                             const void *nodes, const void *triangles);

    cv_result (*list_compile)(cv_backend_device *bd, cv_device *dev, const cv_command_list *list,
                              void **out_compiled);
    void (*list_release)(cv_backend_device *bd, void *compiled);
    cv_result (*submit)(cv_backend_device *bd, void *compiled, uint64_t ticket);
    cv_result (*wait)(cv_backend_device *bd, uint64_t ticket, uint64_t timeout_ns);
    uint64_t (*completed)(cv_backend_device *bd);
    /* Timings of the latest finished submission of `compiled` (may be NULL: none). */
    cv_result (*timings)(cv_backend_device *bd, void *compiled, cv_pass_timing *out,
                         uint32_t capacity, uint32_t *count);
};

/* A device's representation of one handle. */
typedef struct cv_device_resource {
    uint64_t id;                        /* 0 = slot not loaded */
    cv_resource_desc desc;
    const cv_pipeline_info *pipeline;   /* pipelines only */
    void *obj;                          /* the backend's object */
    uint64_t last_use;                  /* ticket of the last submission using it */
    bool ready;                         /* accels: data written, can be traced */
} cv_device_resource;

/* The loaded representation of id on dev, or NULL (not loaded, stale, wrong id).
 * Valid while the device lock is held (i.e. inside backend callbacks). */
const cv_device_resource *cv_device_lookup(const cv_device *dev, uint64_t id);
cv_backend_device *cv_device_backend_data(const cv_device *dev);

#endif
