/* Command lists <-> protobuf CommandList (see command_codec.h).
 *
 * Per command, the encoder fills the generated Corvid__<Camel>Cmd from the
 * stored cv_<lower>_cmd, and the decoder fills cv_<lower>_args from the
 * unpacked message and calls cv_cmd_<lower>; both are expanded from
 * CV_COMMAND_TABLE and CV_FIELDS_<lower>, relying on protobuf-c's naming
 * (Corvid__<Camel>Cmd, CORVID__<UPPER>_CMD__INIT, CORVID__COMMAND__CMD_<UPPER>,
 * member <lower> of Command).
 *
 * The CommandList wrapper (field 1: repeated, length-delimited Command) is
 * framed here, one Command at a time, rather than packed or unpacked as one
 * message: encoding needs no message tree for the whole list, and decoding
 * unpacks each Command into an arena that is reset between commands, so
 * memory stays bounded by the largest command, not the whole input. The bytes
 * are the same as protobuf-c packing a Corvid__CommandList (tests/codec
 * checks). */
#include "corvid/command_codec.h"

#include <stdlib.h>
#include <string.h>

#include "corvid.pb-c.h"
#include "proto_arena.h"

/* Protobuf wire types and CommandList's one field. */
enum { WIRE_VARINT = 0, WIRE_I64 = 1, WIRE_LEN = 2, WIRE_I32 = 5 };
#define LIST_FIELD_COMMANDS 1u
#define LIST_COMMANDS_KEY ((LIST_FIELD_COMMANDS << 3) | WIRE_LEN)
#define VARINT_MAX_BYTES 10u

/* What unpacking one Command may allocate: its bytes and strings are copied
 * once, and every legitimate command's structs fit well within 64 KiB, while
 * a hostile one (a million empty Bindings) blows far past this. */
#define UNPACK_BUDGET(wire_bytes) (2u * (size_t)(wire_bytes) + 64u * 1024u)

/* BYTES lengths and binding counts are narrowed to uint32_t for the
 * recording calls; nothing inside an accepted input can be larger. */
_Static_assert(CV_MAX_ENCODED_LIST <= UINT32_MAX, "decoded sizes must fit in uint32_t");

/* ---- Encoding ---- */

/* Per command: the message and the storage its pointers refer to while it is
 * packed (labels need a NUL terminator, bindings an array of pointers). */
#define ENC_SCRATCH_U32(f)
#define ENC_SCRATCH_U64(f)
#define ENC_SCRATCH_I32(f)
#define ENC_SCRATCH_F32(f)
#define ENC_SCRATCH_BUFFER(f)
#define ENC_SCRATCH_TEXTURE(f)
#define ENC_SCRATCH_PIPELINE(f)
#define ENC_SCRATCH_ACCEL(f)
#define ENC_SCRATCH_ANY(f)
#define ENC_SCRATCH_BYTES(f)
#define ENC_SCRATCH_STRING(f) char f##_text[CV_LABEL_MAX];
#define ENC_SCRATCH_BINDINGS(f) \
    Corvid__Binding f##_items[CV_MAX_BINDINGS]; \
    Corvid__Binding *f##_ptrs[CV_MAX_BINDINGS];
#define ENC_SCRATCH_FIELD(num, TYPE, f) ENC_SCRATCH_##TYPE(f)

#define ENC_SCRATCH_TYPE(id, UPPER, lower, Camel, queues) \
    typedef struct enc_##lower { \
        Corvid__##Camel##Cmd msg; \
        CV_FIELDS_##lower(ENC_SCRATCH_FIELD) \
    } enc_##lower;
CV_COMMAND_TABLE(ENC_SCRATCH_TYPE)
#undef ENC_SCRATCH_TYPE

typedef union encode_scratch {
#define ENC_SCRATCH_MEMBER(id, UPPER, lower, Camel, queues) enc_##lower lower;
    CV_COMMAND_TABLE(ENC_SCRATCH_MEMBER)
#undef ENC_SCRATCH_MEMBER
} encode_scratch;

