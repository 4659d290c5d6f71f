/* A hostile client against corvid-node: every bad message gets its expected
 * gRPC status or Reply code, and the node goes on serving other sessions.
 *
 * The client here speaks node.proto by hand over the rpc layer (no proxy
 * backend, which would refuse most of this before sending it). The node serves
 * mock devices: what is checked is the node's own parsing, validation and
 * isolation, which do not depend on the backend (the proxy-vulkan conformance
 * fixture covers Vulkan through the node). */
#include <inttypes.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "corvid/command_codec.h"
#include "corvid/node_protocol.h"
#include "corvid/rpc.h"
#include "corvid/sha256.h"
#include "raw_node_client.h"
#include "scratch_node.h"

static scratch_node node;

/* Opens a session that said hello and got its reply. */
static void session(raw_client *c) {
    raw_open(c, node.endpoint);
    raw_send_hello(c, CV_NODE_PROTOCOL_VERSION, 0, "hostile");
    Corvid__NodeMessage *m = raw_recv(c);
    CHECK(m && m->msg_case == CORVID__NODE_MESSAGE__MSG_HELLO && m->hello->device);
    if (m)
        corvid__node_message__free_unpacked(m, NULL);
}

static const cv_resource_desc buffer_desc = { .type = CV_HANDLE_BUFFER, .buffer = { .size = 256 } };
static const cv_resource_desc texture_desc = {
    .type = CV_HANDLE_TEXTURE, .texture = { .width = 8, .height = 8, .format = CV_FORMAT_RGBA8_UNORM }
};

#define BUF_ID(i) cv_handle_pack(CV_HANDLE_BUFFER, 1, 1, (i))
#define TEX_ID(i) cv_handle_pack(CV_HANDLE_TEXTURE, 1, 1, (i))
#define LIST_ID(i) cv_handle_pack(CV_HANDLE_CMDLIST, 1, 1, (i))

/* ---- the cases ------------------------------------------------------------------ */

static void malformed_and_protocol(void) {
    raw_client c;
    raw_open(&c, node.endpoint); /* 1: bytes that are no protobuf */
    static const uint8_t junk[] = { 0xff, 0xff, 0xff, 0xff, 0x0f, 0x12, 0x80 };
    CHECK_OK(cv_rpc_stream_send(c.stream, junk, sizeof(junk)));
    EXPECT_END(&c, CV_RPC_STATUS_INVALID_ARGUMENT, "not a corvid.ClientMessage");
    raw_close(&c);

    raw_open(&c, node.endpoint); /* 2: a protocol version the node does not speak */
    raw_send_hello(&c, 99, 0, "hostile");
    EXPECT_END(&c, CV_RPC_STATUS_FAILED_PRECONDITION, "protocol version 99");
    raw_close(&c);

    raw_open(&c, node.endpoint); /* 3: a request before hello */
    raw_send_create(&c, BUF_ID(1), &buffer_desc);
    EXPECT_END(&c, CV_RPC_STATUS_INVALID_ARGUMENT, "must be hello");
    raw_close(&c);

    session(&c); /* 4: a second hello */
    raw_send_hello(&c, CV_NODE_PROTOCOL_VERSION, 0, "hostile");
    EXPECT_END(&c, CV_RPC_STATUS_INVALID_ARGUMENT, "second hello");
    raw_close(&c);

    raw_open(&c, node.endpoint); /* 5: a device the node does not have */
    raw_send_hello(&c, CV_NODE_PROTOCOL_VERSION, 7, "hostile");
    EXPECT_END(&c, CV_RPC_STATUS_FAILED_PRECONDITION, "device 7 does not exist");
    raw_close(&c);

    session(&c); /* 6: a message over the node's limit */
    size_t big = CV_NODE_MAX_MESSAGE_BYTES + 1024;
    uint8_t *huge = calloc(1, big);
    raw_send_write(&c, BUF_ID(1), 0, huge, big);
    free(huge);
    EXPECT_END(&c, CV_RPC_STATUS_RESOURCE_EXHAUSTED, NULL);
    raw_close(&c);

    session(&c); /* 7: a message with no request in it */
    Corvid__ClientMessage empty = CORVID__CLIENT_MESSAGE__INIT;
    raw_send(&c, &empty);
    EXPECT_END(&c, CV_RPC_STATUS_INVALID_ARGUMENT, "no request");
    raw_close(&c);
}

