/* Render graph construction: resources, passes and their declarations
 * (graph.h). Declarations are only recorded here; bake.c checks them. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "graph_internal.h"

static const char *access_names[CV_GRAPH_ACCESS_COUNT] = {
    [CV_GRAPH_COLOR_TARGET] = "color target",   [CV_GRAPH_DEPTH_TARGET] = "depth target",
    [CV_GRAPH_STORAGE_WRITE] = "storage write", [CV_GRAPH_TRANSFER_DST] = "transfer dst",
    [CV_GRAPH_STORAGE_READ] = "storage read",   [CV_GRAPH_SAMPLED] = "sampled",
    [CV_GRAPH_TRANSFER_SRC] = "transfer src",
};

const char *cv_graph_access_name(cv_graph_access a) {
    return (unsigned)a < CV_GRAPH_ACCESS_COUNT ? access_names[a] : "unknown";
}

bool graph_access_writes(cv_graph_access a) { return a <= CV_GRAPH_TRANSFER_DST; }

bool graph_grow(void **items, uint32_t *capacity, uint32_t needed, size_t size) {
    if (needed <= *capacity)
        return true;
    uint32_t cap = *capacity ? *capacity * 2 : 8;
    while (cap < needed)
        cap *= 2;
    void *p = realloc(*items, cap * size);
    if (!p)
        return false;
    *items = p;
    *capacity = cap;
    return true;
}

cv_result cv_graph_create(cv_context *ctx, cv_device *const *devices, uint32_t count, cv_graph **out) {
    if (!ctx || !devices || !out || count == 0 || count > CV_MAX_DEVICES)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_graph_create: need a context and 1..%u devices",
                        CV_MAX_DEVICES);
    for (uint32_t d = 0; d < count; d++)
        if (!devices[d] || cv_device_context(devices[d]) != ctx)
            return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_graph_create: device %u is %s", d,
                            devices[d] ? "another context's" : "NULL");
    cv_graph *g = calloc(1, sizeof(*g));
    if (!g)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "cv_graph_create");
    g->ctx = ctx;
    memcpy(g->devices, devices, count * sizeof(*devices));
    g->device_count = count;
    cv_result res = cv_balancer_init(&g->balancer, &(cv_balancer_desc){ .device_count = count });
    if (res != CV_OK) {
        free(g);
        return res;
    }
    *out = g;
    return CV_OK;
}

void graph_changed(cv_graph *g) { g->structure_epoch++; }

bool graph_pass_touches(const graph_pass *q, uint32_t r) {
    for (uint32_t c = 0; c < q->access_count; c++)
        if ((q->accesses[c].id & ~GRAPH_HISTORY_BIT) - 1 == r)
            return true;
    return false;
}

void graph_baked_free(graph_baked *b) {
    free(b->steps);
    free(b->instances);
    free(b->barriers);
    free(b->kept);
    free(b->physical);
    free(b->first);
    free(b->last);
    free(b->shared);
    memset(b, 0, sizeof(*b));
}

static void destroy_handle(cv_graph *g, cv_handle h) {
    if (h.id)
        cv_destroy(g->ctx, h);
}

void cv_graph_destroy(cv_graph *g) {
    if (!g)
        return;
    for (uint32_t s = 0; s < CV_MAX_DEVICES; s++)
        for (uint32_t d = 0; d < CV_MAX_DEVICES; d++)
            cv_transfer_ring_destroy(g->rings[s][d]); /* waits for its copies */
    for (uint32_t d = 0; d < g->device_count; d++)
        cv_device_wait_idle(g->devices[d]);
    for (uint32_t i = 0; i < g->pool_count; i++)
        destroy_handle(g, g->pool[i].handle);
    for (uint32_t r = 0; r < g->resource_count; r++)
        for (int f = 0; f < 2; f++)
            destroy_handle(g, g->resources[r].frames[f]);
    for (uint32_t k = 0; k < CV_GRAPH_FRAMES_KEPT; k++) {
        for (uint32_t i = 0; g->list_sets[k] && i < g->list_count; i++)
            destroy_handle(g, cv_any(g->list_sets[k][i]));
        free(g->list_sets[k]);
        free(g->frames[k].entries);
    }
    for (uint32_t p = 0; p < g->pass_count; p++)
        free(g->passes[p].accesses);
    graph_baked_free(&g->baked);
    free(g->resources);
    free(g->passes);
    free(g->pool);
    free(g);
}

