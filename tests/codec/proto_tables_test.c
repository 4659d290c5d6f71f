/* proto/node.proto must state what a client needs beyond the messages, equal
 * to the C tables both sides are built from, so a client can be written from
 * proto/ alone (the way schema_test.c holds corvid.proto to CV_COMMAND_TABLE):
 *  - service corvid.Node and grpc.health.v1.Health give exactly the method
 *    paths the node serves (node_protocol.h);
 *  - enum Result is CV_RESULT_TABLE, Format is CV_FORMAT_TABLE, Codec is cv_codec, HandleType is
 *    cv_handle_type, BufferUsage / TextureUsage are the usage bits, Filter and
 *    AddressMode the sampler's, ProtocolVersion and Limit the protocol's
 *    constants; corvid.proto's QueueType and TraceFlag are cv_queue_type and
 *    the trace flags;
 *  - enum Pipeline names every pipeline of shaders/registry.def, and its
 *    comment states the pipeline's kind, local size, push bytes and bindings.
 * Checked on protobuf-c's run-time descriptors in both directions (nothing
 * missing, nothing extra); the pipeline comments on the text of node.proto. */
#include <ctype.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "corvid/handle.h"
#include "corvid/node_protocol.h"
#include "corvid/pipeline_registry.h"
#include "corvid/result.h"
#include "corvid.pb-c.h"
#include "health.pb-c.h"
#include "node.pb-c.h"

typedef struct named_value {
    const char *name;
    int value;
} named_value;

#define COUNT(a) (sizeof(a) / sizeof((a)[0]))

/* Every entry of `want` is a value of `d` (same name, same number) and every value of `d` is an entry of
 * `want` or `zero` (the proto3 zero value a C table may lack; NULL if the table has its own). */
static void check_enum(const ProtobufCEnumDescriptor *d, const named_value *want, size_t n, const char *zero) {
    for (size_t i = 0; i < n; i++) {
        const ProtobufCEnumValue *v = protobuf_c_enum_descriptor_get_value_by_name(d, want[i].name);
        if (!v)
            fprintf(stderr, "enum %s has no %s (%d in the C table)\n", d->name, want[i].name, want[i].value);
        else if (v->value != want[i].value)
            fprintf(stderr, "enum %s: %s is %d, the C table says %d\n", d->name, want[i].name, v->value,
                    want[i].value);
        CHECK(v != NULL && v->value == want[i].value);
    }
    for (unsigned i = 0; i < d->n_values; i++) {
        const char *name = d->values[i].name;
        bool known = zero && strcmp(name, zero) == 0 && d->values[i].value == 0;
        for (size_t k = 0; !known && k < n; k++)
            known = strcmp(want[k].name, name) == 0;
        if (!known)
            fprintf(stderr, "enum %s: %s (%d) is not in the C table\n", d->name, name, d->values[i].value);
        CHECK(known);
    }
    CHECK_EQ_INT(d->n_values, n + (zero ? 1 : 0));
}

static void test_service_paths(void) {
    const ProtobufCServiceDescriptor *node = &corvid__node__descriptor;
    CHECK(strcmp(node->name, "corvid.Node") == 0);
    CHECK_EQ_INT(node->n_methods, 3);
    static const struct {
        const char *path;
        const ProtobufCMessageDescriptor *input, *output;
    } methods[] = {
        { CV_NODE_METHOD_SESSION, &corvid__client_message__descriptor, &corvid__node_message__descriptor },
        { CV_NODE_METHOD_INFO, &corvid__info_request__descriptor, &corvid__node_info__descriptor },
        { CV_NODE_METHOD_PEER_PIECE, &corvid__peer_piece__descriptor, &corvid__peer_piece_ack__descriptor },
    };
    for (size_t i = 0; i < COUNT(methods); i++) {
        bool found = false;
        for (unsigned m = 0; m < node->n_methods; m++) {
            char path[256];
            snprintf(path, sizeof(path), "/%s/%s", node->name, node->methods[m].name);
            if (strcmp(path, methods[i].path) != 0)
                continue;
            found = true;
            CHECK(node->methods[m].input == methods[i].input);
            CHECK(node->methods[m].output == methods[i].output);
        }
        if (!found)
            fprintf(stderr, "service %s has no method for %s\n", node->name, methods[i].path);
        CHECK(found);
    }
    const ProtobufCServiceDescriptor *health = &grpc__health__v1__health__descriptor;
    char check[256], watch[256];
    const ProtobufCMethodDescriptor *m = protobuf_c_service_descriptor_get_method_by_name(health, "Check");
    const ProtobufCMethodDescriptor *w = protobuf_c_service_descriptor_get_method_by_name(health, "Watch");
    CHECK(m != NULL && w != NULL);
    snprintf(check, sizeof(check), "/%s/%s", health->name, m ? m->name : "");
    snprintf(watch, sizeof(watch), "/%s/%s", health->name, w ? w->name : "");
    CHECK(strcmp(check, CV_HEALTH_METHOD_CHECK) == 0);
    CHECK(strcmp(watch, CV_HEALTH_METHOD_WATCH) == 0);
}

