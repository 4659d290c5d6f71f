/* A raw node.proto client for tests (raw_node_client.h). */
#include "raw_node_client.h"

#include <inttypes.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "corvid/command_codec.h"

void raw_open_with(raw_client *c, const char *endpoint, const cv_rpc_client_config *cc, const cv_rpc_metadata *md,
                   uint32_t count) {
    memset(c, 0, sizeof(*c));
    cv_rpc_client_config defaults = { .max_message_bytes = CV_NODE_MAX_MESSAGE_BYTES };
    CHECK_OK(cv_rpc_client_create(endpoint, cc ? cc : &defaults, &c->client));
    if (c->client)
        CHECK_OK(cv_rpc_client_open(c->client, CV_NODE_METHOD_SESSION, md, count, &c->stream));
}

void raw_open(raw_client *c, const char *endpoint) { raw_open_with(c, endpoint, NULL, NULL, 0); }

void raw_close(raw_client *c) {
    if (c->stream)
        cv_rpc_stream_destroy(c->stream);
    if (c->client)
        cv_rpc_client_destroy(c->client);
    memset(c, 0, sizeof(*c));
}

uint64_t raw_send(raw_client *c, Corvid__ClientMessage *m) {
    m->seq = ++c->seq;
    uint8_t *buf;
    size_t size;
    CHECK_OK(cv_node_pack_client(m, &buf, &size));
    cv_rpc_stream_send(c->stream, buf, size);
    free(buf);
    return m->seq;
}

Corvid__NodeMessage *raw_recv(raw_client *c) {
    uint8_t *data = NULL;
    size_t size = 0;
    if (cv_rpc_stream_recv(c->stream, RAW_TIMEOUT_MS, &data, &size) != CV_OK || !data)
        return NULL;
    Corvid__NodeMessage *m = corvid__node_message__unpack(NULL, size, data);
    free(data);
    CHECK(m != NULL);
    return m;
}

void raw_expect_end(raw_client *c, int status, const char *needle, int line) {
    Corvid__NodeMessage *m;
    while ((m = raw_recv(c)) != NULL)
        corvid__node_message__free_unpacked(m, NULL);
    char message[512] = "";
    int got = cv_rpc_stream_status(c->stream, message, sizeof(message));
    bool ok = got == status && (!needle || strstr(message, needle));
    if (!ok)
        fprintf(stderr, "line %d: stream ended with %d '%s', expected %d mentioning '%s'\n", line, got, message,
                status, needle ? needle : "");
    CHECK(ok);
}

void raw_expect_reply(raw_client *c, uint64_t seq, cv_result code, const char *needle, int line) {
    Corvid__NodeMessage *m = raw_recv(c);
    bool reply = m && m->msg_case == CORVID__NODE_MESSAGE__MSG_REPLY;
    bool ok = reply && m->seq == seq && m->reply->result == code && (!needle || strstr(m->reply->message, needle));
    if (!ok)
        fprintf(stderr,
                "line %d: expected reply %" PRIu64 " with %s mentioning '%s', got %s seq %" PRIu64
                " result %s '%s'\n",
                line, seq, cv_result_name(code), needle ? needle : "", m ? "message" : "nothing", m ? m->seq : 0,
                reply ? cv_result_name(m->reply->result) : "-", reply ? m->reply->message : "");
    CHECK(ok);
    if (m)
        corvid__node_message__free_unpacked(m, NULL);
}

void raw_expect_completed(raw_client *c, uint64_t ticket, cv_result code, const char *needle, int line) {
    Corvid__NodeMessage *m = raw_recv(c);
    bool done = m && m->msg_case == CORVID__NODE_MESSAGE__MSG_COMPLETED;
    bool ok = done && m->completed->ticket == ticket && m->completed->result == code &&
              (!needle || strstr(m->completed->message, needle));
    if (!ok)
        fprintf(stderr,
                "line %d: expected Completed %" PRIu64 " %s mentioning '%s', got %s ticket %" PRIu64 " %s '%s'\n",
                line, ticket, cv_result_name(code), needle ? needle : "", m ? "message" : "nothing",
                done ? m->completed->ticket : 0, done ? cv_result_name(m->completed->result) : "-",
                done ? m->completed->message : "");
    CHECK(ok);
    if (m)
        corvid__node_message__free_unpacked(m, NULL);
}

uint64_t raw_send_hello(raw_client *c, uint32_t version, uint32_t device, const char *client_name) {
    Corvid__Hello hello = CORVID__HELLO__INIT;
    hello.protocol_version = version;
    hello.client_name = (char *)client_name;
    hello.device = device;
    Corvid__ClientMessage m = CORVID__CLIENT_MESSAGE__INIT;
    m.msg_case = CORVID__CLIENT_MESSAGE__MSG_HELLO;
    m.hello = &hello;
    return raw_send(c, &m);
}

uint64_t raw_send_create(raw_client *c, uint64_t id, const cv_resource_desc *desc) {
    Corvid__CreateResource create;
    cv_node_desc_storage storage;
    cv_node_desc_to_msg(id, desc, &create, &storage);
    Corvid__ClientMessage m = CORVID__CLIENT_MESSAGE__INIT;
    m.msg_case = CORVID__CLIENT_MESSAGE__MSG_CREATE;
    m.create = &create;
    return raw_send(c, &m);
}

