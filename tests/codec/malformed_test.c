/* Hostile and broken encodings: each is rejected with its own code and a
 * message naming what was wrong (and which command), and leaves the target
 * list exactly as it was. Inputs are built with protobuf-c's own packer where
 * they are valid protobuf, by hand where they are not. */
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "corvid.pb-c.h"
#include "corvid/command_codec.h"
#include "random_list.h"

static cv_command_list reference; /* what `target` holds before every decode */
static cv_command_list target;

static void expect(const uint8_t *data, size_t size, cv_result code, const char *needle, const char *what) {
    uint32_t version = target.version;
    cv_result r = cv_command_list_decode(data, size, &target);
    if (r != code || !strstr(cv_last_error(), needle))
        fprintf(stderr, "%s: got %s \"%s\", expected %s with \"%s\"\n", what, cv_result_name(r), cv_last_error(),
                cv_result_name(code), needle);
    CHECK_RESULT(r, code);
    CHECK(strstr(cv_last_error(), needle) != NULL);
    if (code != CV_OK) {
        CHECK(lists_equal(&reference, &target, what));
        CHECK_EQ_INT(target.version, version);
    }
}

static uint8_t *pack_list(Corvid__Command **commands, size_t n, size_t *size) {
    Corvid__CommandList list = CORVID__COMMAND_LIST__INIT;
    list.n_commands = n;
    list.commands = commands;
    *size = corvid__command_list__get_packed_size(&list);
    uint8_t *bytes = malloc(*size + 1);
    corvid__command_list__pack(&list, bytes);
    return bytes;
}

/* Packs the commands and expects the decode result. */
static void expect_commands(Corvid__Command **commands, size_t n, cv_result code, const char *needle,
                            const char *what) {
    size_t size;
    uint8_t *bytes = pack_list(commands, n, &size);
    expect(bytes, size, code, needle, what);
    free(bytes);
}

static void expect_one(Corvid__Command *c, cv_result code, const char *needle, const char *what) {
    expect_commands(&c, 1, code, needle, what);
}

static const uint64_t BUFFER = 0x1000000100000001ull; /* buffer, generation 1, slot 1 */
static const uint64_t TEXTURE = 0x2000000100000002ull;
static const uint64_t PIPELINE = 0x4000000100000003ull;

static void test_not_protobuf(void) {
    uint8_t garbage[32];
    memset(garbage, 0xff, sizeof(garbage));
    expect(garbage, sizeof(garbage), CV_ERROR_MALFORMED, "overlong field key", "garbage");

    static const uint8_t field_zero[] = { 0x02, 0x00 };
    expect(field_zero, sizeof(field_zero), CV_ERROR_MALFORMED, "field number 0", "field 0");

    static const uint8_t commands_as_varint[] = { 0x08, 0x01 };
    expect(commands_as_varint, sizeof(commands_as_varint), CV_ERROR_MALFORMED, "wire type 0", "commands varint");

    static const uint8_t group[] = { 0x13, 0x14 };
    expect(group, sizeof(group), CV_ERROR_MALFORMED, "invalid wire type 3", "group");

    static const uint8_t unknown_past_end[] = { 0x42, 0x09, 0x00 };
    expect(unknown_past_end, sizeof(unknown_past_end), CV_ERROR_MALFORMED, "runs past the end", "field 8 length");

    /* Command { dispatch { groups_x as a length-delimited field } } */
    static const uint8_t wrong_inner_wire[] = { 0x0a, 0x05, 0x0a, 0x03, 0x22, 0x01, 0x00 };
    expect(wrong_inner_wire, sizeof(wrong_inner_wire), CV_ERROR_MALFORMED, "command 0", "inner wire type");

    expect(NULL, 4, CV_ERROR_INVALID_ARGUMENT, "NULL", "NULL data");
    CHECK_RESULT(cv_command_list_decode(garbage, 0, NULL), CV_ERROR_INVALID_ARGUMENT);
}

