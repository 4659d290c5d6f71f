/* The core of every device (see device.h, backend.h): per-device handle
 * tables, load/unload, compile caching, submission tickets, in-flight tracking
 * and deferred release. Backends only create objects and run commands. */
#include "device_internal.h"

#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "context_internal.h"

/* process-wide: the devices alive in the process, whatever their context, for
 * leak checks (cv_live_devices, CHECK_NOTHING_LIVE in the tests); atomic
 * because devices come and go on any thread. */
static atomic_uint live_devices;

uint32_t cv_live_devices(void) { return atomic_load(&live_devices); }

static cv_device_resource *slot_of(const cv_device *dev, uint64_t id) {
    cv_handle_type t = cv_handle_type_of(id);
    if (t <= CV_HANDLE_NONE || t >= CV_HANDLE_TYPE_COUNT)
        return NULL;
    const resource_table *tab = &dev->tables[t];
    uint32_t index = cv_handle_index(id);
    return index < tab->capacity ? &tab->slots[index] : NULL;
}

/* Compares the whole id, context tag included: a device's table holds only its
 * context's handles, so another context's handle to the same slot never matches. */
const cv_device_resource *cv_device_lookup(const cv_device *dev, uint64_t id) {
    const cv_device_resource *s = id ? slot_of(dev, id) : NULL;
    return s && s->id == id ? s : NULL;
}

cv_backend_device *cv_device_backend_data(const cv_device *dev) { return dev->bd; }
const cv_device_info *cv_device_get_info(const cv_device *dev) { return &dev->info; }
const char *cv_device_label(const cv_device *dev) { return dev->label; }
cv_context *cv_device_context(const cv_device *dev) { return dev->ctx; }

cv_result cv_device_require(cv_device *dev, uint64_t id, cv_handle_type type, const char *what,
                            cv_device_resource **out) {
    if (id == 0)
        return cv_error(CV_ERROR_INVALID_HANDLE, "%s: null %s handle", what, cv_handle_type_name(type));
    if (cv_handle_type_of(id) != type)
        return cv_error(CV_ERROR_WRONG_HANDLE_TYPE, "%s: needs a %s handle, got a %s handle (0x%016llx)", what,
                        cv_handle_type_name(type), cv_handle_type_name(cv_handle_type_of(id)),
                        (unsigned long long)id);
    cv_device_resource *s = slot_of(dev, id);
    if (s && s->id == id) {
        *out = s;
        return CV_OK;
    }
    cv_result live = cv_context_check(dev->ctx, (cv_handle){ id });
    if (live != CV_OK)
        return cv_error(live, "%s: %s", what, cv_last_error());
    return cv_error(CV_ERROR_NOT_LOADED, "%s: %s handle 0x%016llx is not loaded on device '%s'", what,
                    cv_handle_type_name(type), (unsigned long long)id, dev->label);
}

/* ---- deferred release ---------------------------------------------------- */

static void release_now(cv_device *dev, cv_handle_type type, void *obj) {
    if (type == CV_HANDLE_CMDLIST)
        dev->backend->list_release(dev->bd, obj);
    else
        dev->backend->resource_destroy(dev->bd, type, obj);
}

static void release_later(cv_device *dev, cv_handle_type type, void *obj, uint64_t after) {
    if (after <= dev->backend->completed(dev->bd)) {
        release_now(dev, type, obj);
        return;
    }
    if (dev->deferred_count == dev->deferred_capacity) {
        uint32_t cap = dev->deferred_capacity ? dev->deferred_capacity * 2 : 64;
        deferred_release *d = realloc(dev->deferred, cap * sizeof(*d));
        if (!d) {
            /* Cannot queue it: wait for the work instead of leaking or freeing early. */
            dev->backend->wait(dev->bd, after, UINT64_MAX);
            release_now(dev, type, obj);
            return;
        }
        dev->deferred = d;
        dev->deferred_capacity = cap;
    }
    dev->deferred[dev->deferred_count++] = (deferred_release){ type, obj, after };
}

static void collect_finished(cv_device *dev) {
    if (!dev->deferred_count)
        return;
    uint64_t done = dev->backend->completed(dev->bd);
    uint32_t kept = 0;
    for (uint32_t i = 0; i < dev->deferred_count; i++) {
        if (dev->deferred[i].after <= done)
            release_now(dev, dev->deferred[i].type, dev->deferred[i].obj);
        else
            dev->deferred[kept++] = dev->deferred[i];
    }
    dev->deferred_count = kept;
}

/* ---- create / destroy ------------------------------------------------------ */

static void member_forget(void *member, uint64_t id);
static void member_destroy(void *member) { cv_device_destroy(member); }
/* How the context reaches its devices (context_internal.h). */
static const cv_context_member_ops member_ops = { member_forget, member_destroy };