static void bad_requests(void) {
    raw_client c;
    session(&c);
    /* 8: a description that does not match the handle's type */
    EXPECT_REPLY(&c, raw_send_create(&c, TEX_ID(1), &buffer_desc), CV_ERROR_WRONG_HANDLE_TYPE, "texture handle");
    /* 9: the same id twice */
    EXPECT_REPLY(&c, raw_send_create(&c, BUF_ID(1), &buffer_desc), CV_OK, NULL);
    EXPECT_REPLY(&c, raw_send_create(&c, BUF_ID(1), &buffer_desc), CV_ERROR_ALREADY_LOADED, "already exists");
    /* 10: a format that does not exist */
    Corvid__CreateResource create;
    cv_node_desc_storage storage;
    cv_node_desc_to_msg(TEX_ID(2), &texture_desc, &create, &storage);
    storage.texture.format = 1000;
    Corvid__ClientMessage m = CORVID__CLIENT_MESSAGE__INIT;
    m.msg_case = CORVID__CLIENT_MESSAGE__MSG_CREATE;
    m.create = &create;
    EXPECT_REPLY(&c, raw_send(&c, &m), CV_ERROR_MALFORMED, "format");
    /* 11: a zero-sized buffer */
    cv_resource_desc zero = buffer_desc;
    zero.buffer.size = 0;
    EXPECT_REPLY(&c, raw_send_create(&c, BUF_ID(3), &zero), CV_ERROR_INVALID_ARGUMENT, "size is 0");
    /* 12: a pipeline the registry does not have */
    cv_resource_desc pipe = { .type = CV_HANDLE_PIPELINE };
    snprintf(pipe.pipeline.name, sizeof(pipe.pipeline.name), "no-such-pipeline");
    EXPECT_REPLY(&c, raw_send_create(&c, cv_handle_pack(CV_HANDLE_PIPELINE, 1, 1, 1), &pipe),
                 CV_ERROR_UNKNOWN_PIPELINE, "no-such-pipeline");
    /* 13: a write out of range (async: answered only because it fails) */
    uint8_t bytes[64] = { 1 };
    EXPECT_REPLY(&c, raw_send_write(&c, BUF_ID(1), 250, bytes, sizeof(bytes)), CV_ERROR_OUT_OF_RANGE, "out of range");
    /* 14: a texture handle where a buffer is wanted */
    EXPECT_REPLY(&c, raw_send_write(&c, TEX_ID(1), 0, bytes, 4), CV_ERROR_WRONG_HANDLE_TYPE, "needs a buffer");
    /* 15: reads of a resource never created */
    EXPECT_REPLY(&c, raw_send_read(&c, BUF_ID(77), 0, 4), CV_ERROR_INVALID_HANDLE, "unknown in this session");
    /* 16: a read past the end */
    EXPECT_REPLY(&c, raw_send_read(&c, BUF_ID(1), 200, 100), CV_ERROR_OUT_OF_RANGE, "read_buffer");
    /* 17: a stale handle (destroyed, then used) */
    raw_send_destroy(&c, BUF_ID(1));
    EXPECT_REPLY(&c, raw_send_write(&c, BUF_ID(1), 0, bytes, 4), CV_ERROR_INVALID_HANDLE, "unknown in this session");
    /* 18: texture data of the wrong size */
    EXPECT_REPLY(&c, raw_send_create(&c, TEX_ID(3), &texture_desc), CV_OK, NULL);
    Corvid__WriteTexture wt = CORVID__WRITE_TEXTURE__INIT;
    wt.id = TEX_ID(3);
    wt.width = 8;
    wt.height = 8;
    wt.data = (ProtobufCBinaryData){ 10, bytes };
    Corvid__ClientMessage tm = CORVID__CLIENT_MESSAGE__INIT;
    tm.msg_case = CORVID__CLIENT_MESSAGE__MSG_WRITE_TEXTURE;
    tm.write_texture = &wt;
    EXPECT_REPLY(&c, raw_send(&c, &tm), CV_ERROR_MALFORMED, "10 bytes of data for 8x8");
    /* 19: a blob query with a hash of the wrong length */
    ProtobufCBinaryData short_hash = { 5, bytes };
    Corvid__BlobQuery q = CORVID__BLOB_QUERY__INIT;
    q.n_sha256 = 1;
    q.sha256 = &short_hash;
    Corvid__ClientMessage qm = CORVID__CLIENT_MESSAGE__INIT;
    qm.msg_case = CORVID__CLIENT_MESSAGE__MSG_BLOB_QUERY;
    qm.blob_query = &q;
    EXPECT_REPLY(&c, raw_send(&c, &qm), CV_ERROR_MALFORMED, "SHA-256");
    /* The session still works after all of that. */
    EXPECT_REPLY(&c, raw_send_create(&c, BUF_ID(4), &buffer_desc), CV_OK, NULL);
    uint8_t pattern[16], back[16];
    for (int i = 0; i < 16; i++)
        pattern[i] = (uint8_t)(i * 7 + 1);
    raw_send_write(&c, BUF_ID(4), 0, pattern, 16);
    CHECK(raw_read_back(&c, BUF_ID(4), 16, back) && memcmp(pattern, back, 16) == 0);
    raw_close(&c);
}

