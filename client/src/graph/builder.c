/* The pass builder (graph.h): a pass and its declarations as one chain whose
 * calls keep the first error, as command lists do, and whose declarations
 * return the use the record callback binds. Nothing reaches the graph before
 * cv_graph_pass_end, which adds the pass, its declarations and the transients
 * it created all at once, or nothing. */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "graph_internal.h"

#define BUILDER_MESSAGE_MAX 512u

struct cv_graph_builder {
    cv_graph *graph;
    cv_graph_pass_desc desc; /* desc.name points at name */
    char name[CV_LABEL_MAX];
    /* The graph's resource count when the builder opened: the transients it
     * creates get the ids after it, which they keep when the end adds them. */
    uint32_t resource_base;
    graph_resource *created;
    uint32_t created_count, created_capacity;
    graph_access *accesses;
    uint32_t access_count, access_capacity;
    cv_result error; /* the first failure; CV_OK while the chain holds */
    char message[BUILDER_MESSAGE_MAX];
};

/* What cv_graph_pass_begin returns when it cannot make a builder: every call on
 * these does nothing (they are never written) and their end says why. */
static const cv_graph_builder no_graph = { .error = CV_ERROR_INVALID_ARGUMENT,
                                           .message = "cv_graph_pass_begin: NULL graph or description" };
static const cv_graph_builder no_memory = { .error = CV_ERROR_OUT_OF_MEMORY,
                                            .message = "cv_graph_pass_begin: no memory for a builder" };

static const char *const rule_names[] = { "auto", "multicast", "to primary", "primary to windows" };

/* Keeps the chain's first error: "graph: pass '<name>': " and the reason. */
__attribute__((format(printf, 3, 4))) static cv_graph_use fail(cv_graph_builder *b, cv_result code, const char *fmt,
                                                               ...) {
    int at = snprintf(b->message, sizeof(b->message), "graph: pass '%s': ", b->name);
    va_list args;
    va_start(args, fmt);
    vsnprintf(b->message + at, sizeof(b->message) - (size_t)at, fmt, args);
    va_end(args);
    b->error = cv_error(code, "%s", b->message);
    return (cv_graph_use){ 0, 0 };
}

/* Keeps an error of the graph's own checks, whose message names the pass already. */
static void keep(cv_graph_builder *b, cv_result code) {
    snprintf(b->message, sizeof(b->message), "%s", cv_last_error());
    b->error = code;
}

cv_graph_builder *cv_graph_pass_begin(cv_graph *g, const cv_graph_pass_desc *desc) {
    if (!g || !desc)
        return (cv_graph_builder *)&no_graph;
    cv_graph_builder *b = calloc(1, sizeof(*b));
    if (!b)
        return (cv_graph_builder *)&no_memory;
    b->graph = g;
    b->desc = *desc;
    b->desc.name = b->name;
    b->resource_base = g->resource_count;
    snprintf(b->name, sizeof(b->name), "%s", desc->name ? desc->name : "");
    cv_result res;
    if (!desc->name)
        fail(b, CV_ERROR_INVALID_ARGUMENT, "a pass needs a name");
    else if ((res = graph_check_pass(g, desc)) != CV_OK)
        keep(b, res);
    return b;
}

/* The resource behind an id: the graph's, or one this builder created. */
static const graph_resource *lookup(const cv_graph_builder *b, uint32_t id, bool *history) {
    uint32_t index = id & ~GRAPH_HISTORY_BIT;
    if (index > b->resource_base && index <= b->resource_base + b->created_count) {
        *history = (id & GRAPH_HISTORY_BIT) != 0;
        return *history ? NULL : &b->created[index - b->resource_base - 1];
    }
    return graph_lookup(b->graph, id, history);
}

/* The checks the bake would make of this one declaration, made now so the
 * message names the declaration; then the declaration is kept. */