static void test_truncated(void) {
    uint8_t *bytes;
    size_t size;
    CHECK_OK(cv_command_list_encode(&reference, &bytes, &size));
    expect(bytes, size - 1, CV_ERROR_MALFORMED, "runs past the end", "last byte cut");

    /* A Command cut short inside, re-framed with a consistent outer length:
     * the outer framing is fine, the Command itself is not. */
    Corvid__DispatchCmd d = CORVID__DISPATCH_CMD__INIT;
    d.pipeline = PIPELINE;
    d.groups_x = 1000;
    Corvid__Command c = CORVID__COMMAND__INIT;
    c.queue = CV_QUEUE_COMPUTE;
    c.cmd_case = CORVID__COMMAND__CMD_DISPATCH;
    c.dispatch = &d;
    uint8_t inner[64];
    size_t n = corvid__command__pack(&c, inner);
    uint8_t framed[66] = { 0x0a, (uint8_t)(n - 1) };
    memcpy(framed + 2, inner, n - 1);
    expect(framed, n + 1, CV_ERROR_MALFORMED, "not a valid Command", "inner truncation");
    free(bytes);
}

static void test_no_or_unknown_command(void) {
    Corvid__Command empty = CORVID__COMMAND__INIT;
    expect_one(&empty, CV_ERROR_MALFORMED, "command 0 carries no command", "empty Command");

    /* Command { field 50: {} }: a command from a newer table. */
    static const uint8_t unknown[] = { 0x0a, 0x03, 0x92, 0x03, 0x00 };
    expect(unknown, sizeof(unknown), CV_ERROR_MALFORMED, "carries no command", "unknown oneof member");
}

static void test_queue_out_of_range(void) {
    Corvid__BarrierCmd b = CORVID__BARRIER_CMD__INIT;
    Corvid__Command c = CORVID__COMMAND__INIT;
    c.cmd_case = CORVID__COMMAND__CMD_BARRIER;
    c.barrier = &b;
    c.queue = CV_QUEUE_TYPE_COUNT;
    expect_one(&c, CV_ERROR_MALFORMED, "queue 3 is not a queue type", "queue 3");
    c.queue = UINT32_MAX;
    expect_one(&c, CV_ERROR_MALFORMED, "queue 4294967295", "queue max");
}

static void test_handle_tags(void) {
    Corvid__DispatchCmd d = CORVID__DISPATCH_CMD__INIT;
    d.pipeline = BUFFER;
    Corvid__Command c = CORVID__COMMAND__INIT;
    c.queue = CV_QUEUE_COMPUTE;
    c.cmd_case = CORVID__COMMAND__CMD_DISPATCH;
    c.dispatch = &d;
    expect_one(&c, CV_ERROR_WRONG_HANDLE_TYPE, "'pipeline' wants a pipeline handle", "buffer as pipeline");

    Corvid__CopyBufferCmd cb = CORVID__COPY_BUFFER_CMD__INIT;
    cb.src = BUFFER;
    cb.dst = TEXTURE;
    Corvid__Command c2 = CORVID__COMMAND__INIT;
    c2.queue = CV_QUEUE_COPY;
    c2.cmd_case = CORVID__COMMAND__CMD_COPY_BUFFER;
    c2.copy_buffer = &cb;
    expect_one(&c2, CV_ERROR_WRONG_HANDLE_TYPE, "'dst' wants a buffer handle", "texture as buffer");

    Corvid__BarrierCmd b = CORVID__BARRIER_CMD__INIT;
    b.resource = (0xfull << 60) | 1;
    Corvid__Command c3 = CORVID__COMMAND__INIT;
    c3.cmd_case = CORVID__COMMAND__CMD_BARRIER;
    c3.barrier = &b;
    expect_one(&c3, CV_ERROR_INVALID_HANDLE, "no valid handle type tag", "unknown tag in ANY field");

    Corvid__Binding null_binding = CORVID__BINDING__INIT, *nb = &null_binding;
    d.pipeline = PIPELINE;
    d.n_bindings = 1;
    d.bindings = &nb;
    expect_one(&c, CV_ERROR_INVALID_HANDLE, "binding 0 has a null resource", "null binding");
    null_binding.resource = PIPELINE;
    expect_one(&c, CV_ERROR_WRONG_HANDLE_TYPE, "cannot be bound", "pipeline bound");
}