static void uploads(void) {
    raw_client c;
    session(&c);
    EXPECT_REPLY(&c,
                 raw_send_create(&c, BUF_ID(1),
                                 &(cv_resource_desc){ .type = CV_HANDLE_BUFFER, .buffer = { .size = 4096 } }),
                 CV_OK, NULL);
    uint8_t data[4096], sha[32];
    for (int i = 0; i < 4096; i++)
        data[i] = (uint8_t)(i ^ 0x5a);
    cv_sha256(data, sizeof(data), sha);
    /* 20: chunks whose content does not match their hash */
    uint8_t wrong[32];
    memcpy(wrong, sha, 32);
    wrong[0] ^= 1;
    raw_send_chunk(&c, wrong, 4096, 0, data, 2048);
    EXPECT_REPLY(&c, raw_send_chunk(&c, wrong, 4096, 2048, data + 2048, 2048), CV_ERROR_HASH_MISMATCH, NULL);
    EXPECT_REPLY(&c, raw_send_blob_write(&c, BUF_ID(1), wrong), CV_ERROR_NOT_FOUND, "not in the node's cache");
    /* 21: an upload that stops half way, then a write that refers to it */
    raw_send_chunk(&c, sha, 4096, 0, data, 1000);
    EXPECT_REPLY(&c, raw_send_blob_write(&c, BUF_ID(1), sha), CV_ERROR_NOT_FOUND, "upload it first");
    /* 22: a first chunk that does not start at 0 */
    uint8_t other[32];
    cv_sha256(data, 100, other);
    EXPECT_REPLY(&c, raw_send_chunk(&c, other, 100, 50, data, 50), CV_ERROR_OUT_OF_RANGE, "must be 0");
    /* A proper upload then works, and the bytes arrive. */
    raw_send_chunk(&c, sha, 4096, 0, data, 3000);
    raw_send_chunk(&c, sha, 4096, 3000, data + 3000, 1096);
    EXPECT_REPLY(&c, raw_send_blob_write(&c, BUF_ID(1), sha), CV_OK, NULL);
    uint8_t *back = malloc(4096);
    CHECK(raw_read_back(&c, BUF_ID(1), 4096, back) && memcmp(back, data, 4096) == 0);
    free(back);
    raw_close(&c);
}