cv_result cv_device_create(cv_context *ctx, const cv_backend *backend, const cv_device_desc *desc, cv_device **out) {
    if (!ctx || !backend || !out)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_device_create: NULL argument");
    cv_device_desc d = desc ? *desc : (cv_device_desc){ 0 };
    cv_device *dev = calloc(1, sizeof(*dev));
    if (!dev)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "cv_device_create");
    pthread_mutex_init(&dev->lock, NULL);
    pthread_mutex_init(&dev->slots_lock, NULL);
    dev->ctx = ctx;
    dev->backend = backend;
    cv_result r = backend->device_create(&d, &dev->info, &dev->bd);
    if (r != CV_OK) {
        pthread_mutex_destroy(&dev->lock);
        pthread_mutex_destroy(&dev->slots_lock);
        free(dev);
        return r;
    }
    if (d.label[0] && memchr(d.label, '\0', CV_LABEL_MAX))
        snprintf(dev->label, sizeof(dev->label), "%s", d.label);
    else
        snprintf(dev->label, sizeof(dev->label), "%s:%u", backend->name, dev->info.adapter_index);
    r = cv_context_attach(ctx, dev, &member_ops);
    if (r != CV_OK) {
        backend->device_destroy(dev->bd);
        pthread_mutex_destroy(&dev->lock);
        pthread_mutex_destroy(&dev->slots_lock);
        free(dev);
        return r;
    }
    atomic_fetch_add(&live_devices, 1);
    *out = dev;
    return CV_OK;
}

void cv_device_destroy(cv_device *dev) {
    if (!dev)
        return;
    cv_context_detach(dev->ctx, dev);
    pthread_mutex_lock(&dev->lock);
    if (dev->last_ticket)
        dev->backend->wait(dev->bd, dev->last_ticket, UINT64_MAX);
    collect_finished(dev);
    for (uint32_t i = 0; i < dev->compiled_capacity; i++)
        if (dev->compiled[i].obj)
            dev->backend->list_release(dev->bd, dev->compiled[i].obj);
    for (int t = 0; t < CV_HANDLE_TYPE_COUNT; t++) {
        resource_table *tab = &dev->tables[t];
        for (uint32_t i = 0; i < tab->capacity; i++)
            if (tab->slots[i].id)
                dev->backend->resource_destroy(dev->bd, (cv_handle_type)t, tab->slots[i].obj);
        free(tab->slots);
    }
    cv_device_close_encoders(dev);
    dev->backend->device_destroy(dev->bd);
    free(dev->compiled);
    free(dev->deferred);
    pthread_mutex_unlock(&dev->lock);
    pthread_mutex_destroy(&dev->lock);
    for (uint32_t i = 0; i < dev->slot_count; i++)
        free(dev->slots[i]);
    pthread_mutex_destroy(&dev->slots_lock);
    free(dev);
    atomic_fetch_sub(&live_devices, 1);
}

/* ---- load / unload ------------------------------------------------------- */

static cv_result ensure_slot(cv_device *dev, uint64_t id, cv_device_resource **out) {
    resource_table *tab = &dev->tables[cv_handle_type_of(id)];
    uint32_t index = cv_handle_index(id);
    if (index >= tab->capacity) {
        uint32_t cap = tab->capacity ? tab->capacity : 64;
        while (cap <= index)
            cap *= 2;
        cv_device_resource *s = realloc(tab->slots, (size_t)cap * sizeof(*s));
        if (!s)
            return cv_error(CV_ERROR_OUT_OF_MEMORY, "device '%s': handle table of %u entries", dev->label, cap);
        memset(s + tab->capacity, 0, (size_t)(cap - tab->capacity) * sizeof(*s));
        tab->slots = s;
        tab->capacity = cap;
    }
    *out = &tab->slots[index];
    return CV_OK;
}

/* Empties a loaded slot (lock held); its object is released once no
 * submitted work uses it. */
static void release_slot(cv_device *dev, cv_device_resource *s) {
    release_later(dev, cv_handle_type_of(s->id), s->obj, s->last_use);
    memset(s, 0, sizeof(*s));
    dev->loaded--;
    dev->epoch++;
}