static void test_results(void) {
    static const named_value results[] = {
#define RESULT_ROW(name, value, text) { #name, value },
        CV_RESULT_TABLE(RESULT_ROW)
#undef RESULT_ROW
    };
    check_enum(&corvid__result__descriptor, results, COUNT(results), NULL);
}

static void test_formats_and_sampler(void) {
    static const named_value formats[] = {
#define FORMAT_ROW(name, bytes, depth, text) { "CV_FORMAT_" #name, CV_FORMAT_##name },
        CV_FORMAT_TABLE(FORMAT_ROW)
#undef FORMAT_ROW
    };
    check_enum(&corvid__format__descriptor, formats, COUNT(formats), NULL);
    static const named_value filters[] = { { "CV_FILTER_LINEAR", CV_FILTER_LINEAR },
                                           { "CV_FILTER_NEAREST", CV_FILTER_NEAREST } };
    check_enum(&corvid__filter__descriptor, filters, COUNT(filters), NULL);
    static const named_value addresses[] = { { "CV_ADDRESS_CLAMP", CV_ADDRESS_CLAMP },
                                             { "CV_ADDRESS_REPEAT", CV_ADDRESS_REPEAT } };
    check_enum(&corvid__address_mode__descriptor, addresses, COUNT(addresses), NULL);
    static const named_value queues[] = { { "CV_QUEUE_GRAPHICS", CV_QUEUE_GRAPHICS },
                                          { "CV_QUEUE_COMPUTE", CV_QUEUE_COMPUTE },
                                          { "CV_QUEUE_COPY", CV_QUEUE_COPY } };
    _Static_assert(CV_QUEUE_TYPE_COUNT == 3, "a new queue type: add it here and to QueueType in corvid.proto");
    check_enum(&corvid__queue_type__descriptor, queues, COUNT(queues), NULL);
    static const named_value codecs[] = { { "CV_CODEC_RAW", CV_CODEC_RAW },
                                          { "CV_CODEC_JPEG", CV_CODEC_JPEG },
                                          { "CV_CODEC_H264", CV_CODEC_H264 },
                                          { "CV_CODEC_PNG", CV_CODEC_PNG },
                                          { "CV_CODEC_ZSTD", CV_CODEC_ZSTD } };
    _Static_assert(CV_CODEC_COUNT == 5, "a new codec: add it here and to Codec in node.proto");
    check_enum(&corvid__codec__descriptor, codecs, COUNT(codecs), NULL);
}

/* The bits listed must be all of the C enum's: their union is its _ALL mask. */
static void check_bits(const ProtobufCEnumDescriptor *d, const named_value *bits, size_t n, const char *zero,
                       unsigned all) {
    check_enum(d, bits, n, zero);
    unsigned mask = 0;
    for (size_t i = 0; i < n; i++)
        mask |= (unsigned)bits[i].value;
    CHECK_EQ_INT(mask, all);
}

