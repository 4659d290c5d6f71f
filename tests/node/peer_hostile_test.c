/* Node-to-node transfers against hostile input: every bad PeerPiece gets its
 * gRPC status (wrong or short session key, oversize, out of order), every bad
 * or missing transfer fails its AwaitTransfer with a clear Reply (corrupt
 * compressed data, a size that is not the region's, a region out of range, a
 * peer that stops half way, a transfer the client gave up), nothing is
 * written, the session's submissions and reads are refused until the client
 * resumes, and then the session and the node go on. A well-formed transfer
 * lands byte for byte. Mock devices: this is the node's own checking. */
#include <inttypes.h>
#include <stdlib.h>
#include <string.h>
#include <zstd.h>

#include "check.h"
#include "corvid/node_protocol.h"
#include "corvid/rpc.h"
#include "raw_node_client.h"
#include "scratch_node.h"

static scratch_node node;

#define BUF_ID(i) cv_handle_pack(CV_HANDLE_BUFFER, 1, 1, (i))
#define LIST_ID(i) cv_handle_pack(CV_HANDLE_CMDLIST, 1, 1, (i))
#define SIZE 256u

/* A session that said hello; key gets its session key. */
static void session(raw_client *c, uint8_t key[CV_NODE_SESSION_KEY_BYTES]) {
    raw_open(c, node.endpoint);
    raw_send_hello(c, CV_NODE_PROTOCOL_VERSION, 0, "peer hostile");
    Corvid__NodeMessage *m = raw_recv(c);
    CHECK(m && m->msg_case == CORVID__NODE_MESSAGE__MSG_HELLO);
    bool keyed = m && m->msg_case == CORVID__NODE_MESSAGE__MSG_HELLO &&
                 m->hello->session_key.len == CV_NODE_SESSION_KEY_BYTES;
    CHECK(keyed);
    memset(key, 0, CV_NODE_SESSION_KEY_BYTES);
    if (keyed)
        memcpy(key, m->hello->session_key.data, CV_NODE_SESSION_KEY_BYTES);
    if (m)
        corvid__node_message__free_unpacked(m, NULL);
}

/* One PeerPiece as a peer node sends it; returns the gRPC status, `message` its text. */
static int piece(const uint8_t *key, size_t key_len, uint64_t transfer_id, uint64_t raw_size, uint64_t compressed,
                 uint64_t offset, const void *data, size_t len, bool abort_it, char *message, size_t cap) {
    Corvid__PeerPiece p = CORVID__PEER_PIECE__INIT;
    p.session_key = (ProtobufCBinaryData){ key_len, (uint8_t *)key };
    p.transfer_id = transfer_id;
    p.raw_size = raw_size;
    p.compressed_size = compressed;
    p.offset = offset;
    p.data = (ProtobufCBinaryData){ len, (uint8_t *)data };
    p.abort = abort_it;
    size_t n = corvid__peer_piece__get_packed_size(&p);
    uint8_t *buf = malloc(n ? n : 1);
    corvid__peer_piece__pack(&p, buf);
    cv_rpc_client *client;
    int status = -1;
    CHECK_OK(cv_rpc_client_create(node.endpoint, NULL, &client));
    void *resp = NULL;
    size_t resp_size = 0;
    cv_rpc_client_unary(client, CV_NODE_METHOD_PEER_PIECE, buf, n, 5000, &resp, &resp_size, &status);
    snprintf(message, cap, "%s", cv_last_error());
    free(resp);
    cv_rpc_client_destroy(client);
    free(buf);
    return status;
}

static uint64_t await_on(raw_client *c, uint64_t id, uint64_t transfer_id, uint64_t offset, uint64_t size,
                         uint32_t deadline) {
    Corvid__AwaitTransfer a = CORVID__AWAIT_TRANSFER__INIT;
    a.transfer_id = transfer_id;
    a.id = id;
    a.offset = offset;
    a.size = size;
    a.deadline_ms = deadline;
    Corvid__ClientMessage m = CORVID__CLIENT_MESSAGE__INIT;
    m.msg_case = CORVID__CLIENT_MESSAGE__MSG_AWAIT_TRANSFER;
    m.await_transfer = &a;
    return raw_send(c, &m);
}