cv_result cv_device_load(cv_device *dev, cv_handle h) {
    if (!dev)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_device_load: NULL device");
    cv_resource_desc desc;
    cv_result r = cv_context_describe(dev->ctx, h, &desc); /* before the device lock: lock order */
    if (r != CV_OK)
        return r;
    const cv_pipeline_info *pipeline = NULL;
    if (desc.type == CV_HANDLE_PIPELINE)
        pipeline = cv_pipeline_registry_find(desc.pipeline.name);
    pthread_mutex_lock(&dev->lock);
    collect_finished(dev);
    cv_device_resource *s = NULL;
    r = ensure_slot(dev, h.id, &s);
    if (r == CV_OK && s->id == h.id)
        r = cv_error(CV_ERROR_ALREADY_LOADED, "%s handle 0x%016llx is already loaded on device '%s'",
                     cv_handle_type_name(desc.type), (unsigned long long)h.id, dev->label);
    if (r == CV_OK && s->id != 0) /* an older generation's: the context destroyed it, this device was not told */
        release_slot(dev, s);
    void *obj = NULL;
    if (r == CV_OK)
        r = dev->backend->resource_create(dev->bd, h.id, &desc, pipeline, &obj);
    if (r == CV_OK) {
        *s = (cv_device_resource){ .id = h.id, .desc = desc, .pipeline = pipeline, .obj = obj };
        dev->loaded++;
    }
    pthread_mutex_unlock(&dev->lock);
    return r;
}

/* Removes a representation or compiled list of `id` (lock held); false if none. */
static bool drop(cv_device *dev, uint64_t id) {
    cv_handle_type t = cv_handle_type_of(id);
    if (t == CV_HANDLE_CMDLIST) {
        uint32_t index = cv_handle_index(id);
        if (index >= dev->compiled_capacity || dev->compiled[index].id != id)
            return false;
        compiled_list *c = &dev->compiled[index];
        release_later(dev, CV_HANDLE_CMDLIST, c->obj, c->last_ticket);
        memset(c, 0, sizeof(*c));
        dev->loaded--;
        return true;
    }
    cv_device_resource *s = slot_of(dev, id);
    if (!s || s->id != id)
        return false;
    release_slot(dev, s);
    return true;
}

cv_result cv_device_unload(cv_device *dev, cv_handle h) {
    if (!dev)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_device_unload: NULL device");
    pthread_mutex_lock(&dev->lock);
    cv_result r = CV_OK;
    if (!drop(dev, h.id)) {
        cv_result live = cv_context_check(dev->ctx, h);
        r = live != CV_OK
                ? live
                : cv_error(CV_ERROR_NOT_LOADED, "%s handle 0x%016llx is not loaded on device '%s'",
                           cv_handle_type_name(cv_handle_type_of(h.id)), (unsigned long long)h.id, dev->label);
    }
    collect_finished(dev);
    pthread_mutex_unlock(&dev->lock);
    return r;
}

static void member_forget(void *member, uint64_t id) {
    cv_device *dev = member;
    pthread_mutex_lock(&dev->lock);
    drop(dev, id);
    pthread_mutex_unlock(&dev->lock);
}

bool cv_device_has(cv_device *dev, cv_handle h) {
    if (!dev || !h.id)
        return false;
    pthread_mutex_lock(&dev->lock);
    bool has;
    if (cv_handle_type_of(h.id) == CV_HANDLE_CMDLIST) {
        /* Loaded = compiled from the list as it is now, against current resources. */
        uint32_t index = cv_handle_index(h.id);
        cv_command_list *list;
        has = index < dev->compiled_capacity && dev->compiled[index].id == h.id &&
              cv_cmdlist_get(dev->ctx, (cv_cmdlist){ h.id }, &list) == CV_OK &&
              dev->compiled[index].version == list->version && dev->compiled[index].epoch == dev->epoch;
    } else {
        has = cv_device_lookup(dev, h.id) != NULL;
    }
    pthread_mutex_unlock(&dev->lock);
    return has;
}

bool cv_device_is_alias(cv_device *dev, cv_handle h) {
    if (!dev)
        return false;
    pthread_mutex_lock(&dev->lock);
    const cv_device_resource *s = slot_of(dev, h.id);
    bool alias = s && s->id == h.id && s->alias;
    pthread_mutex_unlock(&dev->lock);
    return alias;
}

uint32_t cv_device_loaded_count(cv_device *dev) {
    pthread_mutex_lock(&dev->lock);
    uint32_t n = dev->loaded;
    pthread_mutex_unlock(&dev->lock);
    return n;
}

/* ---- host data ------------------------------------------------------------ */

/* In slices, so that cv_device_abandon can end it. */
cv_result cv_device_wait_for_resource(cv_device *dev, cv_device_resource *s) {
    if (dev->backend->orders_host_access || s->last_use <= dev->backend->completed(dev->bd))
        return CV_OK;
    for (;;) {
        if (atomic_load(&dev->abandoned))
            return cv_error(CV_ERROR_DEVICE_LOST, "device '%s': abandoned while waiting for ticket %llu", dev->label,
                            (unsigned long long)s->last_use);
        cv_result r = dev->backend->wait(dev->bd, s->last_use, 100ull * 1000 * 1000);
        if (r != CV_ERROR_TIMEOUT)
            return r;
    }
}

void cv_device_abandon(cv_device *dev) {
    if (dev)
        atomic_store(&dev->abandoned, true);
}

/* A write (src) or a read (dst): `write` says which, so that a NULL pointer
 * is reported as what the caller did. */
