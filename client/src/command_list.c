/* Recording of command lists (see command_list.h).
 *
 * The recording functions are generated from the command table: each copies
 * its arguments into a fixed-size cv_command, moving variable-size data
 * (bindings, bytes, labels) into the list's side arrays. Recording checks only
 * what needs no device; a failed call rolls back what it appended and makes
 * the error sticky. */
#include "corvid/command_list.h"

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

void cv_command_list_init(cv_command_list *list) { memset(list, 0, sizeof(*list)); }

void cv_command_list_finish(cv_command_list *list) {
    free(list->commands);
    free(list->bindings);
    free(list->data);
    memset(list, 0, sizeof(*list));
}

void cv_command_list_begin(cv_command_list *list) {
    list->count = 0;
    list->binding_count = 0;
    list->data_size = 0;
    list->queue_mask = 0;
    list->version++;
    list->recording = true;
    list->ended_ok = false;
    list->render_pass_open = 0;
    list->marker_depth = 0;
    list->error = CV_OK;
    list->error_message[0] = '\0';
}

__attribute__((format(printf, 3, 4))) static cv_result fail(cv_command_list *list, cv_result code, const char *fmt,
                                                            ...) {
    if (list->error == CV_OK) {
        char detail[200];
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(detail, sizeof(detail), fmt, ap);
        va_end(ap);
        list->error = code;
        snprintf(list->error_message, sizeof(list->error_message), "command %u: %s", list->count, detail);
    }
    return cv_error(list->error, "%s", list->error_message);
}

cv_result cv_command_list_end(cv_command_list *list) {
    if (!list->recording && list->error == CV_OK)
        return fail(list, CV_ERROR_BAD_STATE, "end of a list that is not recording");
    list->recording = false;
    if (list->error != CV_OK)
        return cv_error(list->error, "%s", list->error_message);
    if (list->render_pass_open)
        return fail(list, CV_ERROR_BAD_STATE, "list ends inside a render pass (missing end_render_pass)");
    if (list->marker_depth != 0)
        return fail(list, CV_ERROR_BAD_STATE, "list ends with %d open begin_marker(s)", list->marker_depth);
    list->ended_ok = true;
    return CV_OK;
}

const char *cv_command_list_error(const cv_command_list *list) { return list->error_message; }

void cv_list_string(const cv_command_list *l, cv_span s, char *buf, size_t cap) {
    if (cap == 0)
        return;
    size_t n = s.size < cap - 1 ? s.size : cap - 1;
    if (n)
        memcpy(buf, l->data + s.offset, n);
    buf[n] = '\0';
}

static bool grow(void **ptr, uint32_t *capacity, uint32_t needed, size_t elem, uint32_t limit) {
    if (needed <= *capacity)
        return true;
    if (needed > limit)
        return false;
    uint64_t cap = *capacity ? *capacity : 16;
    while (cap < needed)
        cap *= 2;
    if (cap > limit)
        cap = limit;
    void *p = realloc(*ptr, (size_t)cap * elem);
    if (!p)
        return false;
    *ptr = p;
    *capacity = (uint32_t)cap;
    return true;
}

static cv_result push_data(cv_command_list *list, const void *src, uint32_t size, cv_span *out) {
    uint32_t aligned = (list->data_size + 3u) & ~3u;
    if ((uint64_t)aligned + size > CV_MAX_LIST_DATA ||
        !grow((void **)&list->data, &list->data_capacity, aligned + size, 1, CV_MAX_LIST_DATA))
        return fail(list, CV_ERROR_LIMIT_EXCEEDED, "list data would exceed %u bytes", CV_MAX_LIST_DATA);
    if (size)
        memcpy(list->data + aligned, src, size);
    out->offset = aligned;
    out->size = size;
    list->data_size = aligned + size;
    return CV_OK;
}