static void test_usage_bits_and_handles(void) {
    static const named_value buffer[] = {
        { "CV_BUFFER_USAGE_STORAGE", CV_BUFFER_USAGE_STORAGE },
        { "CV_BUFFER_USAGE_UNIFORM", CV_BUFFER_USAGE_UNIFORM },
        { "CV_BUFFER_USAGE_INDEX", CV_BUFFER_USAGE_INDEX },
        { "CV_BUFFER_USAGE_INDIRECT", CV_BUFFER_USAGE_INDIRECT },
    };
    check_bits(&corvid__buffer_usage__descriptor, buffer, COUNT(buffer), "BUFFER_USAGE_DEFAULT", CV_BUFFER_USAGE_ALL);
    static const named_value texture[] = {
        { "CV_TEXTURE_USAGE_SAMPLED", CV_TEXTURE_USAGE_SAMPLED },
        { "CV_TEXTURE_USAGE_STORAGE", CV_TEXTURE_USAGE_STORAGE },
        { "CV_TEXTURE_USAGE_COLOR_TARGET", CV_TEXTURE_USAGE_COLOR_TARGET },
        { "CV_TEXTURE_USAGE_DEPTH_TARGET", CV_TEXTURE_USAGE_DEPTH_TARGET },
        { "CV_TEXTURE_USAGE_SHARED", CV_TEXTURE_USAGE_SHARED },
    };
    check_bits(&corvid__texture_usage__descriptor, texture, COUNT(texture), "TEXTURE_USAGE_DEFAULT",
               CV_TEXTURE_USAGE_ALL);
    static const named_value handles[] = {
        { "CV_HANDLE_NONE", CV_HANDLE_NONE },         { "CV_HANDLE_BUFFER", CV_HANDLE_BUFFER },
        { "CV_HANDLE_TEXTURE", CV_HANDLE_TEXTURE },   { "CV_HANDLE_SAMPLER", CV_HANDLE_SAMPLER },
        { "CV_HANDLE_PIPELINE", CV_HANDLE_PIPELINE }, { "CV_HANDLE_CMDLIST", CV_HANDLE_CMDLIST },
        { "CV_HANDLE_ACCEL", CV_HANDLE_ACCEL },
    };
    _Static_assert(CV_HANDLE_TYPE_COUNT == 7, "a new handle type: add it here and to HandleType in node.proto");
    check_enum(&corvid__handle_type__descriptor, handles, COUNT(handles), NULL);
    static const named_value trace[] = { { "CV_TRACE_ANY_HIT", CV_TRACE_ANY_HIT },
                                         { "CV_TRACE_CULL_BACK_FACES", CV_TRACE_CULL_BACK_FACES } };
    check_bits(&corvid__trace_flag__descriptor, trace, COUNT(trace), "TRACE_FLAGS_NONE", CV_TRACE_FLAGS_ALL);
    /* The layout the proto's comment states. */
    CHECK_EQ_INT(CV_HANDLE_INDEX_BITS, 24);
    CHECK_EQ_INT(CV_HANDLE_GENERATION_BITS, 24);
    CHECK_EQ_INT(CV_HANDLE_TAG_BITS, 12);
    CHECK(cv_handle_type_of(0x3000000000000000ull) == CV_HANDLE_SAMPLER);
}

static void test_protocol_constants(void) {
    static const named_value version[] = { { "PROTOCOL_VERSION_CURRENT", CV_NODE_PROTOCOL_VERSION } };
    check_enum(&corvid__protocol_version__descriptor, version, COUNT(version), "PROTOCOL_VERSION_UNSPECIFIED");
    static const named_value limits[] = {
        { "MAX_MESSAGE_BYTES", CV_NODE_MAX_MESSAGE_BYTES },
        { "CHUNK_BYTES", CV_NODE_CHUNK_BYTES },
        { "BLOB_MIN_BYTES", CV_NODE_BLOB_MIN_BYTES },
        { "UNPACK_BUDGET_BASE_BYTES", CV_NODE_UNPACK_BUDGET_BASE_BYTES },
        { "SHA256_BYTES", CV_SHA256_BYTES },
        { "SESSION_KEY_BYTES", CV_NODE_SESSION_KEY_BYTES },
        { "PEER_MAX_BYTES", (int)CV_NODE_PEER_MAX_BYTES },
        { "MAX_BLOB_QUERY_HASHES", CV_NODE_MAX_BLOB_QUERY },
        { "MAX_ENCODER_STREAMS", CV_NODE_MAX_ENCODER_STREAMS },
        { "MAX_ENCODE_SIDE", CV_NODE_MAX_ENCODE_SIDE },
        { "MAX_ENCODE_PIXELS", CV_NODE_MAX_ENCODE_PIXELS },
        { "MAX_ENCODE_BITRATE_KBPS", CV_ENCODE_MAX_BITRATE_KBPS },
        { "MAX_ENCODE_FPS", CV_ENCODE_MAX_FPS },
    };
    check_enum(&corvid__limit__descriptor, limits, COUNT(limits), "LIMIT_UNSPECIFIED");
    CHECK_EQ_INT(CV_NODE_UNPACK_BUDGET(100), 200 + CV_NODE_UNPACK_BUDGET_BASE_BYTES);
}

static char *read_text(const char *path) {
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    char *text = n >= 0 ? malloc((size_t)n + 1) : NULL;
    if (text && fread(text, 1, (size_t)n, f) == (size_t)n)
        text[n] = '\0';
    else {
        free(text);
        text = NULL;
    }
    fclose(f);
    return text;
}

static const char *format_short_name(cv_format f) {
    switch (f) {
#define FORMAT_CASE(name, bytes, depth, text) \
    case CV_FORMAT_##name: return #name;
        CV_FORMAT_TABLE(FORMAT_CASE)
#undef FORMAT_CASE
    default: return "?";
    }
}

