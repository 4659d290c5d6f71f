/* The mock backend: a device that runs nothing on a GPU.
 *
 * Everything the core does for real devices (handle tables, validation of every
 * list, in-flight tracking, deferred release) happens as usual; the mock keeps
 * resources in host memory and emulates the data-movement commands (copies,
 * clears, updates) so tests can check what a list moves. Dispatches and draws
 * and ray traces are validated but not executed (an acceleration structure
 * keeps a copy of its BVH); a dispatch_indirect's group counts are read when
 * the list runs and held to the device's limits like on a GPU (backend.h,
 * cv_indirect_counts_fit), the first refusal reported by the next wait. Submissions finish immediately; pass timings
 * are the host time spent emulating each marker region. */
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "corvid/backend.h"
#include "corvid/clock.h"
#include "corvid/texel.h"

typedef struct mock_object {
    cv_handle_type type;
    uint64_t size;  /* bytes of `bytes` */
    uint32_t width; /* textures: texels per row */
    uint32_t texel; /* textures: bytes per texel */
    uint8_t *bytes; /* buffer or texture contents; NULL for samplers/pipelines */
} mock_object;

typedef struct mock_compiled {
    cv_device *dev;       /* resolves handles when the list runs */
    cv_command_list list; /* a private copy: the original may be re-recorded */
    cv_pass_timing *timings;
    uint32_t timing_count;
} mock_compiled;

#define MOCK_MAX_DISPATCH 65535u

struct cv_backend_device {
    _Atomic uint64_t completed; /* written by submit (device lock), read by wait/completed (no lock) */
    char label[CV_LABEL_MAX];
    /* The first refused dispatch_indirect not yet reported: set by submit (device
     * lock), taken by refused() (after a wait, outside it), hence a lock. */
    pthread_mutex_t lock;
    uint64_t refused_ticket; /* 0: none */
    uint32_t refused_command;
    uint32_t refused_counts[3];
};

static cv_result mock_device_create(const cv_device_desc *desc, cv_device_info *info, cv_backend_device **out) {
    const char *a = desc->adapter;
    if (a && a[0] && strcmp(a, "0") != 0 && strcmp(a, "mock") != 0)
        return cv_error(CV_ERROR_NOT_FOUND, "mock backend: no adapter matches '%s' (it has one: 'mock', index 0)", a);
    cv_backend_device *bd = calloc(1, sizeof(*bd));
    if (!bd)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "mock device");
    memset(info, 0, sizeof(*info));
    strcpy(info->name, "Corvid mock device");
    strcpy(info->backend, "mock");
    strcpy(info->driver, "none (validates, runs nothing)");
    info->max_storage_buffer_range = 128u << 20;
    info->max_dispatch[0] = info->max_dispatch[1] = info->max_dispatch[2] = MOCK_MAX_DISPATCH;
    snprintf(bd->label, sizeof(bd->label), "%s", desc->label);
    pthread_mutex_init(&bd->lock, NULL);
    *out = bd;
    return CV_OK;
}

static void mock_device_destroy(cv_backend_device *bd) {
    pthread_mutex_destroy(&bd->lock);
    free(bd);
}

static cv_result mock_resource_create(cv_backend_device *bd, uint64_t id, const cv_resource_desc *desc,
                                      const cv_pipeline_info *pipeline, void **out) {
    (void)bd, (void)id, (void)pipeline;
    mock_object *o = calloc(1, sizeof(*o));
    if (!o)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "mock resource");
    o->type = desc->type;
    if (desc->type == CV_HANDLE_BUFFER) {
        o->size = desc->buffer.size;
    } else if (desc->type == CV_HANDLE_TEXTURE) {
        o->width = desc->texture.width;
        o->texel = cv_format_bytes(desc->texture.format);
        o->size = (uint64_t)desc->texture.width * desc->texture.height * o->texel;
    } else if (desc->type == CV_HANDLE_ACCEL) {
        o->size = (uint64_t)desc->accel.node_count * CV_ACCEL_NODE_BYTES +
                  (uint64_t)desc->accel.triangle_count * CV_ACCEL_TRIANGLE_BYTES;
    }
    if (o->size) {
        o->bytes = calloc(1, o->size);
        if (!o->bytes) {
            unsigned long long size = o->size;
            free(o);
            return cv_error(CV_ERROR_OUT_OF_MEMORY, "mock resource of %llu bytes", size);
        }
    }
    *out = o;
    return CV_OK;
}