static cv_result buffer_access(cv_device *dev, cv_buffer b, uint64_t offset, uint64_t size, bool write,
                               const void *src, void *dst) {
    if (!dev || (write ? !src : !dst))
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "buffer %s: NULL argument", write ? "write" : "read");
    pthread_mutex_lock(&dev->lock);
    cv_device_resource *s;
    cv_result r = cv_device_require(dev, b.id, CV_HANDLE_BUFFER, write ? "buffer write" : "buffer read", &s);
    if (r == CV_OK && size == 0)
        r = cv_error(CV_ERROR_INVALID_ARGUMENT, "buffer '%s': %s of 0 bytes at offset %llu: size is 0",
                     s->desc.buffer.label, write ? "write" : "read", (unsigned long long)offset);
    if (r == CV_OK && (offset > s->desc.buffer.size || size > s->desc.buffer.size - offset))
        r = cv_error(CV_ERROR_OUT_OF_RANGE,
                     "buffer '%s' (%llu bytes): %s of %llu bytes at offset %llu is out of range",
                     s->desc.buffer.label, (unsigned long long)s->desc.buffer.size, write ? "write" : "read",
                     (unsigned long long)size, (unsigned long long)offset);
    if (r == CV_OK)
        r = cv_device_wait_for_resource(dev, s);
    if (r == CV_OK)
        r = write ? dev->backend->buffer_write(dev->bd, s->obj, offset, size, src)
                  : dev->backend->buffer_read(dev->bd, s->obj, offset, size, dst);
    pthread_mutex_unlock(&dev->lock);
    return r;
}

cv_result cv_device_write_buffer(cv_device *dev, cv_buffer b, uint64_t offset, uint64_t size, const void *data) {
    return buffer_access(dev, b, offset, size, true, data, NULL);
}

cv_result cv_device_read_buffer(cv_device *dev, cv_buffer b, uint64_t offset, uint64_t size, void *out) {
    return buffer_access(dev, b, offset, size, false, NULL, out);
}

static cv_result texture_access(cv_device *dev, cv_texture t, cv_rect rect, bool write, const void *src, void *dst) {
    if (!dev || (write ? !src : !dst))
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "texture %s: NULL argument", write ? "write" : "read");
    pthread_mutex_lock(&dev->lock);
    cv_device_resource *s;
    cv_result r = cv_device_require(dev, t.id, CV_HANDLE_TEXTURE, write ? "texture write" : "texture read", &s);
    if (r == CV_OK) {
        const cv_texture_desc *d = &s->desc.texture;
        if (rect.width == 0 || rect.height == 0)
            r = cv_error(CV_ERROR_INVALID_ARGUMENT, "texture '%s': %s of an empty %ux%u region at (%u,%u)", d->label,
                         write ? "write" : "read", rect.width, rect.height, rect.x, rect.y);
        else if (rect.x > d->width || rect.width > d->width - rect.x || rect.y > d->height ||
                 rect.height > d->height - rect.y)
            r = cv_error(CV_ERROR_OUT_OF_RANGE, "texture '%s' (%ux%u): %s of %ux%u at (%u,%u) is out of range",
                         d->label, d->width, d->height, write ? "write" : "read", rect.width, rect.height, rect.x,
                         rect.y);
    }
    if (r == CV_OK)
        r = cv_device_wait_for_resource(dev, s);
    if (r == CV_OK)
        r = write ? dev->backend->texture_write(dev->bd, s->obj, &s->desc.texture, rect, src)
                  : dev->backend->texture_read(dev->bd, s->obj, &s->desc.texture, rect, dst);
    pthread_mutex_unlock(&dev->lock);
    return r;
}

cv_result cv_device_write_texture(cv_device *dev, cv_texture t, cv_rect rect, const void *data) {
    return texture_access(dev, t, rect, true, data, NULL);
}

cv_result cv_device_read_texture(cv_device *dev, cv_texture t, cv_rect rect, void *out) {
    return texture_access(dev, t, rect, false, NULL, out);
}

/* ---- cross-device links (transfer.c) ----------------------------------------- */

bool cv_device_link_caps(cv_device *dev, cv_link_caps *out) {
    memset(out, 0, sizeof(*out));
    if (!dev->backend->link_caps || !dev->backend->link_staging || !dev->backend->link_copy)
        return false;
    pthread_mutex_lock(&dev->lock);
    dev->backend->link_caps(dev->bd, out);
    pthread_mutex_unlock(&dev->lock);
    return true;
}

cv_result cv_device_link_staging(cv_device *dev, cv_staging_desc *desc, void **out) {
    pthread_mutex_lock(&dev->lock);
    cv_result r = dev->backend->link_staging(dev->bd, desc, out);
    pthread_mutex_unlock(&dev->lock);
    return r;
}