static cv_result add_resource(cv_graph *g, const graph_resource *r, cv_graph_resource *out) {
    if (g->resource_count == CV_GRAPH_MAX_RESOURCES)
        return cv_error(CV_ERROR_LIMIT_EXCEEDED, "graph: resource '%s': the graph already has %u resources", r->name,
                        CV_GRAPH_MAX_RESOURCES);
    if (!graph_grow((void **)&g->resources, &g->resource_capacity, g->resource_count + 1, sizeof(*r)))
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "graph: resource '%s'", r->name);
    g->resources[g->resource_count++] = *r;
    graph_changed(g);
    *out = (cv_graph_resource){ g->resource_count };
    return CV_OK;
}

bool graph_texture_ok(const cv_texture_desc *desc) {
    return desc->width && desc->height && desc->width <= CV_MAX_TEXTURE_DIM && desc->height <= CV_MAX_TEXTURE_DIM &&
           desc->format != CV_FORMAT_UNDEFINED && desc->format < CV_FORMAT_COUNT;
}

graph_resource graph_transient(const cv_texture_desc *texture, const cv_buffer_desc *buffer, uint64_t column_bytes) {
    graph_resource r = { .type = texture ? CV_HANDLE_TEXTURE : CV_HANDLE_BUFFER, .column_bytes = column_bytes };
    if (texture)
        r.texture = *texture;
    else
        r.buffer = *buffer;
    memcpy(r.name, texture ? texture->label : buffer->label, sizeof(r.name) - 1);
    return r;
}

cv_result cv_graph_create_texture(cv_graph *g, const cv_texture_desc *desc, cv_graph_resource *out) {
    if (!g || !desc || !out)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_graph_create_texture: NULL argument");
    if (!graph_texture_ok(desc))
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "graph: texture '%.*s': %ux%u %s is not a texture", CV_LABEL_MAX,
                        desc->label, desc->width, desc->height, cv_format_name(desc->format));
    graph_resource r = graph_transient(desc, NULL, 0);
    return add_resource(g, &r, out);
}

cv_result cv_graph_create_buffer(cv_graph *g, const cv_buffer_desc *desc, uint64_t column_bytes,
                                 cv_graph_resource *out) {
    if (!g || !desc || !out)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_graph_create_buffer: NULL argument");
    if (desc->size == 0)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "graph: buffer '%.*s': size 0", CV_LABEL_MAX, desc->label);
    graph_resource r = graph_transient(NULL, desc, column_bytes);
    return add_resource(g, &r, out);
}

static cv_result import(cv_graph *g, cv_handle h, cv_handle_type type, uint64_t column_bytes,
                        cv_graph_resource *out) {
    if (!g || !out)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_graph_import: NULL argument");
    cv_resource_desc desc;
    cv_result res = cv_context_describe(g->ctx, h, &desc);
    if (res != CV_OK)
        return res;
    if (desc.type != type)
        return cv_error(CV_ERROR_WRONG_HANDLE_TYPE, "graph: import of a %s handle as a %s",
                        desc.type == CV_HANDLE_TEXTURE ? "texture" : "non-texture",
                        type == CV_HANDLE_TEXTURE ? "texture" : "buffer");
    graph_resource r = { .type = type, .imported = true, .handle = h, .column_bytes = column_bytes };
    if (type == CV_HANDLE_TEXTURE)
        r.texture = desc.texture;
    else
        r.buffer = desc.buffer;
    memcpy(r.name, type == CV_HANDLE_TEXTURE ? desc.texture.label : desc.buffer.label, sizeof(r.name) - 1);
    return add_resource(g, &r, out);
}

cv_result cv_graph_import_texture(cv_graph *g, cv_texture t, cv_graph_resource *out) {
    return import(g, cv_any(t), CV_HANDLE_TEXTURE, 0, out);
}

cv_result cv_graph_import_buffer(cv_graph *g, cv_buffer b, uint64_t column_bytes, cv_graph_resource *out) {
    return import(g, cv_any(b), CV_HANDLE_BUFFER, column_bytes, out);
}

const graph_resource *graph_lookup(const cv_graph *g, uint32_t id, bool *history) {
    *history = (id & GRAPH_HISTORY_BIT) != 0;
    uint32_t index = id & ~GRAPH_HISTORY_BIT;
    if (index == 0 || index > g->resource_count)
        return NULL;
    const graph_resource *r = &g->resources[index - 1];
    return *history && !r->history ? NULL : r;
}