static cv_result check_tag(cv_command_list *list, const char *field, uint64_t id, cv_handle_type want) {
    if (id == 0 || cv_handle_type_of(id) == want)
        return CV_OK;
    return fail(list, CV_ERROR_WRONG_HANDLE_TYPE, "field '%s' wants a %s handle, got a %s handle (0x%016llx)", field,
                cv_handle_type_name(want), cv_handle_type_name(cv_handle_type_of(id)), (unsigned long long)id);
}

static cv_result check_any_tag(cv_command_list *list, const char *field, uint64_t id) {
    if (cv_handle_type_of(id) < CV_HANDLE_TYPE_COUNT)
        return CV_OK;
    return fail(list, CV_ERROR_INVALID_HANDLE, "field '%s': 0x%016llx has no valid handle type tag", field,
                (unsigned long long)id);
}

static cv_result store_bytes(cv_command_list *list, const char *field, const void *src, uint32_t size, uint32_t limit,
                             cv_span *out) {
    if (size > limit)
        return fail(list, CV_ERROR_LIMIT_EXCEEDED, "field '%s' has %u bytes, limit %u", field, size, limit);
    if (size && !src)
        return fail(list, CV_ERROR_INVALID_ARGUMENT, "field '%s' has size %u but no data", field, size);
    return push_data(list, src, size, out);
}

static cv_result store_string(cv_command_list *list, const char *field, const char *s, cv_span *out) {
    size_t n = s ? strlen(s) : 0;
    if (n >= CV_LABEL_MAX)
        return fail(list, CV_ERROR_LIMIT_EXCEEDED, "field '%s' is %zu bytes long, limit %u", field, n,
                    CV_LABEL_MAX - 1);
    return push_data(list, s, (uint32_t)n, out);
}

static cv_result store_bindings(cv_command_list *list, const char *field, const cv_binding *b, uint32_t count,
                                cv_span *out) {
    if (count > CV_MAX_BINDINGS)
        return fail(list, CV_ERROR_LIMIT_EXCEEDED, "field '%s' has %u bindings, limit %u", field, count,
                    CV_MAX_BINDINGS);
    if (count && !b)
        return fail(list, CV_ERROR_INVALID_ARGUMENT, "field '%s' has count %u but no array", field, count);
    for (uint32_t i = 0; i < count; i++) {
        cv_handle_type t = cv_handle_type_of(b[i].resource.id);
        if (b[i].resource.id == 0)
            return fail(list, CV_ERROR_INVALID_HANDLE, "binding %u has a null resource", i);
        if (t != CV_HANDLE_BUFFER && t != CV_HANDLE_TEXTURE)
            return fail(list, CV_ERROR_WRONG_HANDLE_TYPE, "binding %u: a %s handle cannot be bound", i,
                        cv_handle_type_name(t));
        cv_result r = check_tag(list, "binding sampler", b[i].sampler.id, CV_HANDLE_SAMPLER);
        if (r != CV_OK)
            return r;
    }
    uint32_t needed = list->binding_count + count;
    if (!grow((void **)&list->bindings, &list->binding_capacity, needed, sizeof(cv_binding), CV_MAX_COMMANDS))
        return fail(list, CV_ERROR_LIMIT_EXCEEDED, "too many bindings in one list");
    if (count)
        memcpy(list->bindings + list->binding_count, b, count * sizeof(cv_binding));
    out->offset = list->binding_count;
    out->size = count;
    list->binding_count = needed;
    return CV_OK;
}

/* Ordering rules that need no device: what may appear inside a render pass,
 * marker pairing, push constant size. */