cv_result cv_device_link_copy(cv_device *dev, void *staging, uint64_t staging_offset, uint64_t id, uint64_t offset,
                              uint64_t size, cv_rect rect, bool to_staging) {
    cv_handle_type type = cv_handle_type_of(id);
    const char *what = to_staging ? "transfer (source)" : "transfer (destination)";
    pthread_mutex_lock(&dev->lock);
    cv_device_resource *s;
    cv_result r = type == CV_HANDLE_BUFFER || type == CV_HANDLE_TEXTURE
                      ? cv_device_require(dev, id, type, what, &s)
                      : cv_error(CV_ERROR_WRONG_HANDLE_TYPE, "%s on device '%s': a %s handle", what, dev->label,
                                 cv_handle_type_name(type));
    if (r == CV_OK)
        r = cv_device_wait_for_resource(dev, s);
    if (r == CV_OK)
        r = dev->backend->link_copy(dev->bd, staging, staging_offset, type, s->obj, offset, size, rect, to_staging);
    pthread_mutex_unlock(&dev->lock);
    return r;
}

bool cv_device_link_async(cv_device *dev) {
    cv_link_caps caps;
    return cv_device_link_caps(dev, &caps) && dev->backend->link_copy_async && dev->backend->link_release;
}

cv_result cv_device_link_copy_async(cv_device *dev, void *staging, uint64_t staging_offset, uint64_t id,
                                    uint64_t offset, uint64_t size, cv_rect rect, bool to_staging, cv_device *after,
                                    uint64_t after_ticket, uint64_t *ticket) {
    cv_handle_type type = cv_handle_type_of(id);
    const char *what = to_staging ? "transfer (source)" : "transfer (destination)";
    *ticket = 0;
    if (!dev->backend->link_copy_async)
        return cv_error(CV_ERROR_UNSUPPORTED, "device '%s' (%s backend) has no asynchronous link copies", dev->label,
                        dev->backend->name);
    if (after && after->backend != dev->backend)
        return cv_error(CV_ERROR_UNSUPPORTED,
                        "%s on device '%s': cannot wait on the GPU for device '%s' of another "
                        "backend",
                        what, dev->label, after->label);
    /* The other device's backend object never changes: read without its lock (lock order). */
    cv_link_wait wait = { .device = after && after != dev && after_ticket ? after->bd : NULL,
                          .ticket = after_ticket };
    pthread_mutex_lock(&dev->lock);
    collect_finished(dev);
    cv_device_resource *s;
    cv_result r = type == CV_HANDLE_BUFFER || type == CV_HANDLE_TEXTURE
                      ? cv_device_require(dev, id, type, what, &s)
                      : cv_error(CV_ERROR_WRONG_HANDLE_TYPE, "%s on device '%s': a %s handle", what, dev->label,
                                 cv_handle_type_name(type));
    uint64_t t = dev->last_ticket + 1;
    if (r == CV_OK)
        r = dev->backend->link_copy_async(dev->bd, staging, staging_offset, type, s->obj, offset, size, rect,
                                          to_staging, &wait, t);
    if (r == CV_OK) {
        dev->last_ticket = t;
        s->last_use = t; /* kept alive (deferred release) until the copy finished */
        *ticket = t;
    }
    pthread_mutex_unlock(&dev->lock);
    return r;
}

bool cv_device_link_same_group(cv_device *src, cv_device *dst) {
    cv_link_caps a, b;
    return src != dst && src->backend == dst->backend && src->backend->link_copy_device &&
           cv_device_link_caps(src, &a) && cv_device_link_caps(dst, &b) && a.device_group &&
           a.device_group == b.device_group;
}

cv_result cv_device_link_copy_device(cv_device *src, uint64_t src_id, cv_device *dst, uint64_t dst_id,
                                     const cv_link_region *region, uint64_t *src_ticket, uint64_t *dst_ticket) {
    cv_handle_type type = cv_handle_type_of(src_id);
    *src_ticket = *dst_ticket = 0;
    if (!cv_device_link_same_group(src, dst))
        return cv_error(CV_ERROR_UNSUPPORTED, "transfer from device '%s' to device '%s': they share no device",
                        src->label, dst->label);
    if ((type != CV_HANDLE_BUFFER && type != CV_HANDLE_TEXTURE) || cv_handle_type_of(dst_id) != type)
        return cv_error(CV_ERROR_WRONG_HANDLE_TYPE, "transfer from device '%s' to device '%s': a %s and a %s handle",
                        src->label, dst->label, cv_handle_type_name(type),
                        cv_handle_type_name(cv_handle_type_of(dst_id)));
    /* Both locks, in address order (nothing else holds two device locks). */
    cv_device *first = src < dst ? src : dst, *second = src < dst ? dst : src;
    pthread_mutex_lock(&first->lock);
    pthread_mutex_lock(&second->lock);
    collect_finished(src);
    collect_finished(dst);
    cv_device_resource *s, *d;
    cv_result r = cv_device_require(src, src_id, type, "transfer (source)", &s);
    if (r == CV_OK)
        r = cv_device_require(dst, dst_id, type, "transfer (destination)", &d);
    uint64_t ts = src->last_ticket + 1, td = dst->last_ticket + 1;
    if (r == CV_OK)
        r = src->backend->link_copy_device(src->bd, dst->bd, type, s->obj, d->obj, region, d->last_use, ts, td);
    if (r == CV_OK) {
        src->last_ticket = ts;
        dst->last_ticket = td;
        s->last_use = ts; /* kept alive (deferred release) until the copy finished */
        d->last_use = td;
        *src_ticket = ts;
        *dst_ticket = td;
    }
    pthread_mutex_unlock(&second->lock);
    pthread_mutex_unlock(&first->lock);
    return r;
}