static cv_graph_use declare(cv_graph_builder *b, uint32_t id, cv_graph_access access, cv_graph_transfer rule,
                            bool write) {
    const char *verb = write ? "write" : "read";
    bool history = false;
    const graph_resource *r = lookup(b, id, &history);
    if (!r)
        return fail(b, CV_ERROR_NOT_FOUND, "%s of unknown resource #%u", verb, id & ~GRAPH_HISTORY_BIT);
    if ((unsigned)access >= CV_GRAPH_ACCESS_COUNT || graph_access_writes(access) != write)
        return fail(b, CV_ERROR_INVALID_ARGUMENT, "%s of '%s': access %s is not a %s", verb, r->name,
                    cv_graph_access_name(access), verb);
    if (history && write)
        return fail(b, CV_ERROR_INVALID_ARGUMENT, "write of '%s': its history is read-only", r->name);
    bool texture_only = access == CV_GRAPH_COLOR_TARGET || access == CV_GRAPH_DEPTH_TARGET ||
                        access == CV_GRAPH_SAMPLED;
    if (texture_only && r->type != CV_HANDLE_TEXTURE)
        return fail(b, CV_ERROR_WRONG_HANDLE_TYPE, "%s of '%s': a buffer cannot be a %s", verb, r->name,
                    cv_graph_access_name(access));
    if ((unsigned)rule > CV_GRAPH_TRANSFER_PRIMARY_TO_WINDOWS)
        return fail(b, CV_ERROR_INVALID_ARGUMENT, "write of '%s': transfer rule %d", r->name, rule);
    bool primary = b->desc.policy == CV_MGPU_PRIMARY_ONLY;
    if (rule != CV_GRAPH_TRANSFER_AUTO && primary != (rule != CV_GRAPH_TRANSFER_TO_PRIMARY))
        return fail(b, CV_ERROR_INVALID_ARGUMENT, "write of '%s': transfer rule '%s' needs a %s pass", r->name,
                    rule_names[rule], primary ? "ALL_DEVICES" : "PRIMARY_ONLY");
    for (uint32_t a = b->access_count; write && a-- > 0;)
        if (b->accesses[a].id == id) {
            if (b->accesses[a].write)
                return fail(b, CV_ERROR_INVALID_ARGUMENT, "write of '%s': written twice with no read between",
                            r->name);
            break;
        }
    if (!graph_grow((void **)&b->accesses, &b->access_capacity, b->access_count + 1, sizeof(graph_access)))
        return fail(b, CV_ERROR_OUT_OF_MEMORY, "%s of '%s'", verb, r->name);
    b->accesses[b->access_count++] = (graph_access){ .id = id, .access = access, .rule = rule, .write = write };
    return (cv_graph_use){ .resource = id, .access = b->access_count };
}

cv_graph_use cv_graph_pass_read(cv_graph_builder *b, cv_graph_resource r, cv_graph_access a) {
    if (!b || b->error != CV_OK)
        return (cv_graph_use){ 0, 0 };
    return declare(b, r.id, a, CV_GRAPH_TRANSFER_AUTO, false);
}

cv_graph_use cv_graph_pass_write(cv_graph_builder *b, cv_graph_resource r, cv_graph_access a,
                                 cv_graph_transfer rule) {
    if (!b || b->error != CV_OK)
        return (cv_graph_use){ 0, 0 };
    return declare(b, r.id, a, rule, true);
}

/* A transient of this builder, written by its pass; *out its handle (0 on failure). */
static cv_graph_use create(cv_graph_builder *b, const graph_resource *r, cv_graph_access a, cv_graph_transfer rule,
                           cv_graph_resource *out) {
    cv_graph_use u = { 0, 0 };
    if (b->resource_base + b->created_count >= CV_GRAPH_MAX_RESOURCES)
        fail(b, CV_ERROR_LIMIT_EXCEEDED, "creation of '%s': the graph would have over %u resources", r->name,
             CV_GRAPH_MAX_RESOURCES);
    else if (!graph_grow((void **)&b->created, &b->created_capacity, b->created_count + 1, sizeof(*r)))
        fail(b, CV_ERROR_OUT_OF_MEMORY, "creation of '%s'", r->name);
    else {
        b->created[b->created_count++] = *r;
        u = declare(b, b->resource_base + b->created_count, a, rule, true);
    }
    if (out)
        *out = (cv_graph_resource){ u.resource };
    return u;
}

cv_graph_use cv_graph_pass_create_texture(cv_graph_builder *b, const cv_texture_desc *desc, cv_graph_access a,
                                          cv_graph_transfer rule, cv_graph_resource *out) {
    if (out)
        *out = (cv_graph_resource){ 0 };
    if (!b || b->error != CV_OK)
        return (cv_graph_use){ 0, 0 };
    if (!desc)
        return fail(b, CV_ERROR_INVALID_ARGUMENT, "creation of a texture with no description");
    if (!graph_texture_ok(desc))
        return fail(b, CV_ERROR_INVALID_ARGUMENT, "creation of '%.*s': %ux%u %s is not a texture", CV_LABEL_MAX,
                    desc->label, desc->width, desc->height, cv_format_name(desc->format));
    graph_resource r = graph_transient(desc, NULL, 0);
    return create(b, &r, a, rule, out);
}