static void mock_resource_destroy(cv_backend_device *bd, cv_handle_type type, void *obj) {
    (void)bd, (void)type;
    mock_object *o = obj;
    free(o->bytes);
    free(o);
}

static cv_result mock_buffer_write(cv_backend_device *bd, void *buf, uint64_t offset, uint64_t size,
                                   const void *data) {
    (void)bd;
    memcpy(((mock_object *)buf)->bytes + offset, data, size);
    return CV_OK;
}

static cv_result mock_buffer_read(cv_backend_device *bd, void *buf, uint64_t offset, uint64_t size, void *out) {
    (void)bd;
    memcpy(out, ((mock_object *)buf)->bytes + offset, size);
    return CV_OK;
}

/* Copies a rectangle between a texture and tightly packed rows. */
static void texture_rows(mock_object *t, cv_rect r, uint8_t *packed, bool to_texture) {
    size_t row = (size_t)r.width * t->texel;
    for (uint32_t y = 0; y < r.height; y++) {
        uint8_t *texels = t->bytes + ((size_t)(r.y + y) * t->width + r.x) * t->texel;
        if (to_texture)
            memcpy(texels, packed + y * row, row);
        else
            memcpy(packed + y * row, texels, row);
    }
}

static cv_result mock_texture_write(cv_backend_device *bd, void *tex, const cv_texture_desc *desc, cv_rect rect,
                                    const void *data) {
    (void)bd, (void)desc;
    texture_rows(tex, rect, (uint8_t *)data, true);
    return CV_OK;
}

static cv_result mock_texture_read(cv_backend_device *bd, void *tex, const cv_texture_desc *desc, cv_rect rect,
                                   void *out) {
    (void)bd, (void)desc;
    texture_rows(tex, rect, out, false);
    return CV_OK;
}

static cv_result mock_accel_write(cv_backend_device *bd, void *accel, const cv_accel_desc *desc, const void *nodes,
                                  const void *triangles) {
    (void)bd;
    mock_object *o = accel;
    size_t node_bytes = (size_t)desc->node_count * CV_ACCEL_NODE_BYTES;
    memcpy(o->bytes, nodes, node_bytes);
    memcpy(o->bytes + node_bytes, triangles, (size_t)desc->triangle_count * CV_ACCEL_TRIANGLE_BYTES);
    return CV_OK;
}

static cv_result copy_array(void **dst, const void *src, size_t bytes) {
    *dst = NULL;
    if (!bytes)
        return CV_OK;
    *dst = malloc(bytes);
    if (!*dst)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "mock compile: %zu bytes", bytes);
    memcpy(*dst, src, bytes);
    return CV_OK;
}

static cv_result mock_list_compile(cv_backend_device *bd, cv_device *dev, const cv_command_list *list, void **out) {
    (void)bd;
    mock_compiled *c = calloc(1, sizeof(*c));
    if (!c)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "mock compile");
    c->dev = dev;
    c->list = *list;
    c->list.capacity = list->count;
    c->list.binding_capacity = list->binding_count;
    c->list.data_capacity = list->data_size;
    cv_result r = copy_array((void **)&c->list.commands, list->commands, list->count * sizeof(cv_command));
    if (r == CV_OK)
        r = copy_array((void **)&c->list.bindings, list->bindings, list->binding_count * sizeof(cv_binding));
    if (r == CV_OK)
        r = copy_array((void **)&c->list.data, list->data, list->data_size);
    if (r != CV_OK) {
        cv_command_list_finish(&c->list);
        free(c);
        return r;
    }
    *out = c;
    return CV_OK;
}

static void mock_list_release(cv_backend_device *bd, void *compiled) {
    (void)bd;
    mock_compiled *c = compiled;
    cv_command_list_finish(&c->list);
    free(c->timings);
    free(c);
}

static mock_object *obj_of(cv_device *dev, uint64_t id) { return cv_device_lookup(dev, id)->obj; }