bool cv_device_can_alias(cv_device *dev, cv_device *owner, char *why, size_t why_size) {
    char none[1];
    if (!why || !why_size) {
        why = none;
        why_size = sizeof(none);
    }
    why[0] = 0;
    cv_link_caps a, b;
    if (!dev || !owner || dev == owner) {
        snprintf(why, why_size, "%s", !dev || !owner ? "a NULL device" : "it is the same device");
        return false;
    }
    if (dev->backend != owner->backend) {
        snprintf(why, why_size, "the devices are on different backends (%s, %s)", dev->backend->name,
                 owner->backend->name);
        return false;
    }
    if (!dev->backend->resource_alias || !dev->backend->link_wait || !cv_device_link_caps(dev, &a) ||
        !cv_device_link_caps(owner, &b)) {
        snprintf(why, why_size, "the %s backend cannot share memory between devices", dev->backend->name);
        return false;
    }
    if (!a.shared_memory || !b.shared_memory) {
        snprintf(why, why_size, "device '%s' lacks %s", !a.shared_memory ? dev->label : owner->label,
                 !a.shared_memory ? a.shared_missing : b.shared_missing);
        return false;
    }
    if (memcmp(a.driver_uuid, b.driver_uuid, 16) != 0 || memcmp(a.device_uuid, b.device_uuid, 16) != 0) {
        snprintf(why, why_size, "they are different adapters or drivers (driverUUID/deviceUUID differ)");
        return false;
    }
    return true;
}

cv_result cv_device_load_alias(cv_device *dev, cv_handle h, cv_device *owner) {
    if (!dev || !owner)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_device_load_alias: NULL device");
    cv_resource_desc desc;
    cv_result r = cv_context_describe(dev->ctx, h, &desc); /* before the device locks: lock order */
    if (r != CV_OK)
        return r;
    if (owner->ctx != dev->ctx)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "alias on device '%s': device '%s' belongs to another context",
                        dev->label, owner->label);
    if (desc.type != CV_HANDLE_TEXTURE)
        return cv_error(CV_ERROR_WRONG_HANDLE_TYPE, "alias on device '%s': a %s handle (only textures alias)",
                        dev->label, cv_handle_type_name(desc.type));
    if (!(desc.texture.usage & CV_TEXTURE_USAGE_SHARED))
        return cv_error(CV_ERROR_USAGE_MISMATCH,
                        "alias on device '%s': texture '%s' was not created with CV_TEXTURE_USAGE_SHARED", dev->label,
                        desc.texture.label);
    char why[160];
    if (!cv_device_can_alias(dev, owner, why, sizeof(why)))
        return cv_error(CV_ERROR_UNSUPPORTED, "alias of texture '%s' on device '%s' from device '%s': %s",
                        desc.texture.label, dev->label, owner->label, why);
    /* Both locks, in address order (as cv_device_link_copy_device). */
    cv_device *first = dev < owner ? dev : owner, *second = dev < owner ? owner : dev;
    pthread_mutex_lock(&first->lock);
    pthread_mutex_lock(&second->lock);
    collect_finished(dev);
    collect_finished(owner);
    cv_device_resource *src = NULL, *s = NULL;
    r = cv_device_require(owner, h.id, CV_HANDLE_TEXTURE, "alias (owner)", &src);
    if (r == CV_OK)
        r = ensure_slot(dev, h.id, &s);
    if (r == CV_OK && s->id == h.id)
        r = cv_error(CV_ERROR_ALREADY_LOADED, "texture handle 0x%016llx is already loaded on device '%s'",
                     (unsigned long long)h.id, dev->label);
    if (r == CV_OK && s->id != 0) /* an older generation's: the context destroyed it, this device was not told */
        release_slot(dev, s);
    void *obj = NULL;
    if (r == CV_OK)
        r = dev->backend->resource_alias(dev->bd, h.id, &desc, owner->bd, src->obj, &obj);
    if (r == CV_OK) {
        *s = (cv_device_resource){ .id = h.id, .desc = desc, .obj = obj, .alias = true };
        dev->loaded++;
    }
    pthread_mutex_unlock(&second->lock);
    pthread_mutex_unlock(&first->lock);
    return r;
}

