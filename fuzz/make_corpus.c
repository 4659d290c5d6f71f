/* Writes fuzz_node_message's seed corpus: real client sessions, packed the way
 * the proxy backend packs them (cv_node_pack_client), in the fuzz input format
 * (fuzz_input.h). Lists are recorded with the ordinary recording calls against
 * a local context whose handle ids are the ids the Create messages announce,
 * exactly as the proxy does.
 *
 *   make_corpus DIR      (scripts/fuzz.sh --seeds runs it into fuzz/corpus/) */
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "corvid/command_codec.h"
#include "corvid/command_list.h"
#include "corvid/context.h"
#include "corvid/node_protocol.h"
#include "corvid/sha256.h"
#include "fuzz_input.h"

typedef struct seed {
    uint8_t bytes[1 << 16];
    size_t size;
    uint64_t seq;
} seed;

static void add(seed *s, Corvid__ClientMessage *m) {
    m->seq = ++s->seq;
    uint8_t *buf;
    size_t n;
    if (cv_node_pack_client(m, &buf, &n) != CV_OK || n > FUZZ_MAX_MESSAGE || s->size + 2 + n > sizeof(s->bytes)) {
        fprintf(stderr, "make_corpus: message too large\n");
        exit(1);
    }
    s->bytes[s->size++] = (uint8_t)(n & 0xff);
    s->bytes[s->size++] = (uint8_t)(n >> 8);
    memcpy(s->bytes + s->size, buf, n);
    s->size += n;
    free(buf);
}

static void hello(seed *s) {
    Corvid__Hello h = CORVID__HELLO__INIT;
    h.protocol_version = CV_NODE_PROTOCOL_VERSION;
    h.client_name = "seed";
    Corvid__ClientMessage m = CORVID__CLIENT_MESSAGE__INIT;
    m.msg_case = CORVID__CLIENT_MESSAGE__MSG_HELLO;
    m.hello = &h;
    add(s, &m);
}

static void create(seed *s, cv_context *ctx, cv_handle h) {
    cv_resource_desc desc;
    bool list = cv_handle_type_of(h.id) == CV_HANDLE_CMDLIST; /* a list has no description: NULL */
    if (!list && cv_context_describe(ctx, h, &desc) != CV_OK) {
        fprintf(stderr, "make_corpus: %s\n", cv_last_error());
        exit(1);
    }
    Corvid__CreateResource c;
    cv_node_desc_storage storage;
    cv_node_desc_to_msg(h.id, list ? NULL : &desc, &c, &storage);
    Corvid__ClientMessage m = CORVID__CLIENT_MESSAGE__INIT;
    m.msg_case = CORVID__CLIENT_MESSAGE__MSG_CREATE;
    m.create = &c;
    add(s, &m);
}

static void write_inline(seed *s, uint64_t id, const void *data, size_t n) {
    Corvid__WriteBuffer w = CORVID__WRITE_BUFFER__INIT;
    w.id = id;
    w.source_case = CORVID__WRITE_BUFFER__SOURCE_DATA;
    w.data = (ProtobufCBinaryData){ n, (uint8_t *)data };
    Corvid__ClientMessage m = CORVID__CLIENT_MESSAGE__INIT;
    m.msg_case = CORVID__CLIENT_MESSAGE__MSG_WRITE_BUFFER;
    m.write_buffer = &w;
    add(s, &m);
}

static void read_buffer(seed *s, uint64_t id, uint64_t n) {
    Corvid__ReadBuffer r = CORVID__READ_BUFFER__INIT;
    r.id = id;
    r.size = n;
    Corvid__ClientMessage m = CORVID__CLIENT_MESSAGE__INIT;
    m.msg_case = CORVID__CLIENT_MESSAGE__MSG_READ_BUFFER;
    m.read_buffer = &r;
    add(s, &m);
}

static void compile(seed *s, cv_context *ctx, cv_cmdlist list) {
    cv_command_list *l;
    uint8_t *enc;
    size_t n;
    if (cv_cmdlist_get(ctx, list, &l) != CV_OK || cv_command_list_encode(l, &enc, &n) != CV_OK) {
        fprintf(stderr, "make_corpus: %s\n", cv_last_error());
        exit(1);
    }
    Corvid__CompileList c = CORVID__COMPILE_LIST__INIT;
    c.id = list.id;
    c.source_case = CORVID__COMPILE_LIST__SOURCE_ENCODED;
    c.encoded = (ProtobufCBinaryData){ n, enc };
    Corvid__ClientMessage m = CORVID__CLIENT_MESSAGE__INIT;
    m.msg_case = CORVID__CLIENT_MESSAGE__MSG_COMPILE;
    m.compile = &c;
    add(s, &m);
    free(enc);
}

static void submit(seed *s, uint64_t id, uint64_t ticket) {
    Corvid__SubmitList sub = CORVID__SUBMIT_LIST__INIT;
    sub.id = id;
    sub.ticket = ticket;
    Corvid__ClientMessage m = CORVID__CLIENT_MESSAGE__INIT;
    m.msg_case = CORVID__CLIENT_MESSAGE__MSG_SUBMIT;
    m.submit = &sub;
    add(s, &m);
}