/* Runs the data-movement commands of a validated list on host memory. */
static void emulate(cv_device *dev, const cv_command_list *l, const cv_command *c) {
    switch (c->type) {
    case CV_CMD_COPY_BUFFER: {
        const cv_copy_buffer_cmd *x = &c->u.copy_buffer;
        memcpy(obj_of(dev, x->dst.id)->bytes + x->dst_offset, obj_of(dev, x->src.id)->bytes + x->src_offset, x->size);
        break;
    }
    case CV_CMD_COPY_TEXTURE: {
        const cv_copy_texture_cmd *x = &c->u.copy_texture;
        mock_object *src = obj_of(dev, x->src.id), *dst = obj_of(dev, x->dst.id);
        size_t row = (size_t)x->width * src->texel;
        for (uint32_t y = 0; y < x->height; y++)
            memcpy(dst->bytes + ((size_t)(x->dst_y + y) * dst->width + x->dst_x) * dst->texel,
                   src->bytes + ((size_t)(x->src_y + y) * src->width + x->src_x) * src->texel, row);
        break;
    }
    case CV_CMD_COPY_BUFFER_TO_TEXTURE: {
        const cv_copy_buffer_to_texture_cmd *x = &c->u.copy_buffer_to_texture;
        texture_rows(obj_of(dev, x->dst.id), (cv_rect){ x->dst_x, x->dst_y, x->width, x->height },
                     obj_of(dev, x->src.id)->bytes + x->src_offset, true);
        break;
    }
    case CV_CMD_COPY_TEXTURE_TO_BUFFER: {
        const cv_copy_texture_to_buffer_cmd *x = &c->u.copy_texture_to_buffer;
        texture_rows(obj_of(dev, x->src.id), (cv_rect){ x->src_x, x->src_y, x->width, x->height },
                     obj_of(dev, x->dst.id)->bytes + x->dst_offset, false);
        break;
    }
    case CV_CMD_CLEAR_BUFFER: {
        const cv_clear_buffer_cmd *x = &c->u.clear_buffer;
        uint8_t *p = obj_of(dev, x->buffer.id)->bytes + x->offset;
        for (uint64_t i = 0; i < x->size; i += 4)
            memcpy(p + i, &x->value, 4);
        break;
    }
    case CV_CMD_CLEAR_TEXTURE: {
        const cv_clear_texture_cmd *x = &c->u.clear_texture;
        const cv_device_resource *res = cv_device_lookup(dev, x->texture.id);
        mock_object *t = res->obj;
        uint8_t texel[16];
        float rgba[4] = { x->r, x->g, x->b, x->a };
        cv_texel_encode(res->desc.texture.format, rgba, texel);
        for (uint64_t i = 0; i < t->size; i += t->texel)
            memcpy(t->bytes + i, texel, t->texel);
        break;
    }
    case CV_CMD_UPDATE_BUFFER: {
        const cv_update_buffer_cmd *x = &c->u.update_buffer;
        memcpy(obj_of(dev, x->buffer.id)->bytes + x->offset, cv_list_bytes(l, x->data), x->data.size);
        break;
    }
    default: break;
    }
}

/* Reads a dispatch_indirect's counts as the list runs; keeps the first refusal. */
static void check_indirect(cv_backend_device *bd, const mock_compiled *mc, uint32_t index, uint64_t ticket) {
    const cv_dispatch_indirect_cmd *x = &mc->list.commands[index].u.dispatch_indirect;
    uint32_t counts[3];
    memcpy(counts, obj_of(mc->dev, x->args.id)->bytes + x->args_offset, sizeof(counts));
    const uint32_t max[3] = { MOCK_MAX_DISPATCH, MOCK_MAX_DISPATCH, MOCK_MAX_DISPATCH };
    if (cv_indirect_counts_fit(counts, max))
        return;
    pthread_mutex_lock(&bd->lock);
    if (!bd->refused_ticket) {
        bd->refused_ticket = ticket;
        bd->refused_command = index;
        memcpy(bd->refused_counts, counts, sizeof(counts));
    }
    pthread_mutex_unlock(&bd->lock);
}