cv_result cv_device_gpu_wait(cv_device *dev, cv_device *other, uint64_t other_ticket, uint64_t *ticket) {
    if (!dev || !other || !ticket)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_device_gpu_wait: NULL argument");
    *ticket = 0;
    if (dev == other)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_device_gpu_wait: device '%s' waits on itself", dev->label);
    if (dev->backend != other->backend || !dev->backend->link_wait)
        return cv_error(CV_ERROR_UNSUPPORTED, "device '%s' (%s backend) cannot wait on the GPU for device '%s' (%s)",
                        dev->label, dev->backend->name, other->label, other->backend->name);
    pthread_mutex_lock(&other->lock); /* alone, not nested: lock order */
    uint64_t submitted = other->last_ticket;
    pthread_mutex_unlock(&other->lock);
    if (other_ticket > submitted)
        return cv_error(CV_ERROR_INVALID_ARGUMENT,
                        "device '%s': a GPU wait for ticket %llu of device '%s', which submitted only %llu",
                        dev->label, (unsigned long long)other_ticket, other->label, (unsigned long long)submitted);
    /* The other device's backend object never changes: passed without its lock. */
    cv_link_wait wait = { .device = other->bd, .ticket = other_ticket };
    pthread_mutex_lock(&dev->lock);
    collect_finished(dev);
    uint64_t t = dev->last_ticket + 1;
    cv_result r = dev->backend->link_wait(dev->bd, &wait, t);
    if (r == CV_OK) {
        dev->last_ticket = t;
        *ticket = t;
    }
    pthread_mutex_unlock(&dev->lock);
    return r;
}

void cv_device_link_release(cv_device *dev, void *staging) {
    pthread_mutex_lock(&dev->lock);
    dev->backend->link_release(dev->bd, staging);
    pthread_mutex_unlock(&dev->lock);
}

cv_result cv_device_write_accel(cv_device *dev, cv_accel accel, const void *nodes, const void *triangles) {
    if (!dev || !nodes || !triangles)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_device_write_accel: NULL argument");
    pthread_mutex_lock(&dev->lock);
    cv_device_resource *s;
    cv_result r = cv_device_require(dev, accel.id, CV_HANDLE_ACCEL, "accel write", &s);
    if (r == CV_OK && !dev->backend->accel_write)
        r = cv_error(CV_ERROR_UNSUPPORTED, "device '%s' (%s backend) cannot trace rays", dev->label,
                     dev->backend->name);
    if (r == CV_OK)
        r = cv_device_wait_for_resource(dev, s);
    if (r == CV_OK) {
        s->ready = false; /* a failed rebuild leaves no half-built structure in use */
        r = dev->backend->accel_write(dev->bd, s->obj, &s->desc.accel, nodes, triangles);
        s->ready = r == CV_OK;
        dev->epoch++; /* lists compiled against the old structure are re-checked */
    }
    pthread_mutex_unlock(&dev->lock);
    return r;
}

/* ---- compile / submit ----------------------------------------------------- */

static cv_result compiled_slot(cv_device *dev, uint64_t id, compiled_list **out) {
    uint32_t index = cv_handle_index(id);
    if (index >= dev->compiled_capacity) {
        uint32_t cap = dev->compiled_capacity ? dev->compiled_capacity : 16;
        while (cap <= index)
            cap *= 2;
        compiled_list *c = realloc(dev->compiled, (size_t)cap * sizeof(*c));
        if (!c)
            return cv_error(CV_ERROR_OUT_OF_MEMORY, "device '%s': compiled list table", dev->label);
        memset(c + dev->compiled_capacity, 0, (size_t)(cap - dev->compiled_capacity) * sizeof(*c));
        dev->compiled = c;
        dev->compiled_capacity = cap;
    }
    *out = &dev->compiled[index];
    return CV_OK;
}

/* Returns the up-to-date compiled form of the list (lock held). */
static cv_result compile_locked(cv_device *dev, uint64_t id, compiled_list **out) {
    cv_command_list *list;
    cv_result r = cv_context_executable_list(dev->ctx, id, &list);
    if (r != CV_OK)
        return r;
    compiled_list *c = NULL;
    r = compiled_slot(dev, id, &c);
    if (r != CV_OK)
        return r;
    if (c->id == id && c->version == list->version && c->epoch == dev->epoch) {
        *out = c;
        return CV_OK;
    }
    r = cv_validate_list(dev, list);
    if (r != CV_OK)
        return r;
    void *obj = NULL;
    r = dev->backend->list_compile(dev->bd, dev, list, &obj);
    if (r != CV_OK)
        return r;
    if (c->id)
        release_later(dev, CV_HANDLE_CMDLIST, c->obj, c->last_ticket);
    else
        dev->loaded++;
    *c = (compiled_list){ .id = id, .version = list->version, .epoch = dev->epoch, .obj = obj };
    *out = c;
    return CV_OK;
}