/* Spans come from the list itself; checking them keeps a list modified by
 * hand from making the encoder read outside its arrays. */
static cv_result check_span(uint32_t index, const char *field, cv_span s, uint32_t limit, uint32_t array_size) {
    if (s.size > limit || s.offset > array_size || s.size > array_size - s.offset)
        return cv_error(CV_ERROR_INVALID_ARGUMENT,
                        "encode: command %u field '%s' spans [%u, +%u), outside the list (%u entries, limit %u)",
                        index, field, s.offset, s.size, array_size, limit);
    return CV_OK;
}

/* A stored label as the NUL-terminated string protobuf-c packs. A list with
 * only empty labels may have no data array at all. */
static char *label_text(const cv_command_list *list, cv_span s, char text[CV_LABEL_MAX]) {
    if (s.size)
        memcpy(text, list->data + s.offset, s.size);
    text[s.size] = '\0';
    return text;
}

#define ENC_SCALAR(f) m->f = cmd->f;
#define ENC_U32(f) ENC_SCALAR(f)
#define ENC_U64(f) ENC_SCALAR(f)
#define ENC_I32(f) ENC_SCALAR(f)
#define ENC_F32(f) ENC_SCALAR(f)
#define ENC_HANDLE(f) m->f = cmd->f.id;
#define ENC_BUFFER(f) ENC_HANDLE(f)
#define ENC_TEXTURE(f) ENC_HANDLE(f)
#define ENC_PIPELINE(f) ENC_HANDLE(f)
#define ENC_ACCEL(f) ENC_HANDLE(f)
#define ENC_ANY(f) ENC_HANDLE(f)
#define ENC_BYTES(f) \
    if ((r = check_span(index, #f, cmd->f, CV_MAX_LIST_DATA, list->data_size)) != CV_OK) \
        return r; \
    m->f.len = cmd->f.size; \
    m->f.data = cmd->f.size ? (uint8_t *)list->data + cmd->f.offset : NULL;
#define ENC_STRING(f) \
    if ((r = check_span(index, #f, cmd->f, CV_LABEL_MAX - 1, list->data_size)) != CV_OK) \
        return r; \
    m->f = label_text(list, cmd->f, sc->f##_text);
#define ENC_BINDINGS(f) \
    if ((r = check_span(index, #f, cmd->f, CV_MAX_BINDINGS, list->binding_count)) != CV_OK) \
        return r; \
    for (uint32_t i = 0; i < cmd->f.size; i++) { \
        const cv_binding *b = &list->bindings[cmd->f.offset + i]; \
        sc->f##_items[i] = (Corvid__Binding)CORVID__BINDING__INIT; \
        sc->f##_items[i].resource = b->resource.id; \
        sc->f##_items[i].sampler = b->sampler.id; \
        sc->f##_items[i].offset = b->offset; \
        sc->f##_items[i].range = b->range; \
        sc->f##_ptrs[i] = &sc->f##_items[i]; \
    } \
    m->n_##f = cmd->f.size; \
    m->f = sc->f##_ptrs;
#define ENC_FIELD(num, TYPE, f) ENC_##TYPE(f)

/* Fills `wire` (pointing into `scratch`) from command `index` of the list. */
static cv_result fill_wire(const cv_command_list *list, uint32_t index, Corvid__Command *wire,
                           encode_scratch *scratch) {
    const cv_command *c = &list->commands[index];
    cv_result r = CV_OK;
    *wire = (Corvid__Command)CORVID__COMMAND__INIT;
    wire->queue = (uint32_t)c->queue;
    switch (c->type) {
#define ENC_CASE(id, UPPER, lower, Camel, queues) \
    case CV_CMD_##UPPER: { \
        enc_##lower *sc = &scratch->lower; \
        Corvid__##Camel##Cmd *m = &sc->msg; \
        const cv_##lower##_cmd *cmd = &c->u.lower; \
        *m = (Corvid__##Camel##Cmd)CORVID__##UPPER##_CMD__INIT; \
        CV_FIELDS_##lower(ENC_FIELD)(void) cmd; \
        wire->cmd_case = CORVID__COMMAND__CMD_##UPPER; \
        wire->lower = m; \
        return r; \
    }
        CV_COMMAND_TABLE(ENC_CASE)
#undef ENC_CASE
    default: break;
    }
    return cv_error(CV_ERROR_INVALID_ARGUMENT, "encode: command %u has unknown type %d", index, (int)c->type);
}

static size_t varint_size(uint64_t v) {
    size_t n = 1;
    while (v >= 0x80) {
        v >>= 7;
        n++;
    }
    return n;
}

static size_t put_varint(uint8_t *p, uint64_t v) {
    size_t n = 0;
    while (v >= 0x80) {
        p[n++] = (uint8_t)(v | 0x80);
        v >>= 7;
    }
    p[n++] = (uint8_t)v;
    return n;
}

typedef struct out_buffer {
    uint8_t *data;
    size_t size, capacity;
} out_buffer;

static bool reserve(out_buffer *b, size_t extra) {
    if (b->capacity - b->size >= extra)
        return true;
    size_t cap = b->capacity ? b->capacity : 256;
    while (cap - b->size < extra)
        cap *= 2;
    uint8_t *p = realloc(b->data, cap);
    if (!p)
        return false;
    b->data = p;
    b->capacity = cap;
    return true;
}

cv_result cv_command_list_encode(const cv_command_list *list, uint8_t **out, size_t *out_size) {
    if (!list || !out || !out_size)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_command_list_encode: NULL list or output pointer");
    if (!list->ended_ok)
        return cv_error(CV_ERROR_BAD_STATE, "cv_command_list_encode: the list %s",
                        list->recording        ? "is still recording"
                        : list->error != CV_OK ? "ended with an error"
                                               : "was never ended");
    /* A first guess from the list's sizes saves most regrowth. */
    out_buffer b = { 0 };
    if (!reserve(&b, (size_t)list->count * 16 + (size_t)list->binding_count * 40 + list->data_size + 1))
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "cv_command_list_encode: no memory for the output");
    encode_scratch scratch;
    for (uint32_t i = 0; i < list->count; i++) {
        Corvid__Command wire;
        cv_result r = fill_wire(list, i, &wire, &scratch);
        if (r != CV_OK) {
            free(b.data);
            return r;
        }
        size_t n = corvid__command__get_packed_size(&wire);
        size_t framed = 1 + varint_size(n) + n;
        if (framed > CV_MAX_ENCODED_LIST - b.size) {
            free(b.data);
            return cv_error(CV_ERROR_LIMIT_EXCEEDED,
                            "cv_command_list_encode: command %u takes the encoding past %u bytes", i,
                            CV_MAX_ENCODED_LIST);
        }
        if (!reserve(&b, framed)) {
            free(b.data);
            return cv_error(CV_ERROR_OUT_OF_MEMORY, "cv_command_list_encode: no memory for %zu bytes",
                            b.size + framed);
        }
        b.data[b.size++] = LIST_COMMANDS_KEY;
        b.size += put_varint(b.data + b.size, n);
        b.size += corvid__command__pack(&wire, b.data + b.size);
    }
    *out = b.data;
    *out_size = b.size;
    return CV_OK;
}

/* ---- Decoding ---- */

static bool read_varint(const uint8_t **p, const uint8_t *end, uint64_t *value) {
    uint64_t v = 0;
    for (unsigned i = 0; i < VARINT_MAX_BYTES && *p < end; i++) {
        uint8_t byte = *(*p)++;
        v |= (uint64_t)(byte & 0x7f) << (7 * i);
        if (!(byte & 0x80)) {
            *value = v;
            return true;
        }
    }
    return false;
}

/* Unknown CommandList fields are skipped, as protobuf requires, so a newer
 * sender can add list-level fields. */
static cv_result skip_field(const uint8_t **p, const uint8_t *end, size_t at, uint64_t key) {
    uint64_t value, len = 0;
    bool ok = true;
    switch (key & 7) {
    case WIRE_VARINT: ok = read_varint(p, end, &value); break;
    case WIRE_I64: len = 8; break;
    case WIRE_I32: len = 4; break;
    case WIRE_LEN: ok = read_varint(p, end, &len); break;
    default:
        return cv_error(CV_ERROR_MALFORMED, "decode: byte %zu: field %llu has invalid wire type %u", at,
                        (unsigned long long)(key >> 3), (unsigned)(key & 7));
    }
    if (!ok || len > (uint64_t)(end - *p))
        return cv_error(CV_ERROR_MALFORMED, "decode: byte %zu: field %llu runs past the end of the input", at,
                        (unsigned long long)(key >> 3));
    *p += len;
    return CV_OK;
}

static cv_result convert_bindings(uint32_t index, const char *field, Corvid__Binding *const *in, size_t count,
                                  cv_binding out[CV_MAX_BINDINGS]) {
    if (count > CV_MAX_BINDINGS)
        return cv_error(CV_ERROR_LIMIT_EXCEEDED, "decode: command %u field '%s' has %zu bindings, limit %u", index,
                        field, count, CV_MAX_BINDINGS);
    for (size_t i = 0; i < count; i++)
        out[i] = (cv_binding){ .resource = { in[i]->resource },
                               .sampler = { in[i]->sampler },
                               .offset = in[i]->offset,
                               .range = in[i]->range };
    return CV_OK;
}

#define DEC_SCALAR(f) a.f = m->f;
#define DEC_U32(f) DEC_SCALAR(f)
#define DEC_U64(f) DEC_SCALAR(f)
#define DEC_I32(f) DEC_SCALAR(f)
#define DEC_F32(f) DEC_SCALAR(f)
#define DEC_HANDLE(f) a.f.id = m->f;
#define DEC_BUFFER(f) DEC_HANDLE(f)
#define DEC_TEXTURE(f) DEC_HANDLE(f)
#define DEC_PIPELINE(f) DEC_HANDLE(f)
#define DEC_ACCEL(f) DEC_HANDLE(f)
#define DEC_ANY(f) DEC_HANDLE(f)
#define DEC_BYTES(f) \
    a.f = m->f.data; \
    a.f##_size = (uint32_t)m->f.len;
/* Labels end at their first NUL byte, as C strings do. */
#define DEC_STRING(f) a.f = m->f;
#define DEC_BINDINGS(f) \
    cv_binding f##_items[CV_MAX_BINDINGS]; \
    if ((r = convert_bindings(index, #f, m->f, m->n_##f, f##_items)) != CV_OK) \
        return r; \
    a.f = f##_items; \
    a.f##_count = (uint32_t)m->n_##f;
#define DEC_FIELD(num, TYPE, f) DEC_##TYPE(f)

#define DEC_REPLAY(id, UPPER, lower, Camel, queues) \
    static cv_result replay_##lower(cv_command_list *list, uint32_t index, cv_queue_type queue, \
                                    const Corvid__##Camel##Cmd *m) { \
        cv_##lower##_args a; \
        cv_result r = CV_OK; \
        memset(&a, 0, sizeof(a)); \
        CV_FIELDS_##lower(DEC_FIELD)(void) m; \
        (void)index; \
        (void)r; \
        return cv_cmd_##lower(list, queue, &a); \
    }
CV_COMMAND_TABLE(DEC_REPLAY)
#undef DEC_REPLAY

static cv_result replay_command(cv_command_list *list, uint32_t index, const uint8_t *bytes, size_t len,
                                proto_arena *arena) {
    proto_arena_reset(arena, UNPACK_BUDGET(len));
    const Corvid__Command *w = corvid__command__unpack(&arena->allocator, len, bytes);
    if (!w && arena->out_of_memory)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "decode: command %u: no memory to unpack its %zu bytes", index, len);
    if (!w && arena->over_limit)
        return cv_error(CV_ERROR_MALFORMED,
                        "decode: command %u: its %zu bytes unpack to more than %zu bytes (hostile or corrupt)", index,
                        len, UNPACK_BUDGET(len));
    if (!w)
        return cv_error(CV_ERROR_MALFORMED, "decode: command %u: %zu bytes that are not a valid Command message",
                        index, len);
    if (w->queue >= CV_QUEUE_TYPE_COUNT)
        return cv_error(CV_ERROR_MALFORMED, "decode: command %u: queue %u is not a queue type (0..%d)", index,
                        w->queue, CV_QUEUE_TYPE_COUNT - 1);
    cv_queue_type queue = (cv_queue_type)w->queue;
    switch (w->cmd_case) {
#define DEC_CASE(id, UPPER, lower, Camel, queues) \
    case CORVID__COMMAND__CMD_##UPPER: return replay_##lower(list, index, queue, w->lower);
        CV_COMMAND_TABLE(DEC_CASE)
#undef DEC_CASE
    default: break;
    }
    return cv_error(CV_ERROR_MALFORMED,
                    "decode: command %u carries no command (an empty Command, or one this version does not know)",
                    index);
}

static cv_result replay_all(const uint8_t *data, size_t size, cv_command_list *list, proto_arena *arena) {
    const uint8_t *p = data, *end = data + size;
    uint32_t index = 0;
    while (p < end) {
        size_t at = (size_t)(p - data);
        uint64_t key, len;
        if (!read_varint(&p, end, &key))
            return cv_error(CV_ERROR_MALFORMED, "decode: byte %zu: truncated or overlong field key", at);
        if (key >> 3 == 0)
            return cv_error(CV_ERROR_MALFORMED, "decode: byte %zu: field number 0", at);
        cv_result r;
        if (key >> 3 != LIST_FIELD_COMMANDS) {
            r = skip_field(&p, end, at, key);
        } else if (key != LIST_COMMANDS_KEY) {
            r = cv_error(CV_ERROR_MALFORMED, "decode: byte %zu: commands field with wire type %u, not %u", at,
                         (unsigned)(key & 7), WIRE_LEN);
        } else if (!read_varint(&p, end, &len) || len > (uint64_t)(end - p)) {
            r = cv_error(CV_ERROR_MALFORMED, "decode: command %u (byte %zu): length runs past the end of the input",
                         index, at);
        } else {
            r = replay_command(list, index++, p, (size_t)len, arena);
            p += len;
        }
        if (r != CV_OK)
            return r;
    }
    return CV_OK;
}

cv_result cv_command_list_decode(const uint8_t *data, size_t size, cv_command_list *list) {
    if (!list || (!data && size))
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_command_list_decode: NULL list or data");
    if (size > CV_MAX_ENCODED_LIST)
        return cv_error(CV_ERROR_LIMIT_EXCEEDED, "cv_command_list_decode: %zu bytes, limit %u", size,
                        CV_MAX_ENCODED_LIST);
    /* Decode into a fresh list so a failure leaves the caller's untouched. */
    cv_command_list decoded;
    cv_command_list_init(&decoded);
    decoded.id = list->id;
    decoded.version = list->version;
    cv_command_list_begin(&decoded);
    proto_arena arena;
    proto_arena_init(&arena);
    cv_result r = size ? replay_all(data, size, &decoded, &arena) : CV_OK;
    proto_arena_finish(&arena);
    if (r == CV_OK)
        r = cv_command_list_end(&decoded);
    if (r != CV_OK) {
        cv_command_list_finish(&decoded);
        return r;
    }
    cv_command_list_finish(list);
    *list = decoded;
    return CV_OK;
}
