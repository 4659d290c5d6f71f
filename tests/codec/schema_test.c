/* proto/corvid.proto must declare exactly what CV_COMMAND_TABLE says.
 *
 * Checked on protobuf-c's run-time descriptors, in both directions: every
 * table row is a member of Command.cmd (named <lower>, numbered <id>, of
 * message type <Camel>Cmd) whose fields are exactly the row's CV_FIELDS_<lower>
 * (name, number, wire type, repeatedness), and Command, every command message,
 * Binding and CommandList have nothing the table (or the codec) lacks. */
#include <stddef.h>
#include <string.h>

#include "check.h"
#include "corvid.pb-c.h"
#include "corvid/command_list.h"

typedef struct field_spec {
    uint32_t number;
    const char *name;
    ProtobufCType type;
    ProtobufCLabel label;
    const ProtobufCMessageDescriptor *message; /* for message-typed fields */
} field_spec;

#define SPEC_U32 PROTOBUF_C_TYPE_UINT32, PROTOBUF_C_LABEL_NONE, NULL
#define SPEC_U64 PROTOBUF_C_TYPE_UINT64, PROTOBUF_C_LABEL_NONE, NULL
#define SPEC_I32 PROTOBUF_C_TYPE_SINT32, PROTOBUF_C_LABEL_NONE, NULL
#define SPEC_F32 PROTOBUF_C_TYPE_FLOAT, PROTOBUF_C_LABEL_NONE, NULL
#define SPEC_BUFFER SPEC_U64
#define SPEC_TEXTURE SPEC_U64
#define SPEC_PIPELINE SPEC_U64
#define SPEC_ACCEL SPEC_U64
#define SPEC_ANY SPEC_U64
#define SPEC_BYTES PROTOBUF_C_TYPE_BYTES, PROTOBUF_C_LABEL_NONE, NULL
#define SPEC_STRING PROTOBUF_C_TYPE_STRING, PROTOBUF_C_LABEL_NONE, NULL
#define SPEC_BINDINGS PROTOBUF_C_TYPE_MESSAGE, PROTOBUF_C_LABEL_REPEATED, &corvid__binding__descriptor
#define SPEC_FIELD(num, TYPE, f) { num, #f, SPEC_##TYPE },

/* One array per command, ended by a zero entry (so field-less commands work). */
#define SPEC_ARRAY(id, UPPER, lower, Camel, queues) \
    static const field_spec fields_##lower[] = { CV_FIELDS_##lower(SPEC_FIELD){ 0 } };
CV_COMMAND_TABLE(SPEC_ARRAY)
#undef SPEC_ARRAY

typedef struct command_spec {
    uint32_t id;
    const char *lower, *message;
    const field_spec *fields;
} command_spec;

static const command_spec commands[] = {
#define SPEC_ROW(id, UPPER, lower, Camel, queues) { id, #lower, #Camel "Cmd", fields_##lower },
    CV_COMMAND_TABLE(SPEC_ROW)
#undef SPEC_ROW
};
#define COMMAND_COUNT (sizeof(commands) / sizeof(commands[0]))

/* cv_binding's fields, which Binding must mirror. */
static const field_spec binding_fields[] = {
    { 1, "resource", SPEC_U64 },
    { 2, "sampler", SPEC_U64 },
    { 3, "offset", SPEC_U64 },
    { 4, "range", SPEC_U64 },
    { 0 },
};
_Static_assert(offsetof(cv_binding, resource) == 0 && offsetof(cv_binding, sampler) == 8 &&
                   offsetof(cv_binding, offset) == 16 && offsetof(cv_binding, range) == 24 &&
                   sizeof(cv_binding) == 32,
               "cv_binding has exactly resource, sampler, offset, range: update binding_fields and Binding");

static const field_spec *find_spec(const field_spec *specs, const char *name) {
    for (; specs->name; specs++)
        if (strcmp(specs->name, name) == 0)
            return specs;
    return NULL;
}

/* Both directions for one message: each spec is a field with that number,
 * type and label; each field of the message is a spec. */
static void check_message_fields(const ProtobufCMessageDescriptor *desc, const field_spec *specs) {
    unsigned expected = 0;
    for (const field_spec *s = specs; s->name; s++, expected++) {
        const ProtobufCFieldDescriptor *f = protobuf_c_message_descriptor_get_field_by_name(desc, s->name);
        if (!f) {
            fprintf(stderr, "%s has no field '%s' (field %u in the table)\n", desc->short_name, s->name, s->number);
            CHECK(f != NULL);
            continue;
        }
        if (f->id != s->number || f->type != s->type || f->label != s->label)
            fprintf(stderr, "%s.%s: number %u type %d label %d, table wants %u %d %d\n", desc->short_name, s->name,
                    f->id, (int)f->type, (int)f->label, s->number, (int)s->type, (int)s->label);
        CHECK_EQ_INT(f->id, s->number);
        CHECK_EQ_INT(f->type, s->type);
        CHECK_EQ_INT(f->label, s->label);
        CHECK(f->descriptor == (const void *)s->message);
        CHECK_EQ_INT(f->flags & PROTOBUF_C_FIELD_FLAG_ONEOF, 0);
    }
    for (unsigned i = 0; i < desc->n_fields; i++) {
        if (!find_spec(specs, desc->fields[i].name))
            fprintf(stderr, "%s.%s (field %u) is not in the table\n", desc->short_name, desc->fields[i].name,
                    desc->fields[i].id);
        CHECK(find_spec(specs, desc->fields[i].name) != NULL);
    }
    CHECK_EQ_INT(desc->n_fields, expected);
}

