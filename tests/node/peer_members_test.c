/* A node sends transfers only to its cluster's members (cv_node_config.peers,
 * corvid-node --peers), so a client cannot make it connect anywhere:
 *  - addresses are normalised before they are compared (case of names,
 *    spellings of IPv4 / IPv6 addresses, leading zeros of ports), and unix:
 *    or other URI targets, numeric shorthands and bad names are refused;
 *  - a node with --peers refuses a push to a non-member loopback port, a unix:
 *    socket and a DNS name with a Reply that says so, and connects to none of
 *    them: a listening TCP socket and a listening unix socket see no
 *    connection, and no delivery failed (nothing was looked up or dialled);
 *    a push to a member lands byte for byte;
 *  - without --peers a loopback node sends to loopback only, and a node on a
 *    network address to no one, each refusal naming why;
 *  - a bad list stops cv_node_start, naming the entry; nothing is left live. */
#include <errno.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include "check.h"
#include "corvid/node_protocol.h"
#include "peer_members.h"
#include "raw_node_client.h"
#include "scratch_node.h"

#define BUF_ID cv_handle_pack(CV_HANDLE_BUFFER, 1, 1, 1)
#define SIZE 256u

static void normalize_is(const char *in, const char *want) {
    char out[PEER_ADDRESS_MAX];
    cv_result r = peer_address_normalize(in, "test", out, sizeof(out));
    if (r != CV_OK || strcmp(out, want) != 0)
        fprintf(stderr, "normalize '%s': got '%s' (%s), want '%s'\n", in, out, cv_last_error(), want);
    CHECK(r == CV_OK && strcmp(out, want) == 0);
}

static void normalize_refuses(const char *in, const char *needle) {
    char out[PEER_ADDRESS_MAX];
    cv_result r = peer_address_normalize(in, "test", out, sizeof(out));
    if (r != CV_ERROR_MALFORMED || !strstr(cv_last_error(), needle))
        fprintf(stderr, "normalize '%s': %s '%s', want a refusal with '%s'\n", in, cv_result_name(r), cv_last_error(),
                needle);
    CHECK_RESULT(r, CV_ERROR_MALFORMED);
    CHECK(strstr(cv_last_error(), needle) != NULL);
    CHECK(out[0] == '\0');
}

static void test_normalize(void) {
    normalize_is("127.0.0.1:7700", "127.0.0.1:7700");
    normalize_is("Node-0.Corvid.SVC:07700", "node-0.corvid.svc:7700");
    normalize_is("[0:0:0:0:0:0:0:1]:80", "[::1]:80");
    normalize_is("[::ffff:10.0.0.7]:80", "10.0.0.7:80");
    normalize_is("corvid_node:7700", "corvid_node:7700");
    normalize_refuses("unix:/tmp/corvid.sock", "test: 'unix:/tmp/corvid.sock': a 'unix' target");
    normalize_refuses("unix-abstract:corvid", "'unix-abstract' target");
    normalize_refuses("dns:///node0:7700", "'dns' target");
    normalize_refuses("node0", "test: 'node0' is not HOST:PORT");
    normalize_refuses("node0:0", "1..65535");
    normalize_refuses("node0:123456", "1..65535");
    normalize_refuses("::1:7700", "IPv6 goes in brackets");
    normalize_refuses("[::1::2]:7700", "'[::1::2]' is not an IPv6 address");
    normalize_refuses("127.1:7700", "'127.1' is a numeric shorthand");
    normalize_refuses("2130706433:7700", "numeric shorthand");
    normalize_refuses("-node:7700", "not a host name");
    normalize_refuses("a..b:7700", "not a host name");
    normalize_refuses("", "test: '' is not HOST:PORT");
}

/* A listening socket that must never see a connection. */
static int listen_tcp(int *port) {
    int fd = socket(AF_INET, SOCK_STREAM | SOCK_NONBLOCK, 0);
    struct sockaddr_in a = { .sin_family = AF_INET, .sin_addr.s_addr = htonl(INADDR_LOOPBACK) };
    socklen_t len = sizeof(a);
    CHECK(fd >= 0 && bind(fd, (struct sockaddr *)&a, sizeof(a)) == 0 && listen(fd, 8) == 0 &&
          getsockname(fd, (struct sockaddr *)&a, &len) == 0);
    *port = ntohs(a.sin_port);
    return fd;
}

static int listen_unix(const char *path) {
    int fd = socket(AF_UNIX, SOCK_STREAM | SOCK_NONBLOCK, 0);
    struct sockaddr_un a = { .sun_family = AF_UNIX };
    snprintf(a.sun_path, sizeof(a.sun_path), "%s", path);
    unlink(path);
    CHECK(fd >= 0 && bind(fd, (struct sockaddr *)&a, sizeof(a)) == 0 && listen(fd, 8) == 0);
    return fd;
}