static cv_result check_structure(cv_command_list *list, const cv_command *c) {
    bool in_pass = list->render_pass_open != 0;
    switch (c->type) {
    case CV_CMD_BEGIN_RENDER_PASS:
        if (in_pass)
            return fail(list, CV_ERROR_BAD_STATE, "begin_render_pass inside a render pass");
        break;
    case CV_CMD_END_RENDER_PASS:
        if (!in_pass)
            return fail(list, CV_ERROR_BAD_STATE, "end_render_pass without begin_render_pass");
        break;
    case CV_CMD_DRAW:
    case CV_CMD_DRAW_INDEXED:
        if (!in_pass)
            return fail(list, CV_ERROR_BAD_STATE, "%s outside a render pass", cv_command_name(c->type));
        break;
    case CV_CMD_END_MARKER:
        if (list->marker_depth <= 0)
            return fail(list, CV_ERROR_BAD_STATE, "end_marker without begin_marker");
        break;
    case CV_CMD_BEGIN_MARKER:
    case CV_CMD_TIMESTAMP:
    case CV_CMD_BARRIER: break;
    case CV_CMD_TRACE_RAYS:
        if (in_pass)
            return fail(list, CV_ERROR_BAD_STATE, "trace_rays inside a render pass");
        if (c->u.trace_rays.flags & ~(uint32_t)CV_TRACE_FLAGS_ALL)
            return fail(list, CV_ERROR_INVALID_ARGUMENT, "trace_rays: unknown flags 0x%x", c->u.trace_rays.flags);
        break;
    default:
        if (in_pass)
            return fail(list, CV_ERROR_BAD_STATE, "%s inside a render pass", cv_command_name(c->type));
        break;
    }
    cv_span push = { 0, 0 };
    if (c->type == CV_CMD_DISPATCH)
        push = c->u.dispatch.push;
    if (c->type == CV_CMD_DISPATCH_INDIRECT)
        push = c->u.dispatch_indirect.push;
    if (c->type == CV_CMD_DRAW)
        push = c->u.draw.push;
    if (c->type == CV_CMD_DRAW_INDEXED)
        push = c->u.draw_indexed.push;
    if (push.size > CV_MAX_PUSH_CONSTANTS)
        return fail(list, CV_ERROR_LIMIT_EXCEEDED, "%u bytes of push constants, limit %u", push.size,
                    CV_MAX_PUSH_CONSTANTS);
    return CV_OK;
}

static void apply_structure(cv_command_list *list, const cv_command *c) {
    if (c->type == CV_CMD_BEGIN_RENDER_PASS)
        list->render_pass_open = 1;
    if (c->type == CV_CMD_END_RENDER_PASS)
        list->render_pass_open = 0;
    if (c->type == CV_CMD_BEGIN_MARKER)
        list->marker_depth++;
    if (c->type == CV_CMD_END_MARKER)
        list->marker_depth--;
}