cv_result cv_device_compile(cv_device *dev, cv_cmdlist list) {
    if (!dev)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_device_compile: NULL device");
    pthread_mutex_lock(&dev->lock);
    compiled_list *c;
    cv_result r = compile_locked(dev, list.id, &c);
    pthread_mutex_unlock(&dev->lock);
    return r;
}

static void mark_use(uint64_t id, void *user) {
    void **args = user;
    cv_device *dev = args[0];
    uint64_t ticket = *(uint64_t *)args[1];
    cv_device_resource *s = slot_of(dev, id);
    if (s && s->id == id)
        s->last_use = ticket;
}

cv_result cv_device_submit(cv_device *dev, cv_cmdlist list, uint64_t *ticket) {
    if (!dev)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_device_submit: NULL device");
    pthread_mutex_lock(&dev->lock);
    collect_finished(dev);
    compiled_list *c = NULL;
    cv_result r = compile_locked(dev, list.id, &c);
    uint64_t t = dev->last_ticket + 1;
    if (r == CV_OK)
        r = dev->backend->submit(dev->bd, c->obj, t);
    if (r == CV_OK) {
        dev->last_ticket = t;
        c->last_ticket = t;
        cv_command_list *l;
        if (cv_context_executable_list(dev->ctx, list.id, &l) == CV_OK) {
            void *args[2] = { dev, &t };
            for (uint32_t i = 0; i < l->count; i++)
                cv_command_visit_handles(l, &l->commands[i], mark_use, args);
        }
        if (ticket)
            *ticket = t;
    }
    pthread_mutex_unlock(&dev->lock);
    return r;
}

cv_result cv_device_wait(cv_device *dev, uint64_t ticket, uint64_t timeout_ns) {
    if (!dev)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_device_wait: NULL device");
    uint64_t last = atomic_load(&dev->last_ticket);
    if (ticket > last)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "device '%s': ticket %llu was never submitted (last is %llu)",
                        dev->label, (unsigned long long)ticket, (unsigned long long)last);
    /* Waiting does not hold the device lock, so other threads can submit meanwhile. */
    cv_result r = dev->backend->wait(dev->bd, ticket, timeout_ns);
    if (r == CV_OK && dev->backend->refused)
        r = dev->backend->refused(dev->bd, ticket);
    /* Releasing what finished is opportunistic here: a thread may hold the lock
     * in a host wait for work that never ends (cv_device_wait_for_resource), and this
     * wait must still return (a watchdog calls it). Submits collect too. */
    if (pthread_mutex_trylock(&dev->lock) == 0) {
        collect_finished(dev);
        pthread_mutex_unlock(&dev->lock);
    }
    return r;
}

cv_result cv_device_wait_idle(cv_device *dev) {
    if (!dev)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_device_wait_idle: NULL device");
    pthread_mutex_lock(&dev->lock);
    uint64_t last = dev->last_ticket;
    pthread_mutex_unlock(&dev->lock);
    return last ? cv_device_wait(dev, last, UINT64_MAX) : CV_OK;
}

cv_result cv_device_timings(cv_device *dev, uint64_t ticket, cv_pass_timing *out, uint32_t capacity,
                            uint32_t *count) {
    if (!dev || !count || (capacity && !out))
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_device_timings: NULL argument");
    pthread_mutex_lock(&dev->lock);
    cv_result r = CV_OK;
    compiled_list *found = NULL;
    for (uint32_t i = 0; i < dev->compiled_capacity && !found; i++)
        if (dev->compiled[i].id && dev->compiled[i].last_ticket == ticket)
            found = &dev->compiled[i];
    if (!found)
        r = cv_error(CV_ERROR_NOT_FOUND,
                     "device '%s': no timings for ticket %llu (kept only for the latest "
                     "submission of each list)",
                     dev->label, (unsigned long long)ticket);
    else if (ticket > dev->backend->completed(dev->bd))
        r = cv_error(CV_ERROR_BAD_STATE, "device '%s': ticket %llu has not finished; wait for it first", dev->label,
                     (unsigned long long)ticket);
    else
        r = dev->backend->timings(dev->bd, found->obj, out, capacity, count);
    pthread_mutex_unlock(&dev->lock);
    return r;
}

bool cv_device_is_lost(cv_device *dev) {
    if (!dev || !dev->backend->lost)
        return false;
    pthread_mutex_lock(&dev->lock);
    bool lost = dev->backend->lost(dev->bd);
    pthread_mutex_unlock(&dev->lock);
    return lost;
}