/* True if nobody connected: accept finds nothing waiting. */
static bool no_connection(int fd) {
    int c = accept(fd, NULL, NULL);
    if (c >= 0)
        close(c);
    return c < 0 && (errno == EAGAIN || errno == EWOULDBLOCK);
}

static void session(raw_client *c, const char *endpoint, const cv_rpc_metadata *md, uint32_t count,
                    uint8_t key[CV_NODE_SESSION_KEY_BYTES]) {
    raw_open_with(c, endpoint, NULL, md, count);
    raw_send_hello(c, CV_NODE_PROTOCOL_VERSION, 0, "peer members");
    Corvid__NodeMessage *m = raw_recv(c);
    bool keyed = m && m->msg_case == CORVID__NODE_MESSAGE__MSG_HELLO &&
                 m->hello->session_key.len == CV_NODE_SESSION_KEY_BYTES;
    CHECK(keyed);
    memset(key, 0, CV_NODE_SESSION_KEY_BYTES);
    if (keyed)
        memcpy(key, m->hello->session_key.data, CV_NODE_SESSION_KEY_BYTES);
    if (m)
        corvid__node_message__free_unpacked(m, NULL);
    cv_resource_desc desc = { .type = CV_HANDLE_BUFFER, .buffer = { .size = SIZE } };
    EXPECT_REPLY(c, raw_send_create(c, BUF_ID, &desc), CV_OK, NULL);
}

static uint64_t push(raw_client *c, const char *destination, const uint8_t *key, uint64_t transfer_id) {
    Corvid__PushTransfer p = CORVID__PUSH_TRANSFER__INIT;
    p.transfer_id = transfer_id;
    p.id = BUF_ID;
    p.size = SIZE;
    p.destination = (char *)destination;
    p.session_key = (ProtobufCBinaryData){ CV_NODE_SESSION_KEY_BYTES, (uint8_t *)key };
    Corvid__ClientMessage m = CORVID__CLIENT_MESSAGE__INIT;
    m.msg_case = CORVID__CLIENT_MESSAGE__MSG_PUSH_TRANSFER;
    m.push_transfer = &p;
    return raw_send(c, &m);
}

static void await_transfer(raw_client *c, uint64_t transfer_id) {
    Corvid__AwaitTransfer a = CORVID__AWAIT_TRANSFER__INIT;
    a.transfer_id = transfer_id;
    a.id = BUF_ID;
    a.size = SIZE;
    Corvid__ClientMessage m = CORVID__CLIENT_MESSAGE__INIT;
    m.msg_case = CORVID__CLIENT_MESSAGE__MSG_AWAIT_TRANSFER;
    m.await_transfer = &a;
    raw_send(c, &m);
}

/* Node a lists node b (and a name) as its peers: only b is reached. */
static void test_members_only(void) {
    scratch_node b, a;
    CHECK_OK(scratch_node_start(&b, cv_mock_backend(), 1, false));
    char peers[160];
    snprintf(peers, sizeof(peers), "node9.example:7700, %s", b.endpoint);
    cv_node_config with_peers = { .peers = peers, .peer_deadline_ms = 2000 };
    CHECK_OK(scratch_node_start_secured(&a, cv_mock_backend(), 1, &with_peers));
    int tcp_port = 0;
    int tcp = listen_tcp(&tcp_port);
    char unix_path[64], unix_target[80], tcp_target[64];
    snprintf(unix_path, sizeof(unix_path), "/tmp/corvid-peer-members-%d.sock", (int)getpid());
    int ux = listen_unix(unix_path);
    snprintf(unix_target, sizeof(unix_target), "unix:%s", unix_path);
    snprintf(tcp_target, sizeof(tcp_target), "127.0.0.1:%d", tcp_port);

    raw_client ca, cb;
    uint8_t key_a[CV_NODE_SESSION_KEY_BYTES], key_b[CV_NODE_SESSION_KEY_BYTES];
    session(&ca, a.endpoint, NULL, 0, key_a);
    session(&cb, b.endpoint, NULL, 0, key_b);
    uint8_t payload[SIZE], zero[SIZE] = { 0 }, got[SIZE];
    for (uint32_t i = 0; i < SIZE; i++)
        payload[i] = (uint8_t)(i * 13 + 5);
    raw_send_write(&ca, BUF_ID, 0, payload, SIZE);
    raw_send_write(&cb, BUF_ID, 0, zero, SIZE);

    EXPECT_REPLY(&ca, push(&ca, tcp_target, key_b, 1), CV_ERROR_INVALID_ARGUMENT, "is not a peer of this node");
    EXPECT_REPLY(&ca, push(&ca, unix_target, key_b, 2), CV_ERROR_MALFORMED, "a 'unix' target");
    EXPECT_REPLY(&ca, push(&ca, "corvid-bogus-peer.invalid:7700", key_b, 3), CV_ERROR_INVALID_ARGUMENT,
                 "(corvid-node --peers node9.example:7700,127.0.0.1:");
    /* A member, spelled otherwise than in the list: normalised, it is b. Sent after the refused ones, by the
     * same sender thread: had those been queued, their connections would have been tried first. */
    char member[64];
    snprintf(member, sizeof(member), "[::ffff:127.0.0.1]:%s", strrchr(b.endpoint, ':') + 1);
    push(&ca, member, key_b, 4);
    await_transfer(&cb, 4);
    CHECK(raw_read_back(&cb, BUF_ID, SIZE, got) && memcmp(got, payload, SIZE) == 0);
    CHECK(raw_read_back(&ca, BUF_ID, SIZE, got)); /* no stray reply on a's session */
    CHECK(no_connection(tcp));
    CHECK(no_connection(ux));
    cv_node_stats sa = cv_node_get_stats(a.node);
    CHECK_EQ_INT(sa.peer_failures, 0);   /* nothing was dialled, so nothing failed to be delivered */
    CHECK_EQ_INT(sa.peer_raw_out, SIZE); /* only the member's push was read and sent (a's session ordered it
                                            before the read back above) */
    raw_close(&ca);
    raw_close(&cb);
    close(tcp);
    close(ux);
    unlink(unix_path);
    CHECK_EQ_INT(scratch_node_wait_sessions(&a, 5000), 0);
    CHECK_EQ_INT(scratch_node_wait_sessions(&b, 5000), 0);
    scratch_node_stop(&a);
    scratch_node_stop(&b);
}

