/* Field-by-field comparison of two command lists (see random_list.h),
 * expanded from the command table so every field of every command is
 * compared, side data by content. */
#include "random_list.h"

#include <stdio.h>
#include <string.h>

static bool differ(const char *what, uint32_t index, const char *field) {
    fprintf(stderr, "%s: command %u differs in '%s'\n", what, index, field);
    return false;
}

static bool same_span_content(const cv_command_list *a, const cv_command_list *b, cv_span x, cv_span y, size_t elem,
                              bool bindings) {
    if (x.size != y.size || x.offset != y.offset)
        return false;
    if (x.size == 0) /* the list may have no side array to point into */
        return true;
    const void *pa = bindings ? (const void *)cv_list_bindings(a, x) : cv_list_bytes(a, x);
    const void *pb = bindings ? (const void *)cv_list_bindings(b, y) : cv_list_bytes(b, y);
    return memcmp(pa, pb, x.size * elem) == 0;
}

#define CMP_SCALAR(f) \
    if (memcmp(&x->f, &y->f, sizeof(x->f)) != 0) \
        return differ(what, i, #f);
#define CMP_U32(f) CMP_SCALAR(f)
#define CMP_U64(f) CMP_SCALAR(f)
#define CMP_I32(f) CMP_SCALAR(f)
#define CMP_F32(f) CMP_SCALAR(f)
#define CMP_BUFFER(f) CMP_SCALAR(f)
#define CMP_TEXTURE(f) CMP_SCALAR(f)
#define CMP_PIPELINE(f) CMP_SCALAR(f)
#define CMP_ACCEL(f) CMP_SCALAR(f)
#define CMP_ANY(f) CMP_SCALAR(f)
#define CMP_BYTES(f) \
    if (!same_span_content(a, b, x->f, y->f, 1, false)) \
        return differ(what, i, #f);
#define CMP_STRING(f) CMP_BYTES(f)
#define CMP_BINDINGS(f) \
    if (!same_span_content(a, b, x->f, y->f, sizeof(cv_binding), true)) \
        return differ(what, i, #f);
#define CMP_FIELD(num, TYPE, f) CMP_##TYPE(f)

static bool commands_equal(const cv_command_list *a, const cv_command_list *b, uint32_t i, const char *what) {
    const cv_command *ca = &a->commands[i], *cb = &b->commands[i];
    if (ca->type != cb->type)
        return differ(what, i, "type");
    if (ca->queue != cb->queue)
        return differ(what, i, "queue");
    switch (ca->type) {
#define CMP_CASE(id, UPPER, lower, Camel, queues) \
    case CV_CMD_##UPPER: { \
        const cv_##lower##_cmd *x = &ca->u.lower, *y = &cb->u.lower; \
        CV_FIELDS_##lower(CMP_FIELD)(void) x; \
        (void)y; \
        break; \
    }
        CV_COMMAND_TABLE(CMP_CASE)
#undef CMP_CASE
    default: return differ(what, i, "type (unknown)");
    }
    /* Recording zeroes each command before filling it, so the stored
     * commands must also be byte-identical, padding included. */
    if (memcmp(ca, cb, sizeof(*ca)) != 0)
        return differ(what, i, "stored bytes");
    return true;
}

bool lists_equal(const cv_command_list *a, const cv_command_list *b, const char *what) {
    if (a->count != b->count || a->binding_count != b->binding_count || a->data_size != b->data_size ||
        a->queue_mask != b->queue_mask || a->ended_ok != b->ended_ok) {
        fprintf(stderr, "%s: lists differ: count %u/%u bindings %u/%u data %u/%u queue mask %u/%u ended %d/%d\n",
                what, a->count, b->count, a->binding_count, b->binding_count, a->data_size, b->data_size,
                a->queue_mask, b->queue_mask, a->ended_ok, b->ended_ok);
        return false;
    }
    for (uint32_t i = 0; i < a->count; i++)
        if (!commands_equal(a, b, i, what))
            return false;
    return true;
}
