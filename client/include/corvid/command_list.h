/* Command lists: stateless high-level GPU commands, recorded once, compiled per
 * device, submitted many times.
 *
 * Every command is tagged with the queue type it is meant for; recording a
 * command on a queue its table entry does not allow is an error, and the list
 * keeps the mask of queues it uses. Commands are stateless (each dispatch or
 * draw carries its pipeline, bindings and push constants), so lists can be
 * recorded in parallel from many threads, one thread per list, with no locks.
 *
 * Errors are sticky: the first error is kept (with its message) and every later
 * call returns it without recording; cv_command_list_end() returns it too.
 *
 * What recording checks needs no device: queue types, handle type tags, sizes
 * and limits, render-pass and marker nesting. What needs a device (is the handle
 * loaded, is the copy in bounds, do formats match) is checked when the list is
 * compiled for a device (client/src/validate.c), identically for every backend. */
#ifndef CORVID_COMMAND_LIST_H
#define CORVID_COMMAND_LIST_H

#include "corvid/command_table.h"
#include "corvid/handle.h"
#include "corvid/result.h"

/* A slice of a list's side arrays: bytes in `data` or entries in `bindings`. */
typedef struct cv_span {
    uint32_t offset, size;
} cv_span;

/* One resource bound to a pipeline slot. Slot i of a command binds bindings[i]. */
typedef struct cv_binding {
    cv_handle resource; /* buffer or texture */
    cv_sampler sampler; /* sampled textures only */
    uint64_t offset;    /* buffers: byte offset */
    uint64_t range;     /* buffers: bytes, 0 = to the end */
} cv_binding;

/* Storage form of each field type (inside a recorded list). */
#define CV_STORE_U32(n) uint32_t n;
#define CV_STORE_U64(n) uint64_t n;
#define CV_STORE_I32(n) int32_t n;
#define CV_STORE_F32(n) float n;
#define CV_STORE_BUFFER(n) cv_buffer n;
#define CV_STORE_TEXTURE(n) cv_texture n;
#define CV_STORE_PIPELINE(n) cv_pipeline n;
#define CV_STORE_ACCEL(n) cv_accel n;
#define CV_STORE_ANY(n) cv_handle n;
#define CV_STORE_BYTES(n) cv_span n;
#define CV_STORE_STRING(n) cv_span n;
#define CV_STORE_BINDINGS(n) cv_span n;
/* Argument form of each field type (what the recording call takes). */
#define CV_ARG_U32(n) uint32_t n;
#define CV_ARG_U64(n) uint64_t n;
#define CV_ARG_I32(n) int32_t n;
#define CV_ARG_F32(n) float n;
#define CV_ARG_BUFFER(n) cv_buffer n;
#define CV_ARG_TEXTURE(n) cv_texture n;
#define CV_ARG_PIPELINE(n) cv_pipeline n;
#define CV_ARG_ACCEL(n) cv_accel n;
#define CV_ARG_ANY(n) cv_handle n;
#define CV_ARG_BYTES(n) \
    const void *n; \
    uint32_t n##_size;
#define CV_ARG_STRING(n) const char *n;
#define CV_ARG_BINDINGS(n) \
    const cv_binding *n; \
    uint32_t n##_count;

#define CV_STORE_FIELD(num, TYPE, name) CV_STORE_##TYPE(name)
#define CV_ARG_FIELD(num, TYPE, name) CV_ARG_##TYPE(name)

/* cv_<lower>_cmd (stored) and cv_<lower>_args (recording arguments). The
 * `unused` member keeps field-less commands valid C. */
#define CV_CMD_STRUCTS(id, UPPER, lower, Camel, queues) \
    typedef struct cv_##lower##_cmd { \
        CV_FIELDS_##lower(CV_STORE_FIELD) uint8_t unused; \
    } cv_##lower##_cmd; \
    typedef struct cv_##lower##_args { \
        CV_FIELDS_##lower(CV_ARG_FIELD) uint8_t unused; \
    } cv_##lower##_args;
CV_COMMAND_TABLE(CV_CMD_STRUCTS)
#undef CV_CMD_STRUCTS

typedef struct cv_command {
    cv_command_type type;
    cv_queue_type queue;
    union {
#define CV_CMD_MEMBER(id, UPPER, lower, Camel, queues) cv_##lower##_cmd lower;
        CV_COMMAND_TABLE(CV_CMD_MEMBER)
#undef CV_CMD_MEMBER
    } u;
} cv_command;

#define CV_MAX_COMMANDS (1u << 20)
#define CV_MAX_LIST_DATA (64u << 20)

typedef struct cv_command_list {
    uint64_t id; /* the cv_cmdlist handle, 0 for a free-standing list */
    cv_command *commands;
    uint32_t count, capacity;
    cv_binding *bindings;
    uint32_t binding_count, binding_capacity;
    uint8_t *data;
    uint32_t data_size, data_capacity;
    uint32_t queue_mask; /* CV_QUEUE_BIT_* of every recorded command */
    uint32_t version;    /* bumps on every begin; compiled forms key on it */
    bool recording;
    bool ended_ok; /* ended without error: may be compiled and submitted */
    int32_t render_pass_open;
    int32_t marker_depth;
    cv_result error; /* sticky first error */
    char error_message[256];
} cv_command_list;

void cv_command_list_init(cv_command_list *list);
void cv_command_list_finish(cv_command_list *list);
/* Clears the list and starts recording. */
void cv_command_list_begin(cv_command_list *list);
/* Ends recording; returns the sticky error (CV_OK if the list is usable). */
cv_result cv_command_list_end(cv_command_list *list);
/* The sticky error's message ("" if none). */
const char *cv_command_list_error(const cv_command_list *list);

/* Recording calls: cv_cmd_dispatch(list, CV_QUEUE_COMPUTE, &(cv_dispatch_args){...}). */
#define CV_CMD_RECORD_DECL(id, UPPER, lower, Camel, queues) \
    cv_result cv_cmd_##lower(cv_command_list *list, cv_queue_type queue, const cv_##lower##_args *args);
CV_COMMAND_TABLE(CV_CMD_RECORD_DECL)
#undef CV_CMD_RECORD_DECL

/* Accessors for a stored command's side data. */
static inline const void *cv_list_bytes(const cv_command_list *l, cv_span s) {
    return s.size ? l->data + s.offset : NULL;
}
static inline const cv_binding *cv_list_bindings(const cv_command_list *l, cv_span s) {
    return s.size ? l->bindings + s.offset : NULL;
}
/* Copies a STRING field into buf (NUL-terminated, truncated to cap). */
void cv_list_string(const cv_command_list *l, cv_span s, char *buf, size_t cap);

/* Calls fn for every non-zero handle a stored command references (handle
 * fields, bound resources and samplers), in field order. */
typedef void (*cv_handle_visitor)(uint64_t id, void *user);
void cv_command_visit_handles(const cv_command_list *list, const cv_command *cmd, cv_handle_visitor fn, void *user);

/* Replaces every non-zero handle a stored command references (the same ones,
 * in the same order, as cv_command_visit_handles) with fn's answer. Used to
 * translate a list recorded against one context's handles into another's (a
 * node's session). fn returns the new id; what it does with an id it cannot
 * translate (return 0 and note the failure) is up to the caller. */
typedef uint64_t (*cv_handle_mapper)(uint64_t id, void *user);
void cv_command_map_handles(cv_command_list *list, cv_command *cmd, cv_handle_mapper fn, void *user);

#endif