static void lists(void) {
    raw_client c;
    session(&c);
    cv_resource_desc small = { .type = CV_HANDLE_BUFFER, .buffer = { .size = 64 } };
    EXPECT_REPLY(&c, raw_send_create(&c, BUF_ID(1), &small), CV_OK, NULL);
    EXPECT_REPLY(&c, raw_send_create(&c, BUF_ID(2), &small), CV_OK, NULL);
    EXPECT_REPLY(&c, raw_send_create(&c, LIST_ID(1), NULL), CV_OK, NULL);
    /* 23: an encoded list that is garbage */
    static const uint8_t junk[] = { 0x0a, 0x05, 0xff, 0xff };
    EXPECT_REPLY(&c, raw_send_compile(&c, LIST_ID(1), junk, sizeof(junk)), CV_ERROR_MALFORMED, NULL);
    /* 24: a list naming a handle this session never created */
    uint8_t *enc;
    size_t n;
    raw_encode_copy(BUF_ID(1), BUF_ID(99), 16, &enc, &n);
    EXPECT_REPLY(&c, raw_send_compile(&c, LIST_ID(1), enc, n), CV_ERROR_INVALID_HANDLE, "command 0");
    free(enc);
    /* 25: a copy past the end, caught by the node's validation */
    raw_encode_copy(BUF_ID(1), BUF_ID(2), 128, &enc, &n);
    EXPECT_REPLY(&c, raw_send_compile(&c, LIST_ID(1), enc, n), CV_ERROR_OUT_OF_RANGE, NULL);
    free(enc);
    /* 26: submitting a list that never compiled: Completed carries the error */
    raw_send_submit(&c, LIST_ID(1), 1);
    Corvid__NodeMessage *m = raw_recv(&c);
    CHECK(m && m->msg_case == CORVID__NODE_MESSAGE__MSG_COMPLETED && m->completed->ticket == 1 &&
          m->completed->result != CV_OK);
    if (m)
        corvid__node_message__free_unpacked(m, NULL);
    /* A good list runs and its result is there to read. */
    uint8_t pattern[16] = { 9, 8, 7, 6, 5, 4, 3, 2, 1, 0, 11, 12, 13, 14, 15, 16 }, back[16] = { 0 };
    raw_send_write(&c, BUF_ID(1), 0, pattern, 16);
    raw_encode_copy(BUF_ID(1), BUF_ID(2), 16, &enc, &n);
    raw_send_compile(&c, LIST_ID(1), enc, n);
    free(enc);
    raw_send_submit(&c, LIST_ID(1), 2);
    m = raw_recv(&c);
    CHECK(m && m->msg_case == CORVID__NODE_MESSAGE__MSG_COMPLETED && m->completed->ticket == 2 &&
          m->completed->result == CV_OK);
    if (m)
        corvid__node_message__free_unpacked(m, NULL);
    CHECK(raw_read_back(&c, BUF_ID(2), 16, back) && memcmp(pattern, back, 16) == 0);
    /* 27: a ticket out of sequence ends the session */
    raw_send_submit(&c, LIST_ID(1), 9);
    EXPECT_END(&c, CV_RPC_STATUS_INVALID_ARGUMENT, "tickets increase by one");
    raw_close(&c);
}

/* 28: a handle of another session is unknown here, and the other session's
 * resource is untouched. */
static void isolation(void) {
    raw_client a, b;
    session(&a);
    session(&b);
    cv_resource_desc small = { .type = CV_HANDLE_BUFFER, .buffer = { .size = 16 } };
    EXPECT_REPLY(&a, raw_send_create(&a, BUF_ID(5), &small), CV_OK, NULL);
    uint8_t mine[16] = { 42, 42, 42, 42 }, theirs[16] = { 0 }, back[16];
    raw_send_write(&a, BUF_ID(5), 0, mine, 16);
    EXPECT_REPLY(&b, raw_send_write(&b, BUF_ID(5), 0, theirs, 16), CV_ERROR_INVALID_HANDLE,
                 "unknown in this session");
    EXPECT_REPLY(&b, raw_send_read(&b, BUF_ID(5), 0, 16), CV_ERROR_INVALID_HANDLE, "unknown in this session");
    CHECK(raw_read_back(&a, BUF_ID(5), 16, back) && memcmp(back, mine, 16) == 0);
    raw_close(&a);
    raw_close(&b);
}