static void test_sizes(void) {
    static uint8_t big[CV_MAX_UPDATE_BYTES + 4];
    Corvid__UpdateBufferCmd u = CORVID__UPDATE_BUFFER_CMD__INIT;
    u.buffer = BUFFER;
    u.data.data = big;
    u.data.len = CV_MAX_UPDATE_BYTES + 4;
    Corvid__Command c = CORVID__COMMAND__INIT;
    c.queue = CV_QUEUE_COPY;
    c.cmd_case = CORVID__COMMAND__CMD_UPDATE_BUFFER;
    c.update_buffer = &u;
    expect_one(&c, CV_ERROR_LIMIT_EXCEEDED, "'data' has 65540 bytes, limit 65536", "update too big");

    char label[CV_LABEL_MAX + 1];
    memset(label, 'x', CV_LABEL_MAX);
    label[CV_LABEL_MAX] = '\0';
    Corvid__TimestampCmd t = CORVID__TIMESTAMP_CMD__INIT;
    t.label = label;
    Corvid__Command c2 = CORVID__COMMAND__INIT;
    c2.cmd_case = CORVID__COMMAND__CMD_TIMESTAMP;
    c2.timestamp = &t;
    expect_one(&c2, CV_ERROR_LIMIT_EXCEEDED, "'label' is 48 bytes long, limit 47", "label too long");

    Corvid__Binding binding = CORVID__BINDING__INIT, *ptrs[CV_MAX_BINDINGS + 1];
    binding.resource = BUFFER;
    for (int i = 0; i <= CV_MAX_BINDINGS; i++)
        ptrs[i] = &binding;
    Corvid__DispatchCmd d = CORVID__DISPATCH_CMD__INIT;
    d.pipeline = PIPELINE;
    d.n_bindings = CV_MAX_BINDINGS + 1;
    d.bindings = ptrs;
    Corvid__Command c3 = CORVID__COMMAND__INIT;
    c3.queue = CV_QUEUE_COMPUTE;
    c3.cmd_case = CORVID__COMMAND__CMD_DISPATCH;
    c3.dispatch = &d;
    expect_one(&c3, CV_ERROR_LIMIT_EXCEEDED, "'bindings' has 17 bindings, limit 16", "17 bindings");

    d.n_bindings = 1;
    d.push.data = big;
    d.push.len = CV_MAX_PUSH_CONSTANTS + 4;
    expect_one(&c3, CV_ERROR_LIMIT_EXCEEDED, "132 bytes of push constants, limit 128", "push too big");

    uint8_t *huge = calloc(CV_MAX_ENCODED_LIST + 1u, 1);
    expect(huge, CV_MAX_ENCODED_LIST + 1u, CV_ERROR_LIMIT_EXCEEDED, "67108865 bytes, limit 67108864",
           "input too big");
    free(huge);
}

/* 100,000 empty Bindings take 200 KB on the wire and would unpack to 6.4 MB:
 * the unpack arena refuses long before. */
static void test_unpack_blowup(void) {
    enum { N = 100000 };
    size_t inner = (size_t)N * 2; /* each: key 0x12, length 0 */
    uint8_t *bytes = malloc(inner + 16);
    size_t p = 0;
    uint8_t head[16];
    size_t h = 0;
    head[h++] = 0x0a;               /* CommandList.commands */
    size_t cmd_len = 1 + 3 + inner; /* dispatch key + 3-byte length + body */
    head[h++] = (uint8_t)(cmd_len | 0x80);
    head[h++] = (uint8_t)((cmd_len >> 7) | 0x80);
    head[h++] = (uint8_t)(cmd_len >> 14);
    head[h++] = 0x0a; /* Command.dispatch */
    head[h++] = (uint8_t)(inner | 0x80);
    head[h++] = (uint8_t)((inner >> 7) | 0x80);
    head[h++] = (uint8_t)(inner >> 14);
    memcpy(bytes, head, h);
    p = h;
    for (int i = 0; i < N; i++) {
        bytes[p++] = 0x12;
        bytes[p++] = 0x00;
    }
    expect(bytes, p, CV_ERROR_MALFORMED, "unpack to more than 465544 bytes", "binding blow-up");
    free(bytes);
}