static uint64_t send_await(raw_client *c, uint64_t transfer_id, uint64_t offset, uint64_t size, uint32_t deadline) {
    return await_on(c, BUF_ID(1), transfer_id, offset, size, deadline);
}

static uint64_t send_push(raw_client *c, uint64_t id, const uint8_t *key, size_t key_len) {
    Corvid__PushTransfer p = CORVID__PUSH_TRANSFER__INIT;
    p.transfer_id = 1;
    p.id = id;
    p.size = SIZE;
    p.destination = node.endpoint;
    p.session_key = (ProtobufCBinaryData){ key_len, (uint8_t *)key };
    Corvid__ClientMessage m = CORVID__CLIENT_MESSAGE__INIT;
    m.msg_case = CORVID__CLIENT_MESSAGE__MSG_PUSH_TRANSFER;
    m.push_transfer = &p;
    return raw_send(c, &m);
}

static uint64_t send_resume(raw_client *c, uint64_t failure) {
    Corvid__ResumeAfterFailure r = CORVID__RESUME_AFTER_FAILURE__INIT;
    r.failure = failure;
    Corvid__ClientMessage m = CORVID__CLIENT_MESSAGE__INIT;
    m.msg_case = CORVID__CLIENT_MESSAGE__MSG_RESUME;
    m.resume = &r;
    return raw_send(c, &m);
}

/* The await's Reply: its code, a needle in its message and the failure it started (returned). */
static uint64_t expect_failed(raw_client *c, uint64_t seq, cv_result code, const char *needle, int line) {
    Corvid__NodeMessage *m = raw_recv(c);
    bool ok = m && m->msg_case == CORVID__NODE_MESSAGE__MSG_REPLY && m->seq == seq && m->reply->result == code &&
              strstr(m->reply->message, needle) && m->reply->transfer_failure != 0;
    if (!ok)
        fprintf(stderr, "line %d: expected reply %" PRIu64 " %s '%s' with a transfer failure, got %s '%s'\n", line,
                seq, cv_result_name(code), needle,
                m && m->msg_case == CORVID__NODE_MESSAGE__MSG_REPLY ? cv_result_name(m->reply->result) : "-",
                m && m->msg_case == CORVID__NODE_MESSAGE__MSG_REPLY ? m->reply->message : "");
    CHECK(ok);
    uint64_t failure = ok ? m->reply->transfer_failure : 0;
    if (m)
        corvid__node_message__free_unpacked(m, NULL);
    return failure;
}

static bool buffer_is(raw_client *c, const uint8_t *want) {
    uint8_t got[SIZE];
    return raw_read_back(c, BUF_ID(1), SIZE, got) && memcmp(got, want, SIZE) == 0;
}