/* No list: loopback only for a loopback node, nothing for a node on a network address. */
static void test_without_peers(void) {
    scratch_node local, open;
    CHECK_OK(scratch_node_start(&local, cv_mock_backend(), 1, false));
    cv_node_config networked = { .listen = "0.0.0.0:0", .token = "peer-members-token" };
    CHECK_OK(scratch_node_start_secured(&open, cv_mock_backend(), 1, &networked));
    raw_client c, o;
    uint8_t key[CV_NODE_SESSION_KEY_BYTES], key_o[CV_NODE_SESSION_KEY_BYTES];
    session(&c, local.endpoint, NULL, 0, key);
    EXPECT_REPLY(&c, push(&c, "corvid-bogus-peer.invalid:7700", key, 1), CV_ERROR_INVALID_ARGUMENT,
                 "sends transfers to loopback addresses only");
    EXPECT_REPLY(&c, push(&c, "10.1.2.3:7700", key, 2), CV_ERROR_INVALID_ARGUMENT, "loopback addresses only");
    EXPECT_REPLY(&c, push(&c, "127.example:7700", key, 3), CV_ERROR_INVALID_ARGUMENT, "loopback addresses only");
    const cv_rpc_metadata md = { "authorization", "Bearer peer-members-token" };
    session(&o, open.endpoint, &md, 1, key_o);
    EXPECT_REPLY(&o, push(&o, local.endpoint, key, 1), CV_ERROR_INVALID_ARGUMENT,
                 "listens on a network address and has no --peers");
    CHECK_EQ_INT(cv_node_get_stats(local.node).peer_failures, 0);
    CHECK_EQ_INT(cv_node_get_stats(open.node).peer_failures, 0);
    raw_close(&c);
    raw_close(&o);
    CHECK_EQ_INT(scratch_node_wait_sessions(&local, 5000), 0);
    CHECK_EQ_INT(scratch_node_wait_sessions(&open, 5000), 0);
    scratch_node_stop(&local);
    scratch_node_stop(&open);
}

static void test_bad_list(void) {
    scratch_node n;
    cv_node_config bad = { .peers = "node0:7700,unix:/tmp/x.sock" };
    CHECK_RESULT(scratch_node_start_secured(&n, cv_mock_backend(), 1, &bad), CV_ERROR_MALFORMED);
    CHECK(strstr(cv_last_error(), "node: peers: 'unix:/tmp/x.sock': a 'unix' target") != NULL);
    CHECK_RESULT(cv_node_check_peers("node0:7700,,node1:7700", "--peers"), CV_ERROR_MALFORMED);
    CHECK(strstr(cv_last_error(), "--peers: '' is not HOST:PORT") != NULL);
    CHECK_OK(cv_node_check_peers(" node0:7700 , [::1]:7700 ", "--peers"));
}

int main(void) {
    test_normalize();
    test_members_only();
    test_without_peers();
    test_bad_list();
    CHECK_NOTHING_LIVE();
    return check_report("node_peer_members");
}