/* 29: a client that disappears mid-frame; 30: thousands of sessions opened and
 * dropped. The node frees each and keeps serving. */
static void churn(void) {
    raw_client c;
    session(&c);
    cv_resource_desc big = { .type = CV_HANDLE_BUFFER, .buffer = { .size = 1 << 20 } };
    EXPECT_REPLY(&c, raw_send_create(&c, BUF_ID(1), &big), CV_OK, NULL);
    EXPECT_REPLY(&c, raw_send_create(&c, BUF_ID(2), &big), CV_OK, NULL);
    EXPECT_REPLY(&c, raw_send_create(&c, LIST_ID(1), NULL), CV_OK, NULL);
    uint8_t *enc;
    size_t n;
    raw_encode_copy(BUF_ID(1), BUF_ID(2), 1 << 20, &enc, &n);
    raw_send_compile(&c, LIST_ID(1), enc, n);
    free(enc);
    for (uint64_t t = 1; t <= 50; t++)
        raw_send_submit(&c, LIST_ID(1), t);
    cv_rpc_stream_cancel(c.stream);
    raw_close(&c);

    for (int i = 0; i < 2000; i++) {
        raw_open(&c, node.endpoint);
        if (i % 3 == 0) { /* a session that really started, then vanished */
            raw_send_hello(&c, CV_NODE_PROTOCOL_VERSION, 0, "hostile");
            Corvid__NodeMessage *m = raw_recv(&c);
            CHECK(m && m->msg_case == CORVID__NODE_MESSAGE__MSG_HELLO);
            if (m)
                corvid__node_message__free_unpacked(m, NULL);
        }
        if (i % 3 == 1)
            cv_rpc_stream_close_send(c.stream);
        raw_close(&c);
    }
    CHECK_EQ_INT(scratch_node_wait_sessions(&node, 20000), 0);
    raw_client ok;
    session(&ok);
    EXPECT_REPLY(&ok, raw_send_create(&ok, BUF_ID(1), &buffer_desc), CV_OK, NULL);
    raw_close(&ok);
    CHECK(cv_node_get_stats(node.node).sessions_started >= 667);
}

/* Health: SERVING, then NOT_SERVING once draining, and unknown services are NOT_FOUND. */
static void health(void) {
    cv_rpc_client *client;
    CHECK_OK(cv_rpc_client_create(node.endpoint, &(cv_rpc_client_config){ 0 }, &client));
    uint8_t req[64];
    /* HealthCheckRequest{service = ""} packs to nothing; {service = "x"} by hand. */
    void *resp = NULL;
    size_t resp_size = 0;
    int status = -1;
    CHECK_OK(cv_rpc_client_unary(client, CV_HEALTH_METHOD_CHECK, req, 0, RAW_TIMEOUT_MS, &resp, &resp_size, &status));
    CHECK(status == 0 && resp_size == 2 && ((uint8_t *)resp)[0] == 0x08 && ((uint8_t *)resp)[1] == 1);
    free(resp);
    resp = NULL;
    static const uint8_t unknown[] = { 0x0a, 0x03, 'f', 'o', 'o' };
    cv_rpc_client_unary(client, CV_HEALTH_METHOD_CHECK, unknown, sizeof(unknown), RAW_TIMEOUT_MS, &resp, &resp_size,
                        &status);
    CHECK_EQ_INT(status, CV_RPC_STATUS_NOT_FOUND);
    free(resp);
    resp = NULL;
    cv_node_drain(node.node);
    CHECK_OK(cv_rpc_client_unary(client, CV_HEALTH_METHOD_CHECK, req, 0, RAW_TIMEOUT_MS, &resp, &resp_size, &status));
    CHECK(status == 0 && resp_size == 2 && ((uint8_t *)resp)[1] == 2);
    free(resp);
    cv_rpc_client_destroy(client);
    /* A session opened while draining is refused. */
    raw_client c;
    raw_open(&c, node.endpoint);
    raw_send_hello(&c, CV_NODE_PROTOCOL_VERSION, 0, "hostile");
    EXPECT_END(&c, CV_RPC_STATUS_UNAVAILABLE, NULL);
    raw_close(&c);
}