static const command_spec *find_command(const char *name) {
    for (size_t i = 0; i < COMMAND_COUNT; i++)
        if (strcmp(commands[i].lower, name) == 0)
            return &commands[i];
    return NULL;
}

static void test_commands_match_table(void) {
    const ProtobufCMessageDescriptor *cmd = &corvid__command__descriptor;
    unsigned oneof_offset = 0;
    for (size_t i = 0; i < COMMAND_COUNT; i++) {
        const command_spec *c = &commands[i];
        const ProtobufCFieldDescriptor *f = protobuf_c_message_descriptor_get_field_by_name(cmd, c->lower);
        if (!f) {
            fprintf(stderr, "Command has no member '%s' (id %u in the table)\n", c->lower, c->id);
            CHECK(f != NULL);
            continue;
        }
        CHECK_EQ_INT(f->id, c->id);
        CHECK_EQ_INT(f->type, PROTOBUF_C_TYPE_MESSAGE);
        CHECK(f->flags & PROTOBUF_C_FIELD_FLAG_ONEOF);
        /* All members share one case field: they belong to the one oneof. */
        if (oneof_offset == 0)
            oneof_offset = f->quantifier_offset;
        CHECK_EQ_INT(f->quantifier_offset, oneof_offset);
        const ProtobufCMessageDescriptor *m = f->descriptor;
        CHECK(m != NULL);
        if (!m)
            continue;
        if (strcmp(m->short_name, c->message) != 0)
            fprintf(stderr, "Command.%s has type %s, table wants %s\n", c->lower, m->short_name, c->message);
        CHECK(strcmp(m->short_name, c->message) == 0);
        check_message_fields(m, c->fields);
    }
    CHECK_EQ_INT(oneof_offset, offsetof(Corvid__Command, cmd_case));

    /* Reverse: Command is the oneof members of the table plus queue. */
    for (unsigned i = 0; i < cmd->n_fields; i++) {
        const ProtobufCFieldDescriptor *f = &cmd->fields[i];
        if (strcmp(f->name, "queue") == 0) {
            CHECK_EQ_INT(f->type, PROTOBUF_C_TYPE_UINT32);
            CHECK_EQ_INT(f->label, PROTOBUF_C_LABEL_NONE);
            CHECK_EQ_INT(f->flags & PROTOBUF_C_FIELD_FLAG_ONEOF, 0);
            continue;
        }
        const command_spec *c = find_command(f->name);
        if (!c)
            fprintf(stderr, "Command.%s (field %u) is not in CV_COMMAND_TABLE\n", f->name, f->id);
        CHECK(c != NULL);
        CHECK(f->flags & PROTOBUF_C_FIELD_FLAG_ONEOF);
    }
    CHECK_EQ_INT(cmd->n_fields, COMMAND_COUNT + 1);
}

static void test_binding_matches_cv_binding(void) {
    check_message_fields(&corvid__binding__descriptor, binding_fields);
    CHECK(strcmp(corvid__binding__descriptor.short_name, "Binding") == 0);
}

/* The codec frames CommandList by hand: it must be exactly field 1, repeated Command. */
static void test_command_list_shape(void) {
    const ProtobufCMessageDescriptor *d = &corvid__command_list__descriptor;
    CHECK_EQ_INT(d->n_fields, 1);
    const ProtobufCFieldDescriptor *f = protobuf_c_message_descriptor_get_field_by_name(d, "commands");
    CHECK(f != NULL);
    if (!f)
        return;
    CHECK_EQ_INT(f->id, 1);
    CHECK_EQ_INT(f->label, PROTOBUF_C_LABEL_REPEATED);
    CHECK_EQ_INT(f->type, PROTOBUF_C_TYPE_MESSAGE);
    CHECK(f->descriptor == (const void *)&corvid__command__descriptor);
}

/* The checker itself: a spec list that differs from a message must fail. */
static void test_checker_detects_drift(void) {
    int before = check_failures, count = check_count;
    static const field_spec renamed[] = { { 1, "resource", SPEC_U64 },
                                          { 2, "sampler", SPEC_U64 },
                                          { 3, "offset", SPEC_U64 },
                                          { 4, "size", SPEC_U64 },
                                          { 0 } };
    static const field_spec missing[] = {
        { 1, "resource", SPEC_U64 }, { 2, "sampler", SPEC_U64 }, { 3, "offset", SPEC_U64 }, { 0 }
    };
    static const field_spec renumbered[] = { { 1, "resource", SPEC_U64 },
                                             { 2, "sampler", SPEC_U64 },
                                             { 3, "offset", SPEC_U64 },
                                             { 5, "range", SPEC_U64 },
                                             { 0 } };
    static const field_spec retyped[] = { { 1, "resource", SPEC_U64 },
                                          { 2, "sampler", SPEC_U64 },
                                          { 3, "offset", SPEC_U64 },
                                          { 4, "range", SPEC_U32 },
                                          { 0 } };
    const field_spec *drifted[] = { renamed, missing, renumbered, retyped };
    int detected = 0;
    fprintf(stderr, "(expected drift reports follow)\n");
    for (size_t i = 0; i < sizeof(drifted) / sizeof(drifted[0]); i++) {
        int f0 = check_failures;
        check_message_fields(&corvid__binding__descriptor, drifted[i]);
        detected += check_failures > f0;
    }
    check_failures = before;
    check_count = count;
    CHECK_EQ_INT(detected, 4);
}

int main(void) {
    test_commands_match_table();
    test_binding_matches_cv_binding();
    test_command_list_shape();
    test_checker_detects_drift();
    return check_report("codec_schema");
}
