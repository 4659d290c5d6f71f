/* Random valid command lists (see random_list.h). Field generators are
 * expanded from the command table, so a new command is covered with no
 * change here unless it has new structural rules. */
#include "random_list.h"

#include <string.h>

uint64_t test_rng_next(test_rng *rng) {
    /* splitmix64: every seed, including 0, gives a full-period stream. */
    uint64_t z = (rng->state += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

uint32_t test_rng_below(test_rng *rng, uint32_t n) { return (uint32_t)(test_rng_next(rng) % n); }

static uint64_t random_handle(test_rng *r, cv_handle_type type) {
    if (type == CV_HANDLE_NONE || test_rng_below(r, 8) == 0)
        return 0;
    return cv_handle_pack(type, 1 + test_rng_below(r, CV_HANDLE_TAG_MAX),
                          1 + test_rng_below(r, CV_HANDLE_GENERATION_MAX), (uint32_t)test_rng_next(r));
}

/* Any finite float bit pattern, denormals included. NaNs are left out because
 * a compiler may quiet a signalling NaN it copies, and -0 because the wire
 * carries it as +0 (command_codec.h). */
static float random_float(test_rng *r) {
    uint32_t bits = (uint32_t)test_rng_next(r);
    if ((bits & 0x7f800000u) == 0x7f800000u)
        bits &= ~0x00800000u;
    if (bits == 0x80000000u)
        bits = 0;
    float f;
    memcpy(&f, &bits, sizeof(f));
    return f;
}

static void random_bytes(test_rng *r, uint8_t *out, uint32_t n) {
    for (uint32_t i = 0; i < n; i++)
        out[i] = (uint8_t)test_rng_next(r);
}

static void random_label(test_rng *r, char out[CV_LABEL_MAX]) {
    uint32_t n = test_rng_below(r, CV_LABEL_MAX);
    for (uint32_t i = 0; i < n; i++)
        out[i] = (char)(1 + test_rng_below(r, 255));
    out[n] = '\0';
}

static uint32_t random_bindings(test_rng *r, cv_binding out[CV_MAX_BINDINGS]) {
    uint32_t n = test_rng_below(r, CV_MAX_BINDINGS + 1);
    for (uint32_t i = 0; i < n; i++) {
        cv_handle_type t = test_rng_below(r, 2) ? CV_HANDLE_BUFFER : CV_HANDLE_TEXTURE;
        out[i].resource.id = cv_handle_pack(t, 1 + test_rng_below(r, CV_HANDLE_TAG_MAX),
                                            1 + test_rng_below(r, CV_HANDLE_GENERATION_MAX),
                                            (uint32_t)test_rng_next(r));
        out[i].sampler.id = t == CV_HANDLE_TEXTURE ? random_handle(r, CV_HANDLE_SAMPLER) : 0;
        out[i].offset = test_rng_next(r);
        out[i].range = test_rng_next(r);
    }
    return n;
}

static cv_queue_type random_queue(test_rng *r, cv_command_type type) {
    uint32_t allowed = cv_command_queues(type);
    for (;;) {
        cv_queue_type q = (cv_queue_type)test_rng_below(r, CV_QUEUE_TYPE_COUNT);
        if (allowed & (1u << q))
            return q;
    }
}

#define GEN_U32(f) a.f = (uint32_t)test_rng_next(r);
#define GEN_U64(f) a.f = test_rng_next(r);
#define GEN_I32(f) a.f = (int32_t)test_rng_next(r);
#define GEN_F32(f) a.f = random_float(r);
#define GEN_BUFFER(f) a.f.id = random_handle(r, CV_HANDLE_BUFFER);
#define GEN_TEXTURE(f) a.f.id = random_handle(r, CV_HANDLE_TEXTURE);
#define GEN_PIPELINE(f) a.f.id = random_handle(r, CV_HANDLE_PIPELINE);
#define GEN_ACCEL(f) a.f.id = random_handle(r, CV_HANDLE_ACCEL);
#define GEN_ANY(f) a.f.id = random_handle(r, (cv_handle_type)test_rng_below(r, CV_HANDLE_TYPE_COUNT));
/* Push constants and update data alike: up to the push limit, any length. */
#define GEN_BYTES(f) \
    uint8_t f##_buf[CV_MAX_PUSH_CONSTANTS]; \
    a.f##_size = test_rng_below(r, CV_MAX_PUSH_CONSTANTS + 1); \
    random_bytes(r, f##_buf, a.f##_size); \
    a.f = f##_buf;
#define GEN_STRING(f) \
    char f##_buf[CV_LABEL_MAX]; \
    random_label(r, f##_buf); \
    a.f = f##_buf;
#define GEN_BINDINGS(f) \
    cv_binding f##_buf[CV_MAX_BINDINGS]; \
    a.f##_count = random_bindings(r, f##_buf); \
    a.f = f##_buf;
#define GEN_FIELD(num, TYPE, f) GEN_##TYPE(f)

/* Field values that recording itself constrains (beyond sizes and handle tags). */
static void constrain_args(cv_command_type type, void *args) {
    if (type == CV_CMD_TRACE_RAYS)
        ((cv_trace_rays_args *)args)->flags &= CV_TRACE_FLAGS_ALL;
}

#define GEN_COMMAND(id, UPPER, lower, Camel, queues) \
    static cv_result gen_##lower(cv_command_list *list, test_rng *r) { \
        cv_##lower##_args a; \
        memset(&a, 0, sizeof(a)); \
        CV_FIELDS_##lower(GEN_FIELD) constrain_args(CV_CMD_##UPPER, &a); \
        return cv_cmd_##lower(list, random_queue(r, CV_CMD_##UPPER), &a); \
    }
CV_COMMAND_TABLE(GEN_COMMAND)
#undef GEN_COMMAND

typedef cv_result (*generator)(cv_command_list *list, test_rng *r);
static const generator generators[CV_CMD_TYPE_END] = {
#define GEN_ENTRY(id, UPPER, lower, Camel, queues) [CV_CMD_##UPPER] = gen_##lower,
    CV_COMMAND_TABLE(GEN_ENTRY)
#undef GEN_ENTRY
};

static const cv_command_type all_types[] = {
#define TYPE_ENTRY(id, UPPER, lower, Camel, queues) CV_CMD_##UPPER,
    CV_COMMAND_TABLE(TYPE_ENTRY)
#undef TYPE_ENTRY
};
#define TYPE_COUNT (sizeof(all_types) / sizeof(all_types[0]))

static cv_command_type random_type(test_rng *r) { return all_types[test_rng_below(r, TYPE_COUNT)]; }

static cv_result gen(cv_command_list *list, test_rng *r, cv_command_type type) { return generators[type](list, r); }

/* Commands valid inside a render pass besides draws. */
static cv_result gen_in_pass(cv_command_list *list, test_rng *r) {
    static const cv_command_type inside[] = { CV_CMD_DRAW, CV_CMD_DRAW_INDEXED, CV_CMD_BARRIER, CV_CMD_TIMESTAMP };
    return gen(list, r, inside[test_rng_below(r, sizeof(inside) / sizeof(inside[0]))]);
}

static cv_result gen_render_pass(cv_command_list *list, test_rng *r, cv_command_type must_have) {
    cv_result res = gen(list, r, CV_CMD_BEGIN_RENDER_PASS);
    if (res == CV_OK && (must_have == CV_CMD_DRAW || must_have == CV_CMD_DRAW_INDEXED))
        res = gen(list, r, must_have);
    for (uint32_t n = test_rng_below(r, 5); res == CV_OK && n > 0; n--)
        res = gen_in_pass(list, r);
    if (res == CV_OK && test_rng_below(r, 4) == 0) {
        res = gen(list, r, CV_CMD_BEGIN_MARKER);
        if (res == CV_OK)
            res = gen_in_pass(list, r);
        if (res == CV_OK)
            res = gen(list, r, CV_CMD_END_MARKER);
    }
    return res == CV_OK ? gen(list, r, CV_CMD_END_RENDER_PASS) : res;
}

static cv_result gen_block(cv_command_list *list, test_rng *r, cv_command_type type) {
    cv_result res;
    switch (type) {
    case CV_CMD_BEGIN_RENDER_PASS:
    case CV_CMD_END_RENDER_PASS:
    case CV_CMD_DRAW:
    case CV_CMD_DRAW_INDEXED: return gen_render_pass(list, r, type);
    case CV_CMD_BEGIN_MARKER:
    case CV_CMD_END_MARKER:
        res = gen(list, r, CV_CMD_BEGIN_MARKER);
        if (res == CV_OK && test_rng_below(r, 2))
            res = gen_block(list, r, random_type(r));
        return res == CV_OK ? gen(list, r, CV_CMD_END_MARKER) : res;
    default: return gen(list, r, type);
    }
}

cv_result random_list_record(cv_command_list *list, uint64_t seed, uint32_t blocks) {
    test_rng r = { seed };
    cv_command_list_begin(list);
    /* Recording errors are sticky: cv_command_list_end reports the first. */
    for (size_t t = 0; t < TYPE_COUNT; t++)
        gen_block(list, &r, all_types[t]);
    for (uint32_t i = 0; i < blocks; i++)
        gen_block(list, &r, random_type(&r));
    return cv_command_list_end(list);
}