cv_result cv_graph_history(cv_graph *g, cv_graph_resource r, cv_graph_resource *out) {
    bool history;
    const graph_resource *res = g && out ? graph_lookup(g, r.id, &history) : NULL;
    if (!res || history)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_graph_history: resource #%u is not a resource of this graph",
                        r.id);
    if (res->imported)
        return cv_error(CV_ERROR_INVALID_ARGUMENT,
                        "graph: history of '%s': imported resources keep no history "
                        "(the application owns their contents)",
                        res->name);
    g->resources[r.id - 1].history = true;
    graph_changed(g);
    *out = (cv_graph_resource){ r.id | GRAPH_HISTORY_BIT };
    return CV_OK;
}

cv_result cv_graph_output(cv_graph *g, cv_graph_resource r) {
    bool history;
    if (!g || !graph_lookup(g, r.id, &history) || history)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_graph_output: resource #%u is not a resource of this graph",
                        r.id);
    g->resources[r.id - 1].output = true;
    graph_changed(g);
    return CV_OK;
}

cv_result graph_check_pass(const cv_graph *g, const cv_graph_pass_desc *desc) {
    size_t len = strlen(desc->name);
    if (len == 0 || len >= CV_LABEL_MAX)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "graph: pass '%s': a name needs 1..%u bytes", desc->name,
                        CV_LABEL_MAX - 1);
    if ((unsigned)desc->queue >= CV_QUEUE_TYPE_COUNT ||
        (desc->policy != CV_MGPU_PRIMARY_ONLY && desc->policy != CV_MGPU_ALL_DEVICES) || !desc->record)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "graph: pass '%s': bad queue, policy or no record callback",
                        desc->name);
    for (uint32_t p = 0; p < g->pass_count; p++)
        if (strcmp(g->passes[p].name, desc->name) == 0)
            return cv_error(CV_ERROR_ALREADY_EXISTS, "graph: pass '%s' already exists", desc->name);
    if (g->pass_count == CV_GRAPH_MAX_PASSES)
        return cv_error(CV_ERROR_LIMIT_EXCEEDED, "graph: pass '%s': the graph already has %u passes", desc->name,
                        CV_GRAPH_MAX_PASSES);
    return CV_OK;
}

cv_result cv_graph_add_pass(cv_graph *g, const cv_graph_pass_desc *desc, cv_graph_pass *out) {
    if (!g || !desc || !out || !desc->name)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_graph_add_pass: NULL argument");
    cv_result res = graph_check_pass(g, desc);
    if (res != CV_OK)
        return res;
    if (!graph_grow((void **)&g->passes, &g->pass_capacity, g->pass_count + 1, sizeof(graph_pass)))
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "graph: pass '%s'", desc->name);
    *out = graph_push_pass(g, desc, NULL, 0);
    return CV_OK;
}

cv_graph_pass graph_push_pass(cv_graph *g, const cv_graph_pass_desc *desc, graph_access *accesses, uint32_t count) {
    graph_pass *p = &g->passes[g->pass_count++];
    *p = (graph_pass){ .queue = desc->queue,
                       .policy = desc->policy,
                       .record = desc->record,
                       .user = desc->user,
                       .accesses = accesses,
                       .access_count = count,
                       .access_capacity = count };
    snprintf(p->name, sizeof(p->name), "%s", desc->name);
    graph_changed(g);
    return (cv_graph_pass){ g->pass_count };
}

cv_result cv_graph_enable_pass(cv_graph *g, cv_graph_pass p, bool enabled) {
    if (!g || p.id == 0 || p.id > g->pass_count)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_graph_enable_pass: unknown pass #%u", p.id);
    if (g->passes[p.id - 1].disabled == enabled)
        graph_changed(g);
    g->passes[p.id - 1].disabled = !enabled;
    return CV_OK;
}

static cv_result declare(cv_graph *g, cv_graph_pass p, cv_graph_resource r, cv_graph_access access,
                         cv_graph_transfer rule, bool write) {
    if (!g || p.id == 0 || p.id > g->pass_count)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "graph: declaration on unknown pass #%u", p.id);
    graph_pass *pass = &g->passes[p.id - 1];
    if ((unsigned)access >= CV_GRAPH_ACCESS_COUNT || graph_access_writes(access) != write)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "graph: pass '%s': access %d is not a %s", pass->name, access,
                        write ? "write" : "read");
    if ((unsigned)rule > CV_GRAPH_TRANSFER_PRIMARY_TO_WINDOWS)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "graph: pass '%s': transfer rule %d", pass->name, rule);
    if (!graph_grow((void **)&pass->accesses, &pass->access_capacity, pass->access_count + 1, sizeof(graph_access)))
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "graph: pass '%s'", pass->name);
    pass->accesses[pass->access_count++] = (graph_access){
        .id = r.id, .access = access, .rule = rule, .write = write
    };
    graph_changed(g);
    return CV_OK;
}