static void cases(void) {
    raw_client a, b;
    uint8_t key[CV_NODE_SESSION_KEY_BYTES], other[CV_NODE_SESSION_KEY_BYTES];
    session(&a, key);
    session(&b, other);
    CHECK(memcmp(key, other, sizeof(key)) != 0);
    cv_resource_desc desc = { .type = CV_HANDLE_BUFFER, .buffer = { .size = SIZE } };
    EXPECT_REPLY(&a, raw_send_create(&a, BUF_ID(1), &desc), CV_OK, NULL);
    uint8_t before[SIZE], payload[SIZE];
    for (uint32_t i = 0; i < SIZE; i++) {
        before[i] = (uint8_t)i;
        payload[i] = (uint8_t)(255 - i * 7);
    }
    raw_send_write(&a, BUF_ID(1), 0, before, SIZE);
    char why[1024];
    uint8_t junk[64];
    memset(junk, 0xA5, sizeof(junk));

    /* 1: a key no session holds, a short key, bytes that are no PeerPiece */
    uint8_t wrong[CV_NODE_SESSION_KEY_BYTES];
    memcpy(wrong, key, sizeof(wrong));
    wrong[0] ^= 1;
    CHECK_EQ_INT(piece(wrong, sizeof(wrong), 1, SIZE, 10, 0, junk, 10, false, why, sizeof(why)),
                 CV_RPC_STATUS_PERMISSION_DENIED);
    CHECK(strstr(why, "no session of this node holds that session key"));
    CHECK_EQ_INT(piece(key, 8, 1, SIZE, 10, 0, junk, 10, false, why, sizeof(why)), CV_RPC_STATUS_INVALID_ARGUMENT);
    CHECK(strstr(why, "a session key has 16"));
    /* 2: oversize, and compressed beyond zstd's bound for its size */
    CHECK_EQ_INT(piece(key, 16, 1, CV_NODE_PEER_MAX_BYTES + 1, 10, 0, junk, 10, false, why, sizeof(why)),
                 CV_RPC_STATUS_INVALID_ARGUMENT);
    CHECK_EQ_INT(piece(key, 16, 1, SIZE, 1u << 20, 0, junk, 10, false, why, sizeof(why)),
                 CV_RPC_STATUS_INVALID_ARGUMENT);
    CHECK(strstr(why, "compressed at most"));
    /* 3: a piece before the first, and past the end */
    CHECK_EQ_INT(piece(key, 16, 1, SIZE, 20, 10, junk, 10, false, why, sizeof(why)), CV_RPC_STATUS_INVALID_ARGUMENT);
    CHECK(strstr(why, "before its first piece"));
    CHECK_EQ_INT(piece(key, 16, 1, SIZE, 8, 0, junk, 10, false, why, sizeof(why)), CV_RPC_STATUS_INVALID_ARGUMENT);

    /* 4: corrupt compressed data: the await fails, nothing is written, reads and submits wait for the resume */
    CHECK_EQ_INT(piece(key, 16, 1, SIZE, 10, 0, junk, 10, false, why, sizeof(why)), CV_RPC_STATUS_OK);
    uint64_t failure = expect_failed(&a, send_await(&a, 1, 0, SIZE, 0), CV_ERROR_MALFORMED, "zstd", __LINE__);
    uint64_t seq = raw_send_read(&a, BUF_ID(1), 0, SIZE);
    EXPECT_REPLY(&a, seq, CV_ERROR_MALFORMED, "read refused");
    uint8_t *enc;
    size_t enc_size;
    EXPECT_REPLY(&a, raw_send_create(&a, BUF_ID(2), &desc), CV_OK, NULL);
    EXPECT_REPLY(&a, raw_send_create(&a, LIST_ID(1), NULL), CV_OK, NULL);
    raw_encode_copy(BUF_ID(1), BUF_ID(2), 16, &enc, &enc_size);
    raw_send_compile(&a, LIST_ID(1), enc, enc_size);
    free(enc);
    raw_send_submit(&a, LIST_ID(1), 1);
    EXPECT_COMPLETED(&a, 1, CV_ERROR_MALFORMED, "submission skipped");
    /* 5: a failure that never happened */
    EXPECT_REPLY(&a, send_resume(&a, failure + 5), CV_ERROR_MALFORMED, "never happened");
    send_resume(&a, failure);
    raw_send_submit(&a, LIST_ID(1), 2);
    EXPECT_COMPLETED(&a, 2, CV_OK, NULL);
    CHECK(buffer_is(&a, before));

    /* 6: a transfer whose size is not the region's */
    size_t bound = ZSTD_compressBound(SIZE);
    uint8_t *z = malloc(bound);
    size_t zn = ZSTD_compress(z, bound, payload, SIZE, 1);
    CHECK(!ZSTD_isError(zn));
    CHECK_EQ_INT(piece(key, 16, 2, SIZE, zn, 0, z, zn, false, why, sizeof(why)), CV_RPC_STATUS_OK);
    failure = expect_failed(&a, send_await(&a, 2, 0, SIZE / 2, 0), CV_ERROR_MALFORMED, "the region holds 128",
                            __LINE__);
    send_resume(&a, failure);
    /* 7: a region out of range */
    failure = expect_failed(&a, send_await(&a, 3, 16, SIZE, 0), CV_ERROR_OUT_OF_RANGE, "of buffer", __LINE__);
    send_resume(&a, failure);
    /* 8: a peer that stops half way: the await fails at its deadline, naming what came */
    CHECK_EQ_INT(piece(key, 16, 4, SIZE, 20, 0, junk, 10, false, why, sizeof(why)), CV_RPC_STATUS_OK);
    failure = expect_failed(&a, send_await(&a, 4, 0, SIZE, 300), CV_ERROR_TIMEOUT, "10 of 20 bytes", __LINE__);
    send_resume(&a, failure);
    /* 9: another session's key delivers there, not here */
    CHECK_EQ_INT(piece(other, 16, 5, SIZE, zn, 0, z, zn, false, why, sizeof(why)), CV_RPC_STATUS_OK);
    failure = expect_failed(&a, send_await(&a, 5, 0, SIZE, 200), CV_ERROR_TIMEOUT, "0 of 0 bytes", __LINE__);
    send_resume(&a, failure);
    /* 10: a transfer the client gave up fails at once; its late pieces are refused */
    CHECK_EQ_INT(piece(key, 16, 6, 0, 0, 0, NULL, 0, true, why, sizeof(why)), CV_RPC_STATUS_OK);
    failure = expect_failed(&a, send_await(&a, 6, 0, SIZE, 0), CV_ERROR_CONNECTION, "given up", __LINE__);
    CHECK_EQ_INT(piece(key, 16, 6, SIZE, zn, 0, z, zn, false, why, sizeof(why)), CV_RPC_STATUS_FAILED_PRECONDITION);
    send_resume(&a, failure);
    CHECK(buffer_is(&a, before));
    /* 11: an await of a handle the session does not know; pushes of an unknown handle, with a short key */
    failure = expect_failed(&a, await_on(&a, BUF_ID(9), 8, 0, SIZE, 0), CV_ERROR_INVALID_HANDLE,
                            "unknown in this session", __LINE__);
    send_resume(&a, failure);
    EXPECT_REPLY(&b, send_push(&b, BUF_ID(9), key, 16), CV_ERROR_INVALID_HANDLE, "unknown in this session");
    EXPECT_REPLY(&a, send_push(&a, BUF_ID(1), key, 4), CV_ERROR_MALFORMED, "a session key has 16");
    /* 11: an await of an id below the last one */
    failure = expect_failed(&a, send_await(&a, 2, 0, SIZE, 0), CV_ERROR_MALFORMED, "increasing order", __LINE__);
    send_resume(&a, failure);

    /* 12: a good transfer lands byte for byte, whether it came before or after its await */
    CHECK_EQ_INT(piece(key, 16, 9, SIZE, zn, 0, z, zn, false, why, sizeof(why)), CV_RPC_STATUS_OK);
    send_await(&a, 9, 0, SIZE, 0);
    CHECK(buffer_is(&a, payload));
    cv_node_stats ns = cv_node_get_stats(node.node);
    CHECK(ns.transfer_failures >= 7);
    CHECK(ns.peer_bytes_in > 0);
    free(z);
    raw_close(&a);
    raw_close(&b);
}

int main(void) {
    cv_node_config quick = { .peer_deadline_ms = 2000 };
    CHECK_OK(scratch_node_start_secured(&node, cv_mock_backend(), 1, &quick));
    if (!node.node)
        return check_report("node_peer_hostile");
    cases();
    /* The node still serves a new session. */
    raw_client c;
    uint8_t key[CV_NODE_SESSION_KEY_BYTES];
    session(&c, key);
    raw_close(&c);
    CHECK_EQ_INT(scratch_node_wait_sessions(&node, 5000), 0);
    scratch_node_stop(&node);
    CHECK_NOTHING_LIVE();
    return check_report("node_peer_hostile");
}