static void destroy(seed *s, uint64_t id) {
    Corvid__DestroyResource d = CORVID__DESTROY_RESOURCE__INIT;
    d.id = id;
    Corvid__ClientMessage m = CORVID__CLIENT_MESSAGE__INIT;
    m.msg_case = CORVID__CLIENT_MESSAGE__MSG_DESTROY;
    m.destroy = &d;
    add(s, &m);
}

static void save(const seed *s, const char *dir, const char *name) {
    char path[512];
    snprintf(path, sizeof(path), "%s/%s", dir, name);
    FILE *f = fopen(path, "wb");
    if (!f || fwrite(s->bytes, 1, s->size, f) != s->size || fclose(f) != 0) {
        fprintf(stderr, "make_corpus: cannot write %s\n", path);
        exit(1);
    }
    printf("make_corpus: %s (%zu bytes)\n", path, s->size);
}

int main(int argc, char **argv) {
    if (argc != 2) {
        fprintf(stderr, "usage: make_corpus DIR\n");
        return 2;
    }
    static seed s;
    cv_context *ctx;
    if (cv_context_create(NULL, &ctx) != CV_OK)
        return 1;
    cv_buffer a, b;
    cv_texture t;
    cv_cmdlist list;
    cv_buffer_create(ctx, &(cv_buffer_desc){ .size = 256, .label = "a" }, &a);
    cv_buffer_create(ctx, &(cv_buffer_desc){ .size = 256, .label = "b" }, &b);
    cv_texture_create(ctx, &(cv_texture_desc){ .width = 8, .height = 8, .format = CV_FORMAT_RGBA8_UNORM }, &t);
    cv_cmdlist_create(ctx, &list);
    uint8_t bytes[256];
    for (int i = 0; i < 256; i++)
        bytes[i] = (uint8_t)i;

    /* 1: hello alone. */
    memset(&s, 0, sizeof(s));
    hello(&s);
    save(&s, argv[1], "hello.bin");

    /* 2: a buffer written and read back, then destroyed. */
    memset(&s, 0, sizeof(s));
    hello(&s);
    create(&s, ctx, cv_any(a));
    write_inline(&s, a.id, bytes, sizeof(bytes));
    read_buffer(&s, a.id, sizeof(bytes));
    destroy(&s, a.id);
    save(&s, argv[1], "write_read.bin");

    /* 3: a list with a marked pass copying a to b, compiled and submitted twice. */
    cv_command_list *l;
    cv_cmdlist_begin(ctx, list, &l);
    cv_cmd_begin_marker(l, CV_QUEUE_COPY, &(cv_begin_marker_args){ .label = "frame" });
    cv_cmd_copy_buffer(l, CV_QUEUE_COPY, &(cv_copy_buffer_args){ .src = a, .dst = b, .size = 128, .dst_offset = 64 });
    cv_cmd_timestamp(l, CV_QUEUE_COPY, &(cv_timestamp_args){ .label = "copied" });
    cv_cmd_end_marker(l, CV_QUEUE_COPY, &(cv_end_marker_args){ 0 });
    if (cv_command_list_end(l) != CV_OK) {
        fprintf(stderr, "make_corpus: list 3: %s\n", cv_command_list_error(l));
        return 1;
    }
    memset(&s, 0, sizeof(s));
    hello(&s);
    create(&s, ctx, cv_any(a));
    create(&s, ctx, cv_any(b));
    create(&s, ctx, cv_any(t));
    create(&s, ctx, cv_any(list));
    write_inline(&s, a.id, bytes, sizeof(bytes));
    compile(&s, ctx, list);
    submit(&s, list.id, 1);
    submit(&s, list.id, 2);
    read_buffer(&s, b.id, sizeof(bytes));
    save(&s, argv[1], "compile_submit.bin");

    /* 4: a content-addressed upload and a write from it. */
    memset(&s, 0, sizeof(s));
    hello(&s);
    create(&s, ctx, cv_any(a));
    uint8_t sha[CV_SHA256_BYTES];
    cv_sha256(bytes, sizeof(bytes), sha);
    Corvid__BlobChunk chunk = CORVID__BLOB_CHUNK__INIT;
    chunk.sha256 = (ProtobufCBinaryData){ CV_SHA256_BYTES, sha };
    chunk.size = sizeof(bytes);
    chunk.data = (ProtobufCBinaryData){ sizeof(bytes), bytes };
    Corvid__ClientMessage m = CORVID__CLIENT_MESSAGE__INIT;
    m.msg_case = CORVID__CLIENT_MESSAGE__MSG_BLOB_CHUNK;
    m.blob_chunk = &chunk;
    add(&s, &m);
    Corvid__WriteBuffer w = CORVID__WRITE_BUFFER__INIT;
    w.id = a.id;
    w.source_case = CORVID__WRITE_BUFFER__SOURCE_BLOB;
    w.blob = (ProtobufCBinaryData){ CV_SHA256_BYTES, sha };
    m = (Corvid__ClientMessage)CORVID__CLIENT_MESSAGE__INIT;
    m.msg_case = CORVID__CLIENT_MESSAGE__MSG_WRITE_BUFFER;
    m.write_buffer = &w;
    add(&s, &m);
    read_buffer(&s, a.id, 16);
    save(&s, argv[1], "blob_upload.bin");

    cv_context_destroy(ctx);
    return 0;
}