cv_result cv_graph_read(cv_graph *g, cv_graph_pass p, cv_graph_resource r, cv_graph_access access) {
    return declare(g, p, r, access, CV_GRAPH_TRANSFER_AUTO, false);
}

cv_result cv_graph_write(cv_graph *g, cv_graph_pass p, cv_graph_resource r, cv_graph_access access,
                         cv_graph_transfer rule) {
    return declare(g, p, r, access, rule, true);
}

cv_result cv_graph_add_copy_pass(cv_graph *g, const char *name, cv_mgpu_policy policy, cv_graph_resource src,
                                 cv_graph_resource dst, cv_graph_pass *out) {
    cv_graph_pass p = { 0 };
    cv_result res = cv_graph_add_pass(
        g,
        &(cv_graph_pass_desc){ .name = name, .queue = CV_QUEUE_COPY, .policy = policy, .record = graph_record_copy },
        &p);
    if (res != CV_OK)
        return res;
    graph_pass *pass = &g->passes[p.id - 1];
    pass->copy_src = src.id;
    pass->copy_dst = dst.id;
    res = cv_graph_read(g, p, src, CV_GRAPH_TRANSFER_SRC);
    if (res == CV_OK)
        res = cv_graph_write(g, p, dst, CV_GRAPH_TRANSFER_DST, CV_GRAPH_TRANSFER_AUTO);
    if (res != CV_OK) { /* nothing changes: the pass goes again */
        free(pass->accesses);
        g->pass_count--;
        return res;
    }
    *out = p;
    return CV_OK;
}

cv_handle graph_handle_of(const cv_graph *g, uint32_t index, bool history) {
    const graph_resource *r = &g->resources[index];
    if (r->imported)
        return r->handle;
    if (r->history)
        return r->frames[(g->frame + (history ? 1 : 0)) & 1];
    int32_t phys = g->baked.physical ? g->baked.physical[index] : -1;
    return phys >= 0 ? g->pool[phys].handle : (cv_handle){ 0 };
}

static cv_handle pass_handle(const cv_graph_pass_context *pc, cv_graph_resource r, cv_handle_type type) {
    const graph_record_ctx *rc = pc ? pc->instance : NULL;
    if (!rc)
        return (cv_handle){ 0 };
    const graph_pass *pass = &rc->graph->passes[rc->pass];
    bool history;
    const graph_resource *res = graph_lookup(rc->graph, r.id, &history);
    if (!res || res->type != type)
        return (cv_handle){ 0 };
    for (uint32_t a = 0; a < pass->access_count; a++)
        if (pass->accesses[a].id == r.id)
            return graph_handle_of(rc->graph, (r.id & ~GRAPH_HISTORY_BIT) - 1, history);
    return (cv_handle){ 0 };
}

cv_texture cv_graph_texture(const cv_graph_pass_context *pc, cv_graph_resource r) {
    return (cv_texture){ pass_handle(pc, r, CV_HANDLE_TEXTURE).id };
}

cv_buffer cv_graph_buffer(const cv_graph_pass_context *pc, cv_graph_resource r) {
    return (cv_buffer){ pass_handle(pc, r, CV_HANDLE_BUFFER).id };
}

void graph_record_copy(const cv_graph_pass_context *pc, cv_command_list *list, void *user) {
    (void)user;
    const graph_record_ctx *rc = pc->instance;
    const graph_pass *pass = &rc->graph->passes[rc->pass];
    cv_graph_resource src = { pass->copy_src }, dst = { pass->copy_dst };
    bool history;
    const graph_resource *s = graph_lookup(rc->graph, src.id, &history);
    if (s && s->type == CV_HANDLE_TEXTURE) {
        cv_cmd_copy_texture(list, pc->queue,
                            &(cv_copy_texture_args){ .src = cv_graph_texture(pc, src),
                                                     .src_x = pc->x,
                                                     .dst = cv_graph_texture(pc, dst),
                                                     .dst_x = pc->x,
                                                     .width = pc->width,
                                                     .height = s->texture.height });
    } else if (s) {
        bool whole = pc->width == pc->full_width || s->column_bytes == 0;
        uint64_t offset = whole ? 0 : pc->x * s->column_bytes;
        uint64_t size = whole ? s->buffer.size : pc->width * s->column_bytes;
        cv_cmd_copy_buffer(list, pc->queue,
                           &(cv_copy_buffer_args){ .src = cv_graph_buffer(pc, src),
                                                   .src_offset = offset,
                                                   .dst = cv_graph_buffer(pc, dst),
                                                   .dst_offset = offset,
                                                   .size = size });
    }
}