cv_graph_use cv_graph_pass_create_buffer(cv_graph_builder *b, const cv_buffer_desc *desc, uint64_t column_bytes,
                                         cv_graph_access a, cv_graph_transfer rule, cv_graph_resource *out) {
    if (out)
        *out = (cv_graph_resource){ 0 };
    if (!b || b->error != CV_OK)
        return (cv_graph_use){ 0, 0 };
    if (!desc)
        return fail(b, CV_ERROR_INVALID_ARGUMENT, "creation of a buffer with no description");
    if (desc->size == 0)
        return fail(b, CV_ERROR_INVALID_ARGUMENT, "creation of '%.*s': size 0", CV_LABEL_MAX, desc->label);
    graph_resource r = graph_transient(NULL, desc, column_bytes);
    return create(b, &r, a, rule, out);
}

/* Checks what may have changed in the graph since the builder opened, then
 * grows its arrays: past this, adding cannot fail. */
static void check_end(cv_graph_builder *b) {
    cv_graph *g = b->graph;
    cv_result res;
    if (b->created_count && g->resource_count != b->resource_base)
        fail(b, CV_ERROR_BAD_STATE,
             "%u resources were added to the graph while its builder was open (the builder's transients "
             "would change ids)",
             g->resource_count - b->resource_base);
    else if ((res = graph_check_pass(g, &b->desc)) != CV_OK)
        keep(b, res);
    else if (!graph_grow((void **)&g->resources, &g->resource_capacity, g->resource_count + b->created_count,
                         sizeof(graph_resource)) ||
             !graph_grow((void **)&g->passes, &g->pass_capacity, g->pass_count + 1, sizeof(graph_pass)))
        fail(b, CV_ERROR_OUT_OF_MEMORY, "adding the pass");
}

cv_result cv_graph_pass_end(cv_graph_builder *b, cv_graph_pass *out) {
    if (out)
        *out = (cv_graph_pass){ 0 };
    if (!b)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_graph_pass_end: NULL builder");
    if (b == &no_graph || b == &no_memory)
        return cv_error(b->error, "%s", b->message);
    if (b->error == CV_OK)
        check_end(b);
    cv_result res = b->error;
    if (res == CV_OK) {
        cv_graph *g = b->graph;
        if (b->created_count)
            memcpy(g->resources + g->resource_count, b->created, b->created_count * sizeof(graph_resource));
        g->resource_count += b->created_count;
        cv_graph_pass p = graph_push_pass(g, &b->desc, b->accesses, b->access_count);
        b->accesses = NULL; /* the pass's now */
        if (out)
            *out = p;
    } else {
        cv_error(res, "%s", b->message); /* calls since the failure may have replaced the last error */
    }
    free(b->created);
    free(b->accesses);
    free(b);
    return res;
}

/* The handle of use u on the device being recorded, when u is a declaration
 * of the pass being recorded (of type `type`, or any with CV_HANDLE_NONE). */
static cv_handle use_handle(const cv_graph_pass_context *pc, cv_graph_use u, cv_handle_type type) {
    const graph_record_ctx *rc = pc ? pc->instance : NULL;
    if (!rc || u.access == 0)
        return (cv_handle){ 0 };
    const graph_pass *pass = &rc->graph->passes[rc->pass];
    if (u.access > pass->access_count || pass->accesses[u.access - 1].id != u.resource)
        return (cv_handle){ 0 };
    bool history;
    const graph_resource *r = graph_lookup(rc->graph, u.resource, &history);
    if (!r || (type != CV_HANDLE_NONE && r->type != type))
        return (cv_handle){ 0 };
    return graph_handle_of(rc->graph, (u.resource & ~GRAPH_HISTORY_BIT) - 1, history);
}

cv_texture cv_graph_use_texture(const cv_graph_pass_context *pc, cv_graph_use u) {
    return (cv_texture){ use_handle(pc, u, CV_HANDLE_TEXTURE).id };
}

cv_buffer cv_graph_use_buffer(const cv_graph_pass_context *pc, cv_graph_use u) {
    return (cv_buffer){ use_handle(pc, u, CV_HANDLE_BUFFER).id };
}

cv_binding cv_graph_use_binding(const cv_graph_pass_context *pc, cv_graph_use u) {
    return (cv_binding){ .resource = use_handle(pc, u, CV_HANDLE_NONE) };
}