uint64_t raw_send_destroy(raw_client *c, uint64_t id) {
    Corvid__DestroyResource d = CORVID__DESTROY_RESOURCE__INIT;
    d.id = id;
    Corvid__ClientMessage m = CORVID__CLIENT_MESSAGE__INIT;
    m.msg_case = CORVID__CLIENT_MESSAGE__MSG_DESTROY;
    m.destroy = &d;
    return raw_send(c, &m);
}

uint64_t raw_send_write(raw_client *c, uint64_t id, uint64_t offset, const void *data, size_t size) {
    Corvid__WriteBuffer w = CORVID__WRITE_BUFFER__INIT;
    w.id = id;
    w.offset = offset;
    w.source_case = CORVID__WRITE_BUFFER__SOURCE_DATA;
    w.data = (ProtobufCBinaryData){ size, (uint8_t *)data };
    Corvid__ClientMessage m = CORVID__CLIENT_MESSAGE__INIT;
    m.msg_case = CORVID__CLIENT_MESSAGE__MSG_WRITE_BUFFER;
    m.write_buffer = &w;
    return raw_send(c, &m);
}

uint64_t raw_send_read(raw_client *c, uint64_t id, uint64_t offset, uint64_t size) {
    Corvid__ReadBuffer r = CORVID__READ_BUFFER__INIT;
    r.id = id;
    r.offset = offset;
    r.size = size;
    Corvid__ClientMessage m = CORVID__CLIENT_MESSAGE__INIT;
    m.msg_case = CORVID__CLIENT_MESSAGE__MSG_READ_BUFFER;
    m.read_buffer = &r;
    return raw_send(c, &m);
}

bool raw_read_back(raw_client *c, uint64_t id, uint64_t size, uint8_t *out) {
    uint64_t seq = raw_send_read(c, id, 0, size);
    Corvid__NodeMessage *m = raw_recv(c);
    bool ok = m && m->seq == seq && m->msg_case == CORVID__NODE_MESSAGE__MSG_READ_DATA && m->read_data->last &&
              m->read_data->data.len == size;
    if (ok)
        memcpy(out, m->read_data->data.data, size);
    if (m)
        corvid__node_message__free_unpacked(m, NULL);
    return ok;
}

uint64_t raw_send_chunk(raw_client *c, const uint8_t sha[32], uint64_t size, uint64_t offset, const void *data,
                        size_t len) {
    Corvid__BlobChunk chunk = CORVID__BLOB_CHUNK__INIT;
    chunk.sha256 = (ProtobufCBinaryData){ 32, (uint8_t *)sha };
    chunk.size = size;
    chunk.offset = offset;
    chunk.data = (ProtobufCBinaryData){ len, (uint8_t *)data };
    Corvid__ClientMessage m = CORVID__CLIENT_MESSAGE__INIT;
    m.msg_case = CORVID__CLIENT_MESSAGE__MSG_BLOB_CHUNK;
    m.blob_chunk = &chunk;
    return raw_send(c, &m);
}

uint64_t raw_send_blob_write(raw_client *c, uint64_t id, const uint8_t sha[32]) {
    Corvid__WriteBuffer w = CORVID__WRITE_BUFFER__INIT;
    w.id = id;
    w.source_case = CORVID__WRITE_BUFFER__SOURCE_BLOB;
    w.blob = (ProtobufCBinaryData){ 32, (uint8_t *)sha };
    Corvid__ClientMessage m = CORVID__CLIENT_MESSAGE__INIT;
    m.msg_case = CORVID__CLIENT_MESSAGE__MSG_WRITE_BUFFER;
    m.write_buffer = &w;
    return raw_send(c, &m);
}

uint64_t raw_send_compile(raw_client *c, uint64_t id, const uint8_t *encoded, size_t size) {
    Corvid__CompileList cl = CORVID__COMPILE_LIST__INIT;
    cl.id = id;
    cl.source_case = CORVID__COMPILE_LIST__SOURCE_ENCODED;
    cl.encoded = (ProtobufCBinaryData){ size, (uint8_t *)encoded };
    Corvid__ClientMessage m = CORVID__CLIENT_MESSAGE__INIT;
    m.msg_case = CORVID__CLIENT_MESSAGE__MSG_COMPILE;
    m.compile = &cl;
    return raw_send(c, &m);
}

uint64_t raw_send_submit(raw_client *c, uint64_t id, uint64_t ticket) {
    Corvid__SubmitList s = CORVID__SUBMIT_LIST__INIT;
    s.id = id;
    s.ticket = ticket;
    Corvid__ClientMessage m = CORVID__CLIENT_MESSAGE__INIT;
    m.msg_case = CORVID__CLIENT_MESSAGE__MSG_SUBMIT;
    m.submit = &s;
    return raw_send(c, &m);
}

void raw_encode_copy(uint64_t src, uint64_t dst, uint64_t size, uint8_t **out, size_t *out_size) {
    cv_command_list list;
    cv_command_list_init(&list);
    cv_command_list_begin(&list);
    CHECK_OK(cv_cmd_copy_buffer(&list, CV_QUEUE_COPY,
                                &(cv_copy_buffer_args){ .src = { src }, .dst = { dst }, .size = size }));
    CHECK_OK(cv_command_list_end(&list));
    CHECK_OK(cv_command_list_encode(&list, out, out_size));
    cv_command_list_finish(&list);
}