static cv_result mock_submit(cv_backend_device *bd, void *compiled, uint64_t ticket) {
    mock_compiled *mc = compiled;
    const cv_command_list *l = &mc->list;
    free(mc->timings);
    mc->timings = NULL;
    mc->timing_count = 0;
    uint32_t markers = 0;
    for (uint32_t i = 0; i < l->count; i++)
        markers += l->commands[i].type == CV_CMD_BEGIN_MARKER || l->commands[i].type == CV_CMD_TIMESTAMP;
    if (markers && !(mc->timings = calloc(markers, sizeof(cv_pass_timing))))
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "mock timings");
    uint32_t stack[64], depth = 0;
    double start = cv_now_ms();
    for (uint32_t i = 0; i < l->count; i++) {
        const cv_command *c = &l->commands[i];
        if (c->type == CV_CMD_BEGIN_MARKER || c->type == CV_CMD_TIMESTAMP) {
            cv_pass_timing *t = &mc->timings[mc->timing_count];
            cv_span label = c->type == CV_CMD_TIMESTAMP ? c->u.timestamp.label : c->u.begin_marker.label;
            cv_list_string(l, label, t->label, sizeof(t->label));
            double now = cv_now_ms();
            t->start_ms = now - start;
            t->host_ms = now; /* the mock runs lists on the host: its clock is the host's */
            if (c->type == CV_CMD_BEGIN_MARKER && depth < 64)
                stack[depth++] = mc->timing_count;
            mc->timing_count++;
        } else if (c->type == CV_CMD_END_MARKER && depth) {
            cv_pass_timing *t = &mc->timings[stack[--depth]];
            t->duration_ms = cv_now_ms() - start - t->start_ms;
        } else if (c->type == CV_CMD_DISPATCH_INDIRECT) {
            check_indirect(bd, mc, i, ticket);
        } else {
            emulate(mc->dev, l, c);
        }
    }
    atomic_store(&bd->completed, ticket);
    return CV_OK;
}

static cv_result mock_wait(cv_backend_device *bd, uint64_t ticket, uint64_t timeout_ns) {
    (void)timeout_ns;
    return ticket <= atomic_load(&bd->completed)
               ? CV_OK
               : cv_error(CV_ERROR_TIMEOUT, "mock: ticket %llu never submitted", (unsigned long long)ticket);
}

static uint64_t mock_completed(cv_backend_device *bd) { return atomic_load(&bd->completed); }

static cv_result mock_refused(cv_backend_device *bd, uint64_t ticket) {
    cv_result r = CV_OK;
    pthread_mutex_lock(&bd->lock);
    if (bd->refused_ticket && bd->refused_ticket <= ticket) {
        const uint32_t max[3] = { MOCK_MAX_DISPATCH, MOCK_MAX_DISPATCH, MOCK_MAX_DISPATCH };
        r = cv_indirect_refusal(bd->label, bd->refused_ticket, bd->refused_command, bd->refused_counts, max);
        bd->refused_ticket = 0;
    }
    pthread_mutex_unlock(&bd->lock);
    return r;
}

static cv_result mock_timings(cv_backend_device *bd, void *compiled, cv_pass_timing *out, uint32_t capacity,
                              uint32_t *count) {
    (void)bd;
    mock_compiled *mc = compiled;
    uint32_t n = mc->timing_count < capacity ? mc->timing_count : capacity;
    if (n)
        memcpy(out, mc->timings, n * sizeof(*out));
    *count = mc->timing_count;
    return CV_OK;
}

static const cv_backend mock_backend = {
    .name = "mock",
    .device_create = mock_device_create,
    .device_destroy = mock_device_destroy,
    .resource_create = mock_resource_create,
    .resource_destroy = mock_resource_destroy,
    .buffer_write = mock_buffer_write,
    .buffer_read = mock_buffer_read,
    .texture_write = mock_texture_write,
    .texture_read = mock_texture_read,
    .accel_write = mock_accel_write,
    .list_compile = mock_list_compile,
    .list_release = mock_list_release,
    .submit = mock_submit,
    .wait = mock_wait,
    .completed = mock_completed,
    .refused = mock_refused,
    .timings = mock_timings,
};

const cv_backend *cv_mock_backend(void) { return &mock_backend; }