/* Field copiers, one per field type; `r` collects the first failure. */
#define CV_COPY_SCALAR(n) cmd->n = a->n;
#define CV_COPY_U32(n) CV_COPY_SCALAR(n)
#define CV_COPY_U64(n) CV_COPY_SCALAR(n)
#define CV_COPY_I32(n) CV_COPY_SCALAR(n)
#define CV_COPY_F32(n) CV_COPY_SCALAR(n)
#define CV_COPY_HANDLE(n, T) \
    if (r == CV_OK) { \
        r = check_tag(list, #n, a->n.id, T); \
        cmd->n = a->n; \
    }
#define CV_COPY_BUFFER(n) CV_COPY_HANDLE(n, CV_HANDLE_BUFFER)
#define CV_COPY_TEXTURE(n) CV_COPY_HANDLE(n, CV_HANDLE_TEXTURE)
#define CV_COPY_PIPELINE(n) CV_COPY_HANDLE(n, CV_HANDLE_PIPELINE)
#define CV_COPY_ACCEL(n) CV_COPY_HANDLE(n, CV_HANDLE_ACCEL)
#define CV_COPY_ANY(n) \
    if (r == CV_OK) { \
        r = check_any_tag(list, #n, a->n.id); \
        cmd->n = a->n; \
    }
#define CV_COPY_BYTES(n) \
    if (r == CV_OK) \
        r = store_bytes(list, #n, a->n, a->n##_size, CV_MAX_UPDATE_BYTES, &cmd->n);
#define CV_COPY_STRING(n) \
    if (r == CV_OK) \
        r = store_string(list, #n, a->n, &cmd->n);
#define CV_COPY_BINDINGS(n) \
    if (r == CV_OK) \
        r = store_bindings(list, #n, a->n, a->n##_count, &cmd->n);
#define CV_COPY_FIELD(num, TYPE, name) CV_COPY_##TYPE(name)

static cv_result begin_record(cv_command_list *list, cv_command_type type, cv_queue_type queue, const void *args) {
    if (list->error != CV_OK)
        return cv_error(list->error, "%s", list->error_message);
    if (!list->recording) /* not sticky: an ended list stays as it was */
        return cv_error(CV_ERROR_BAD_STATE, "%s recorded into a list that is not recording", cv_command_name(type));
    if (!args)
        return fail(list, CV_ERROR_INVALID_ARGUMENT, "%s with NULL arguments", cv_command_name(type));
    if ((unsigned)queue >= CV_QUEUE_TYPE_COUNT)
        return fail(list, CV_ERROR_INVALID_ARGUMENT, "%s on unknown queue type %d", cv_command_name(type),
                    (int)queue);
    if (!(cv_command_queues(type) & (1u << queue)))
        return fail(list, CV_ERROR_QUEUE_MISMATCH, "%s is not allowed on the %s queue", cv_command_name(type),
                    cv_queue_type_name(queue));
    if (!grow((void **)&list->commands, &list->capacity, list->count + 1, sizeof(cv_command), CV_MAX_COMMANDS))
        return fail(list, CV_ERROR_LIMIT_EXCEEDED, "list would exceed %u commands", CV_MAX_COMMANDS);
    return CV_OK;
}

static cv_result finish_record(cv_command_list *list, cv_command *c, cv_result r, uint32_t saved_data,
                               uint32_t saved_bindings) {
    if (r == CV_OK)
        r = check_structure(list, c);
    if (r != CV_OK) {
        list->data_size = saved_data;
        list->binding_count = saved_bindings;
        return r;
    }
    apply_structure(list, c);
    list->queue_mask |= 1u << c->queue;
    list->count++;
    return CV_OK;
}

#define CV_CMD_RECORD_DEF(id, UPPER, lower, Camel, queues) \
    cv_result cv_cmd_##lower(cv_command_list *list, cv_queue_type queue, const cv_##lower##_args *a) { \
        cv_result r = begin_record(list, CV_CMD_##UPPER, queue, a); \
        if (r != CV_OK) \
            return r; \
        uint32_t saved_data = list->data_size, saved_bindings = list->binding_count; \
        cv_command *c = &list->commands[list->count]; \
        memset(c, 0, sizeof(*c)); \
        c->type = CV_CMD_##UPPER; \
        c->queue = queue; \
        cv_##lower##_cmd *cmd = &c->u.lower; \
        CV_FIELDS_##lower(CV_COPY_FIELD)(void) cmd; \
        return finish_record(list, c, r, saved_data, saved_bindings); \
    }
CV_COMMAND_TABLE(CV_CMD_RECORD_DEF)
#undef CV_CMD_RECORD_DEF

static void visit_bindings(const cv_command_list *list, cv_span s, cv_handle_visitor fn, void *user) {
    const cv_binding *b = cv_list_bindings(list, s);
    for (uint32_t i = 0; i < s.size; i++) {
        if (b[i].resource.id)
            fn(b[i].resource.id, user);
        if (b[i].sampler.id)
            fn(b[i].sampler.id, user);
    }
}

#define CV_VISIT_NONE(n)
#define CV_VISIT_ID(n) \
    if (cmd->n.id) \
        fn(cmd->n.id, user);
#define CV_VISIT_U32(n) CV_VISIT_NONE(n)
#define CV_VISIT_U64(n) CV_VISIT_NONE(n)
#define CV_VISIT_I32(n) CV_VISIT_NONE(n)
#define CV_VISIT_F32(n) CV_VISIT_NONE(n)
#define CV_VISIT_BYTES(n) CV_VISIT_NONE(n)
#define CV_VISIT_STRING(n) CV_VISIT_NONE(n)
#define CV_VISIT_BUFFER(n) CV_VISIT_ID(n)
#define CV_VISIT_TEXTURE(n) CV_VISIT_ID(n)
#define CV_VISIT_PIPELINE(n) CV_VISIT_ID(n)
#define CV_VISIT_ACCEL(n) CV_VISIT_ID(n)
#define CV_VISIT_ANY(n) CV_VISIT_ID(n)
#define CV_VISIT_BINDINGS(n) visit_bindings(list, cmd->n, fn, user);
#define CV_VISIT_FIELD(num, TYPE, name) CV_VISIT_##TYPE(name)

void cv_command_visit_handles(const cv_command_list *list, const cv_command *c, cv_handle_visitor fn, void *user) {
    switch (c->type) {
#define CV_CMD_VISIT(id, UPPER, lower, Camel, queues) \
    case CV_CMD_##UPPER: { \
        const cv_##lower##_cmd *cmd = &c->u.lower; \
        CV_FIELDS_##lower(CV_VISIT_FIELD)(void) cmd; \
        break; \
    }
        CV_COMMAND_TABLE(CV_CMD_VISIT)
#undef CV_CMD_VISIT
    default: break;
    }
    (void)list;
}

static void map_bindings(cv_command_list *list, cv_span s, cv_handle_mapper fn, void *user) {
    cv_binding *b = s.size ? list->bindings + s.offset : NULL;
    for (uint32_t i = 0; i < s.size; i++) {
        if (b[i].resource.id)
            b[i].resource.id = fn(b[i].resource.id, user);
        if (b[i].sampler.id)
            b[i].sampler.id = fn(b[i].sampler.id, user);
    }
}

#define CV_MAP_NONE(n)
#define CV_MAP_ID(n) \
    if (cmd->n.id) \
        cmd->n.id = fn(cmd->n.id, user);
#define CV_MAP_U32(n) CV_MAP_NONE(n)
#define CV_MAP_U64(n) CV_MAP_NONE(n)
#define CV_MAP_I32(n) CV_MAP_NONE(n)
#define CV_MAP_F32(n) CV_MAP_NONE(n)
#define CV_MAP_BYTES(n) CV_MAP_NONE(n)
#define CV_MAP_STRING(n) CV_MAP_NONE(n)
#define CV_MAP_BUFFER(n) CV_MAP_ID(n)
#define CV_MAP_TEXTURE(n) CV_MAP_ID(n)
#define CV_MAP_PIPELINE(n) CV_MAP_ID(n)
#define CV_MAP_ACCEL(n) CV_MAP_ID(n)
#define CV_MAP_ANY(n) CV_MAP_ID(n)
#define CV_MAP_BINDINGS(n) map_bindings(list, cmd->n, fn, user);
#define CV_MAP_FIELD(num, TYPE, name) CV_MAP_##TYPE(name)

void cv_command_map_handles(cv_command_list *list, cv_command *c, cv_handle_mapper fn, void *user) {
    switch (c->type) {
#define CV_CMD_MAP(id, UPPER, lower, Camel, queues) \
    case CV_CMD_##UPPER: { \
        cv_##lower##_cmd *cmd = &c->u.lower; \
        CV_FIELDS_##lower(CV_MAP_FIELD)(void) cmd; \
        break; \
    }
        CV_COMMAND_TABLE(CV_CMD_MAP)
#undef CV_CMD_MAP
    default: break;
    }
}