/* 32: Info reads its request: bytes that are no InfoRequest, and fields this protocol version does not have,
 * are refused by name (they were ignored: the client believed them honoured). */
static void info_request(void) {
    cv_rpc_client *client;
    CHECK_OK(cv_rpc_client_create(node.endpoint, &(cv_rpc_client_config){ 0 }, &client));
    void *resp = NULL;
    size_t resp_size = 0;
    int status = -1;
    uint8_t empty[1];
    CHECK_OK(cv_rpc_client_unary(client, CV_NODE_METHOD_INFO, empty, 0, RAW_TIMEOUT_MS, &resp, &resp_size, &status));
    Corvid__NodeInfo *info = corvid__node_info__unpack(NULL, resp_size, resp);
    CHECK(status == 0 && info && info->n_devices == 1);
    if (info)
        corvid__node_info__free_unpacked(info, NULL);
    free(resp);
    resp = NULL;
    static const uint8_t junk[] = { 0xff, 0xff, 0xff };
    CHECK_RESULT(cv_rpc_client_unary(client, CV_NODE_METHOD_INFO, junk, sizeof(junk), RAW_TIMEOUT_MS, &resp,
                                     &resp_size, &status),
                 CV_ERROR_CONNECTION);
    CHECK_EQ_INT(status, CV_RPC_STATUS_INVALID_ARGUMENT);
    CHECK(strstr(cv_last_error(), "Info: 3 bytes are not a corvid.InfoRequest") != NULL);
    static const uint8_t unknown_field[] = { 0x08, 0x01 }; /* field 1 = 1 */
    CHECK_RESULT(cv_rpc_client_unary(client, CV_NODE_METHOD_INFO, unknown_field, sizeof(unknown_field),
                                     RAW_TIMEOUT_MS, &resp, &resp_size, &status),
                 CV_ERROR_CONNECTION);
    CHECK_EQ_INT(status, CV_RPC_STATUS_INVALID_ARGUMENT);
    CHECK(strstr(cv_last_error(), "InfoRequest field 1 is not served by this node") != NULL);
    cv_rpc_client_destroy(client);
}

/* 31: an idle session is closed by the node. */
static void idle_timeout(void) {
    scratch_node quick;
    CHECK_OK(scratch_node_start_with(&quick, cv_mock_backend(), 1, false, 300, NULL));
    raw_client c;
    raw_open(&c, quick.endpoint);
    raw_send_hello(&c, CV_NODE_PROTOCOL_VERSION, 0, "hostile");
    EXPECT_END(&c, CV_RPC_STATUS_DEADLINE_EXCEEDED, "idle");
    raw_close(&c);
    CHECK_EQ_INT(scratch_node_wait_sessions(&quick, 5000), 0);
    scratch_node_stop(&quick);
}

int main(void) {
    CHECK_OK(scratch_node_start(&node, cv_mock_backend(), 1, false));
    if (!node.node)
        return check_report("node_hostile");
    malformed_and_protocol();
    bad_requests();
    uploads();
    lists();
    isolation();
    churn();
    idle_timeout();
    info_request();
    health(); /* drains the node: last */
    CHECK_EQ_INT(scratch_node_wait_sessions(&node, 5000), 0);
    scratch_node_stop(&node);
    return check_report("node_hostile");
}