static void test_structure(void) {
    Corvid__BarrierCmd b = CORVID__BARRIER_CMD__INIT;
    Corvid__Command barrier = CORVID__COMMAND__INIT;
    barrier.cmd_case = CORVID__COMMAND__CMD_BARRIER;
    barrier.barrier = &b;
    Corvid__DrawCmd dr = CORVID__DRAW_CMD__INIT;
    dr.pipeline = PIPELINE;
    Corvid__Command draw = CORVID__COMMAND__INIT;
    draw.cmd_case = CORVID__COMMAND__CMD_DRAW;
    draw.draw = &dr;
    Corvid__BeginRenderPassCmd bp = CORVID__BEGIN_RENDER_PASS_CMD__INIT;
    bp.color0 = TEXTURE;
    Corvid__Command begin = CORVID__COMMAND__INIT;
    begin.cmd_case = CORVID__COMMAND__CMD_BEGIN_RENDER_PASS;
    begin.begin_render_pass = &bp;
    Corvid__EndMarkerCmd em = CORVID__END_MARKER_CMD__INIT;
    Corvid__Command end_marker = CORVID__COMMAND__INIT;
    end_marker.cmd_case = CORVID__COMMAND__CMD_END_MARKER;
    end_marker.end_marker = &em;

    Corvid__Command *outside[] = { &barrier, &draw };
    expect_commands(outside, 2, CV_ERROR_BAD_STATE, "command 1: draw outside a render pass", "draw outside pass");

    Corvid__Command *open_pass[] = { &begin, &draw };
    expect_commands(open_pass, 2, CV_ERROR_BAD_STATE, "ends inside a render pass", "open pass");

    Corvid__Command *nested[] = { &begin, &barrier, &begin };
    expect_commands(nested, 3, CV_ERROR_BAD_STATE, "command 2: begin_render_pass inside", "nested pass");

    Corvid__Command *lone_end[] = { &barrier, &barrier, &end_marker };
    expect_commands(lone_end, 3, CV_ERROR_BAD_STATE, "command 2: end_marker without begin_marker", "lone end");

    begin.queue = CV_QUEUE_COMPUTE;
    Corvid__Command *wrong_queue[] = { &barrier, &begin };
    expect_commands(wrong_queue, 2, CV_ERROR_QUEUE_MISMATCH,
                    "command 1: begin_render_pass is not allowed on the compute", "pass on compute");
}

/* More than CV_MAX_COMMANDS barriers, each 4 bytes on the wire. */
static void test_too_many_commands(void) {
    size_t n = (size_t)CV_MAX_COMMANDS + 1;
    uint8_t *bytes = malloc(n * 4);
    for (size_t i = 0; i < n; i++)
        memcpy(bytes + 4 * i, (const uint8_t[]){ 0x0a, 0x02, 0x72, 0x00 }, 4);
    expect(bytes, n * 4, CV_ERROR_LIMIT_EXCEEDED, "command 1048576: list would exceed", "too many commands");
    free(bytes);
}

/* Fields this version does not know are skipped, at both levels. */
static void test_unknown_fields_are_skipped(void) {
    uint8_t *bytes;
    size_t size;
    CHECK_OK(cv_command_list_encode(&reference, &bytes, &size));
    static const uint8_t extra[] = { 0x38, 0x05,                              /* field 7 varint */
                                     0x42, 0x02, 0xaa, 0xbb,                  /* field 8 bytes */
                                     0x4d, 1,    2,    3,    4,               /* field 9 fixed32 */
                                     0x51, 1,    2,    3,    4, 5, 6, 7, 8 }; /* field 10 fixed64 */
    uint8_t *longer = malloc(size + sizeof(extra));
    memcpy(longer, extra, sizeof(extra));
    memcpy(longer + sizeof(extra), bytes, size);
    expect(longer, size + sizeof(extra), CV_OK, "", "unknown list fields");
    CHECK(lists_equal(&reference, &target, "unknown list fields"));

    /* Command { barrier {} , field 200: 7 } */
    static const uint8_t inner_extra[] = { 0x0a, 0x05, 0x72, 0x00, 0xc0, 0x0c, 0x07 };
    expect(inner_extra, sizeof(inner_extra), CV_OK, "", "unknown command field");
    CHECK_EQ_INT(target.count, 1);
    CHECK_EQ_INT(target.commands[0].type, CV_CMD_BARRIER);
    free(longer);
    free(bytes);
}

int main(void) {
    cv_command_list_init(&reference);
    cv_command_list_init(&target);
    CHECK_OK(random_list_record(&reference, 2024, 50));
    uint8_t *bytes;
    size_t size;
    CHECK_OK(cv_command_list_encode(&reference, &bytes, &size));
    CHECK_OK(cv_command_list_decode(bytes, size, &target));
    free(bytes);

    test_not_protobuf();
    test_truncated();
    test_no_or_unknown_command();
    test_queue_out_of_range();
    test_handle_tags();
    test_sizes();
    test_unpack_blowup();
    test_structure();
    test_too_many_commands();
    test_unknown_fields_are_skipped();

    cv_command_list_finish(&reference);
    cv_command_list_finish(&target);
    return check_report("codec_malformed");
}