/* The comment node.proto gives pipeline p: kind, local size or targets, push bytes, bindings. */
static void pipeline_comment(const cv_pipeline_info *p, char *out, size_t cap) {
    char bindings[CV_MAX_BINDINGS + 1] = "";
    static const char letters[] = { 'b', 'u', 'i', 't' };
    for (uint32_t b = 0; b < p->binding_count; b++)
        bindings[b] = letters[p->bindings[b]];
    bindings[p->binding_count] = '\0';
    if (p->kind == CV_PIPELINE_COMPUTE) {
        snprintf(out, cap, "\"%s\": compute %ux%ux%u, push %u, bindings \"%s\"", p->name, p->local_size[0],
                 p->local_size[1], p->local_size[2], p->push_constant_size, bindings);
        return;
    }
    char colors[64] = "";
    for (uint32_t c = 0; c < p->color_count; c++)
        snprintf(colors + strlen(colors), sizeof(colors) - strlen(colors), "%s%s", c ? "+" : "",
                 format_short_name(p->color_formats[c]));
    snprintf(out, cap, "\"%s\": graphics, push %u, bindings \"%s\", color %s, depth %s", p->name,
             p->push_constant_size, bindings, p->color_count ? colors : "none",
             p->depth_format == CV_FORMAT_UNDEFINED ? "none" : format_short_name(p->depth_format));
}

static void test_pipelines(void) {
    const ProtobufCEnumDescriptor *d = &corvid__pipeline__descriptor;
    char *proto = read_text(CORVID_PROTO_DIR "/node.proto");
    CHECK(proto != NULL);
    uint32_t count = cv_pipeline_registry_count();
    for (uint32_t i = 0; i < count; i++) {
        const cv_pipeline_info *p = cv_pipeline_registry_at(i);
        char name[128] = "PIPELINE_";
        for (const char *c = p->name; *c && strlen(name) + 1 < sizeof(name); c++) {
            size_t n = strlen(name);
            name[n] = *c == '.' ? '_' : (char)toupper((unsigned char)*c);
            name[n + 1] = '\0';
        }
        const ProtobufCEnumValue *v = protobuf_c_enum_descriptor_get_value_by_name(d, name);
        if (!v)
            fprintf(stderr, "enum Pipeline has no %s for registry pipeline '%s'\n", name, p->name);
        CHECK(v != NULL);
        if (!v || !proto)
            continue;
        char comment[512], line[768];
        pipeline_comment(p, comment, sizeof(comment));
        snprintf(line, sizeof(line), "\n  %s = %d;  // %s\n", name, v->value, comment);
        if (!strstr(proto, line))
            fprintf(stderr, "node.proto lacks the line (or it differs):%s", line);
        CHECK(strstr(proto, line) != NULL);
    }
    CHECK(protobuf_c_enum_descriptor_get_value_by_name(d, "PIPELINE_UNSPECIFIED") != NULL);
    if (d->n_values != count + 1)
        fprintf(stderr, "enum Pipeline has %u values, the registry %u pipelines (+ PIPELINE_UNSPECIFIED)\n",
                d->n_values, count);
    CHECK_EQ_INT(d->n_values, count + 1);
    free(proto);
}

/* The checker itself: a table that differs from an enum must fail. */
static void test_checker_detects_drift(void) {
    int before = check_failures, count = check_count;
    static const named_value renamed[] = { { "CV_FILTER_LINEAR", 0 }, { "CV_FILTER_NEAR", 1 } };
    static const named_value renumbered[] = { { "CV_FILTER_LINEAR", 0 }, { "CV_FILTER_NEAREST", 2 } };
    static const named_value missing[] = { { "CV_FILTER_LINEAR", 0 } };
    static const named_value extra[] = { { "CV_FILTER_LINEAR", 0 },
                                         { "CV_FILTER_NEAREST", 1 },
                                         { "CV_FILTER_CUBIC", 2 } };
    const named_value *tables[] = { renamed, renumbered, missing, extra };
    const size_t sizes[] = { 2, 2, 1, 3 };
    int detected = 0;
    fprintf(stderr, "(expected drift reports follow)\n");
    for (size_t i = 0; i < COUNT(tables); i++) {
        int f0 = check_failures;
        check_enum(&corvid__filter__descriptor, tables[i], sizes[i], NULL);
        detected += check_failures > f0;
    }
    check_failures = before;
    check_count = count;
    CHECK_EQ_INT(detected, 4);
}

int main(void) {
    test_service_paths();
    test_results();
    test_formats_and_sampler();
    test_usage_bits_and_handles();
    test_protocol_constants();
    test_pipelines();
    test_checker_detects_drift();
    return check_report("codec_proto_tables");
}
