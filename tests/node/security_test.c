/* corvid-node's security (docs/node.md, "Security"): bearer tokens, TLS and
 * mutual TLS through gRPC's own credentials, the loopback-only default, and
 * per-session quotas.
 *
 * In-process nodes on 127.0.0.1 port 0 serving mock devices. Clients speak
 * node.proto by hand over the rpc layer (as tests/node/hostile_test.c does), or
 * go through the proxy backend with its token and TLS options (cv_proxy_configure)
 * set. Certificates are made at test time with the openssl command into a
 * temporary directory: a CA, a server certificate for 127.0.0.1 and
 * localhost, a client certificate, an expired server certificate, and a
 * second CA with a client certificate of its own. */
#include <fcntl.h>
#include <inttypes.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "check.h"
#include "corvid/backend.h"
#include "corvid/command_codec.h"
#include "corvid/context.h"
#include "corvid/device.h"
#include "corvid/node_protocol.h"
#include "corvid/proxy.h"
#include "corvid/rpc.h"
#include "corvid/sha256.h"
#include "raw_node_client.h"
#include "scratch_node.h"

#define STATUS_UNAUTHENTICATED 16

static const char TOKEN[] = "corvid-test-token-5f3a9c1e7b2d4680";
static char dir[256]; /* certificates and token files */

/* ---- a raw client (tests/support/raw_node_client.h) ------------------------------ */

static uint64_t send_hello(raw_client *c) { return raw_send_hello(c, CV_NODE_PROTOCOL_VERSION, 0, "security"); }

/* Says hello and expects the node's answer. */
static bool hello_ok(raw_client *c) {
    send_hello(c);
    Corvid__NodeMessage *m = raw_recv(c);
    bool ok = m && m->msg_case == CORVID__NODE_MESSAGE__MSG_HELLO && m->hello->device;
    if (m)
        corvid__node_message__free_unpacked(m, NULL);
    return ok;
}

static uint64_t send_compile_copy(raw_client *c, uint64_t list, uint64_t src, uint64_t dst, uint64_t size) {
    uint8_t *enc = NULL;
    size_t n = 0;
    raw_encode_copy(src, dst, size, &enc, &n);
    uint64_t seq = raw_send_compile(c, list, enc, n);
    free(enc);
    return seq;
}

/* Expects Completed for `ticket` with `code`, its message mentioning `needle`. */

#define BUF_ID(i) cv_handle_pack(CV_HANDLE_BUFFER, 1, 1, (i))
#define TEX_ID(i) cv_handle_pack(CV_HANDLE_TEXTURE, 1, 1, (i))
#define LIST_ID(i) cv_handle_pack(CV_HANDLE_CMDLIST, 1, 1, (i))

static cv_resource_desc buffer_of(uint64_t size) {
    return (cv_resource_desc){ .type = CV_HANDLE_BUFFER, .buffer = { .size = size } };
}

/* A render-free session: create a buffer, write it, read the bytes back. */
static bool roundtrip(raw_client *c) {
    if (!hello_ok(c))
        return false;
    cv_resource_desc b = buffer_of(64);
    EXPECT_REPLY(c, raw_send_create(c, BUF_ID(1), &b), CV_OK, NULL);
    uint8_t data[64], back[64] = { 0 };
    for (int i = 0; i < 64; i++)
        data[i] = (uint8_t)(i * 7 + 1);
    raw_send_write(c, BUF_ID(1), 0, data, sizeof(data));
    return raw_read_back(c, BUF_ID(1), sizeof(back), back) && memcmp(back, data, sizeof(data)) == 0;
}

/* Info over the rpc layer: the gRPC status (-1 if the call never started). */
static int info_status(const char *endpoint, const cv_rpc_client_config *cc, char *why, size_t cap) {
    cv_rpc_client *client;
    if (cv_rpc_client_create(endpoint, cc, &client) != CV_OK) {
        snprintf(why, cap, "%s", cv_last_error());
        return -1;
    }
    uint8_t req[1];
    void *resp = NULL;
    size_t n = 0;
    int status = -1;
    if (cv_rpc_client_unary(client, CV_NODE_METHOD_INFO, req, 0, RAW_TIMEOUT_MS, &resp, &n, &status) != CV_OK)
        snprintf(why, cap, "%s", cv_last_error());
    else
        why[0] = 0;
    free(resp);
    cv_rpc_client_destroy(client);
    return status;
}

static int health_status(const char *endpoint, const cv_rpc_client_config *cc) {
    cv_rpc_client *client;
    if (cv_rpc_client_create(endpoint, cc, &client) != CV_OK)
        return -1;
    uint8_t req[1];
    void *resp = NULL;
    size_t n = 0;
    int status = -1;
    cv_rpc_client_unary(client, CV_HEALTH_METHOD_CHECK, req, 0, RAW_TIMEOUT_MS, &resp, &n, &status);
    free(resp);
    cv_rpc_client_destroy(client);
    return status;
}

/* ---- files ------------------------------------------------------------------------ */

static void path_of(char *out, size_t cap, const char *name) { snprintf(out, cap, "%s/%s", dir, name); }

static bool write_file(const char *name, const char *text) {
    char p[512];
    path_of(p, sizeof(p), name);
    FILE *f = fopen(p, "w");
    if (!f)
        return false;
    fputs(text, f);
    return fclose(f) == 0;
}

static char *read_whole(const char *path) {
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    char *text = calloc(1, 1 << 20);
    size_t n = text ? fread(text, 1, (1 << 20) - 1, f) : 0;
    (void)n;
    fclose(f);
    return text;
}

/* The certificates, by the openssl command. */
static bool make_certificates(void) {
    char script[4096];
    snprintf(script, sizeof(script),
             "set -e; cd '%s'\n"
             "key() { openssl genpkey -algorithm EC -pkeyopt ec_paramgen_curve:P-256 -out \"$1\" 2>/dev/null; }\n"
             "ca() { key $1.key; openssl req -x509 -new -key $1.key -out $1.pem -days 2 -subj \"/CN=$1\" "
             "-addext basicConstraints=critical,CA:TRUE -addext keyUsage=critical,keyCertSign,cRLSign; }\n"
             "leaf() {  # name ca days ext\n"
             "  key $1.key; openssl req -new -key $1.key -out $1.csr -subj \"/CN=$1\"\n"
             "  printf '%%s\\n' \"$4\" > $1.ext\n"
             "  openssl x509 -req -in $1.csr -CA $2.pem -CAkey $2.key -CAcreateserial -out $1.pem -days $3 "
             "-extfile $1.ext 2>/dev/null; }\n"
             "ca ca; ca other\n"
             "leaf server ca 2 'subjectAltName=IP:127.0.0.1,DNS:localhost'\n"
             "leaf expired ca -1 'subjectAltName=IP:127.0.0.1,DNS:localhost'\n"
             "leaf client ca 2 'extendedKeyUsage=clientAuth'\n"
             "leaf stranger other 2 'extendedKeyUsage=clientAuth'\n",
             dir);
    char p[512];
    path_of(p, sizeof(p), "make.sh");
    FILE *f = fopen(p, "w");
    if (!f)
        return false;
    fputs(script, f);
    fclose(f);
    char cmd[600];
    snprintf(cmd, sizeof(cmd), "sh '%s' >/dev/null", p);
    return system(cmd) == 0;
}

/* ---- tokens ----------------------------------------------------------------------- */

static void tokens(void) {
    /* The node's log goes to a file while it runs, to check what it says about refusals. */
    char log_path[512];
    path_of(log_path, sizeof(log_path), "node.log");
    int failures_before = check_failures;
    fflush(stderr);
    int saved = dup(2);
    int log_fd = open(log_path, O_WRONLY | O_CREAT | O_TRUNC, 0600);
    CHECK(saved >= 0 && log_fd >= 0);
    dup2(log_fd, 2);
    close(log_fd);

    scratch_node n;
    cv_node_config sec = { .token = TOKEN, .log_sessions = true };
    CHECK_OK(scratch_node_start_secured(&n, cv_mock_backend(), 1, &sec));

    raw_client c;
    /* No token. */
    raw_open_with(&c, n.endpoint, NULL, NULL, 0);
    send_hello(&c);
    EXPECT_END(&c, STATUS_UNAUTHENTICATED, "no 'authorization' metadata");
    raw_close(&c);
    /* A wrong token. */
    raw_open_with(&c, n.endpoint, &(cv_rpc_client_config){ .bearer_token = "guess" }, NULL, 0);
    send_hello(&c);
    EXPECT_END(&c, STATUS_UNAUTHENTICATED, "wrong token");
    raw_close(&c);
    /* The right length, one bit changed. */
    char flipped[sizeof(TOKEN)];
    memcpy(flipped, TOKEN, sizeof(TOKEN));
    flipped[10] ^= 1;
    raw_open_with(&c, n.endpoint, &(cv_rpc_client_config){ .bearer_token = flipped }, NULL, 0);
    send_hello(&c);
    EXPECT_END(&c, STATUS_UNAUTHENTICATED, "wrong token");
    raw_close(&c);
    /* An empty token, and a scheme that is not Bearer. */
    raw_open_with(&c, n.endpoint, NULL, &(cv_rpc_metadata){ "authorization", "Bearer " }, 1);
    send_hello(&c);
    EXPECT_END(&c, STATUS_UNAUTHENTICATED, "unauthenticated");
    raw_close(&c);
    char basic[128];
    snprintf(basic, sizeof(basic), "Basic %s", TOKEN);
    raw_open_with(&c, n.endpoint, NULL, &(cv_rpc_metadata){ "authorization", basic }, 1);
    send_hello(&c);
    EXPECT_END(&c, STATUS_UNAUTHENTICATED, "not 'Bearer <token>'");
    raw_close(&c);
    /* A client that has a token cannot add a second authorization. */
    cv_rpc_client *dup_client;
    CHECK_OK(cv_rpc_client_create(n.endpoint, &(cv_rpc_client_config){ .bearer_token = TOKEN }, &dup_client));
    cv_rpc_stream *dup_stream = NULL;
    CHECK_RESULT(cv_rpc_client_open(dup_client, CV_NODE_METHOD_SESSION, &(cv_rpc_metadata){ "authorization", basic },
                                    1, &dup_stream),
                 CV_ERROR_INVALID_ARGUMENT);
    cv_rpc_client_destroy(dup_client);
    /* Info needs the token too; health does not. */
    char why[1024];
    CHECK_EQ_INT(info_status(n.endpoint, NULL, why, sizeof(why)), STATUS_UNAUTHENTICATED);
    CHECK(strstr(why, "UNAUTHENTICATED") || strstr(why, "unauthenticated"));
    CHECK_EQ_INT(info_status(n.endpoint, &(cv_rpc_client_config){ .bearer_token = flipped }, why, sizeof(why)),
                 STATUS_UNAUTHENTICATED);
    CHECK_EQ_INT(info_status(n.endpoint, &(cv_rpc_client_config){ .bearer_token = TOKEN }, why, sizeof(why)), 0);
    CHECK_EQ_INT(health_status(n.endpoint, NULL), 0);

    /* The node kept serving: an authenticated session works. */
    raw_open_with(&c, n.endpoint, &(cv_rpc_client_config){ .bearer_token = TOKEN }, NULL, 0);
    CHECK(roundtrip(&c));
    raw_close(&c);

    /* The proxy backend, with the token (as corvid-render reads it from CORVID_NODE_TOKEN_FILE); and without it. */
    char token_file[512], bad_file[512], empty_file[512];
    CHECK(write_file("token", TOKEN) && write_file("bad-token", "guess\n") && write_file("empty-token", "\n"));
    path_of(token_file, sizeof(token_file), "token");
    path_of(bad_file, sizeof(bad_file), "bad-token");
    path_of(empty_file, sizeof(empty_file), "empty-token");
    cv_context *ctx;
    CHECK_OK(cv_context_create(NULL, &ctx));
    cv_device *dev = NULL;
    cv_device_desc desc = { .endpoint = n.endpoint };
    char token_text[1040];
    CHECK_OK(cv_rpc_read_token_file(bad_file, token_text, sizeof(token_text)));
    CHECK_OK(cv_proxy_configure(&(cv_proxy_options){ .bearer_token = token_text }));
    CHECK_RESULT(cv_device_create(ctx, cv_proxy_backend(), &desc, &dev), CV_ERROR_CONNECTION);
    CHECK(strstr(cv_last_error(), "unauthenticated") != NULL);
    CHECK_RESULT(cv_rpc_read_token_file(empty_file, token_text, sizeof(token_text)), CV_ERROR_MALFORMED);
    CHECK(strstr(cv_last_error(), "empty") != NULL);
    CHECK_OK(cv_rpc_read_token_file(token_file, token_text, sizeof(token_text)));
    CHECK_OK(cv_proxy_configure(&(cv_proxy_options){ .bearer_token = token_text }));
    CHECK_OK(cv_device_create(ctx, cv_proxy_backend(), &desc, &dev));
    if (dev)
        cv_device_destroy(dev);
    CHECK_OK(cv_proxy_configure(NULL));
    cv_context_destroy(ctx);

    cv_node_stats st = cv_node_get_stats(n.node);
    CHECK_EQ_INT(st.unauthenticated, 8); /* 5 sessions, 2 Info calls, 1 proxy device */
    CHECK_EQ_INT(scratch_node_wait_sessions(&n, 5000), 0);
    scratch_node_stop(&n);

    fflush(stderr);
    dup2(saved, 2);
    close(saved);
    /* Each refusal was logged with the peer; the token never was. */
    char *log = read_whole(log_path);
    CHECK(log != NULL);
    if (log && check_failures != failures_before)
        fprintf(stderr, "---- what the token checks wrote to stderr:\n%s----\n", log);
    if (log) {
        int refusals = 0;
        for (const char *p = log; (p = strstr(p, "refused /corvid.Node/")) != NULL; p++)
            refusals++;
        CHECK_EQ_INT(refusals, 8);
        CHECK(strstr(log, "refused /corvid.Node/Session from ipv4:127.0.0.1:") != NULL);
        CHECK(strstr(log, "refused /corvid.Node/Info from ipv4:127.0.0.1:") != NULL);
        CHECK(strstr(log, TOKEN) == NULL && strstr(log, flipped) == NULL);
        free(log);
    }
    CHECK_NOTHING_LIVE();
}

/* Loopback-only unless there is a token. */
static void listen_rules(void) {
    CHECK(cv_node_listen_is_local("127.0.0.1:7700"));
    CHECK(cv_node_listen_is_local("127.3.2.1:0"));
    CHECK(cv_node_listen_is_local("localhost:7700"));
    CHECK(cv_node_listen_is_local("[::1]:7700"));
    CHECK(cv_node_listen_is_local("unix:/tmp/corvid.sock"));
    CHECK(!cv_node_listen_is_local("0.0.0.0:7700"));
    CHECK(!cv_node_listen_is_local("[::]:7700"));
    CHECK(!cv_node_listen_is_local(":7700"));
    CHECK(!cv_node_listen_is_local("10.0.0.5:7700"));
    CHECK(!cv_node_listen_is_local("gpubox:7700"));
    CHECK(!cv_node_listen_is_local("128.0.0.1:7700"));

    scratch_node n;
    CHECK_RESULT(scratch_node_start_secured(&n, cv_mock_backend(), 1, &(cv_node_config){ .listen = "0.0.0.0:0" }),
                 CV_ERROR_INVALID_ARGUMENT);
    CHECK(strstr(cv_last_error(), "not loopback") && strstr(cv_last_error(), "--token-file"));
    CHECK_RESULT(scratch_node_start_secured(&n, cv_mock_backend(), 1,
                                            &(cv_node_config){ .listen = "127.0.0.1:0", .token = "" }),
                 CV_ERROR_INVALID_ARGUMENT);
    /* With a token it starts (binding all interfaces is fine; nothing connects there). */
    CHECK_OK(scratch_node_start_secured(&n, cv_mock_backend(), 1,
                                        &(cv_node_config){ .listen = "0.0.0.0:0", .token = TOKEN }));
    scratch_node_stop(&n);
    CHECK_NOTHING_LIVE();
}

/* ---- TLS ---------------------------------------------------------------------------- */

static char ca_pem[512], server_pem[512], server_key[512], expired_pem[512], expired_key[512];
static char client_pem[512], client_key[512], other_pem[512], stranger_pem[512], stranger_key[512];

/* Health/Check at `endpoint` in plaintext: the serving status (1 SERVING, 2 NOT_SERVING), or -status. */
static int plain_health(const char *endpoint, const char *method) {
    cv_rpc_client *client;
    int status = -1;
    void *resp = NULL;
    size_t resp_size = 0;
    if (cv_rpc_client_create(endpoint, NULL, &client) != CV_OK)
        return -100;
    cv_rpc_client_unary(client, method, "", 0, 5000, &resp, &resp_size, &status);
    int serving = status == 0 && resp_size == 2 && ((uint8_t *)resp)[0] == 0x08 ? ((uint8_t *)resp)[1] : -status;
    free(resp);
    cv_rpc_client_destroy(client);
    return serving;
}

/* A TLS node with a plaintext health port (--health-listen): probes that speak no TLS get the node's
 * health there, and nothing else. */
static void health_port(void) {
    scratch_node n;
    CHECK_OK(scratch_node_start_secured(&n, cv_mock_backend(), 1,
                                        &(cv_node_config){ .tls_cert_file = server_pem,
                                                           .tls_key_file = server_key,
                                                           .token = "health-port-token",
                                                           .health_listen = "127.0.0.1:0" }));
    if (!n.node)
        return;
    char health[64];
    snprintf(health, sizeof(health), "127.0.0.1:%d", cv_node_health_port(n.node));
    CHECK(cv_node_health_port(n.node) > 0 && cv_node_health_port(n.node) != cv_node_port(n.node));
    CHECK_EQ_INT(plain_health(health, CV_HEALTH_METHOD_CHECK), 1);
    CHECK_EQ_INT(plain_health(health, CV_NODE_METHOD_INFO), -CV_RPC_STATUS_UNIMPLEMENTED);
    CHECK_EQ_INT(plain_health(health, CV_NODE_METHOD_PEER_PIECE), -CV_RPC_STATUS_UNIMPLEMENTED);
    CHECK(plain_health(n.endpoint, CV_HEALTH_METHOD_CHECK) < 0); /* the main port speaks TLS only */
    cv_node_drain(n.node);
    CHECK_EQ_INT(plain_health(health, CV_HEALTH_METHOD_CHECK), 2);
    scratch_node_stop(&n);
    /* A health port that cannot be bound: the node does not start, and says which. */
    scratch_node a, b;
    CHECK_OK(
        scratch_node_start_secured(&a, cv_mock_backend(), 1, &(cv_node_config){ .health_listen = "127.0.0.1:0" }));
    if (a.node) {
        char taken[64];
        snprintf(taken, sizeof(taken), "127.0.0.1:%d", cv_node_health_port(a.node));
        CHECK_RESULT(scratch_node_start_secured(&b, cv_mock_backend(), 1,
                                                &(cv_node_config){ .health_listen = taken }),
                     CV_ERROR_CONNECTION);
        CHECK(strstr(cv_last_error(), "health port") != NULL);
        scratch_node_stop(&a);
    }
    CHECK_NOTHING_LIVE();
}

static void tls(void) {
    scratch_node n;
    CHECK_OK(
        scratch_node_start_secured(&n, cv_mock_backend(), 1,
                                   &(cv_node_config){ .tls_cert_file = server_pem, .tls_key_file = server_key }));
    char why[1024];
    /* Plaintext to a TLS listener: a connection error. */
    CHECK_EQ_INT(info_status(n.endpoint, NULL, why, sizeof(why)), CV_RPC_STATUS_UNAVAILABLE);
    /* The right CA: a session works. */
    cv_rpc_client_config good = { .tls_ca_file = ca_pem };
    CHECK_EQ_INT(info_status(n.endpoint, &good, why, sizeof(why)), 0);
    raw_client c;
    raw_open_with(&c, n.endpoint, &good, NULL, 0);
    CHECK(roundtrip(&c));
    raw_close(&c);
    /* The wrong CA: the handshake fails. */
    cv_rpc_client_config wrong = { .tls_ca_file = other_pem };
    CHECK_EQ_INT(info_status(n.endpoint, &wrong, why, sizeof(why)), CV_RPC_STATUS_UNAVAILABLE);
    raw_open_with(&c, n.endpoint, &wrong, NULL, 0);
    send_hello(&c);
    EXPECT_END(&c, CV_RPC_STATUS_UNAVAILABLE, NULL);
    raw_close(&c);
    /* Files that are missing or not PEM are clear errors at create. */
    cv_rpc_client *client;
    CHECK_RESULT(cv_rpc_client_create(n.endpoint, &(cv_rpc_client_config){ .tls_ca_file = "/nonexistent/ca.pem" },
                                      &client),
                 CV_ERROR_IO);
    CHECK(strstr(cv_last_error(), "/nonexistent/ca.pem") != NULL);
    char not_pem[512];
    CHECK(write_file("not.pem", "hello\n"));
    path_of(not_pem, sizeof(not_pem), "not.pem");
    CHECK_RESULT(cv_rpc_client_create(n.endpoint, &(cv_rpc_client_config){ .tls_ca_file = not_pem }, &client),
                 CV_ERROR_MALFORMED);
    CHECK_RESULT(cv_rpc_client_create(n.endpoint,
                                      &(cv_rpc_client_config){ .tls_ca_file = ca_pem, .tls_cert_file = client_pem },
                                      &client),
                 CV_ERROR_INVALID_ARGUMENT);

    /* The proxy backend over TLS (tls_ca_file; corvid-render's CORVID_NODE_TLS_CA): write and read bytes back. */
    cv_context *ctx;
    CHECK_OK(cv_context_create(NULL, &ctx));
    cv_device_desc desc = { .endpoint = n.endpoint };
    cv_device *dev = NULL;
    CHECK_OK(cv_proxy_configure(&(cv_proxy_options){ .tls_ca_file = other_pem }));
    CHECK_RESULT(cv_device_create(ctx, cv_proxy_backend(), &desc, &dev), CV_ERROR_CONNECTION);
    CHECK_OK(cv_proxy_configure(&(cv_proxy_options){ .tls_ca_file = ca_pem }));
    CHECK_OK(cv_device_create(ctx, cv_proxy_backend(), &desc, &dev));
    if (dev) {
        cv_buffer b;
        CHECK_OK(cv_buffer_create(ctx, &(cv_buffer_desc){ .size = 256, .label = "tls" }, &b));
        CHECK_OK(cv_device_load(dev, (cv_handle){ b.id }));
        uint8_t data[256], back[256] = { 0 };
        for (int i = 0; i < 256; i++)
            data[i] = (uint8_t)(255 - i);
        CHECK_OK(cv_device_write_buffer(dev, b, 0, sizeof(data), data));
        CHECK_OK(cv_device_read_buffer(dev, b, 0, sizeof(back), back));
        CHECK(memcmp(data, back, sizeof(data)) == 0);
        cv_destroy(ctx, (cv_handle){ b.id });
        cv_device_destroy(dev);
    }
    CHECK_OK(cv_proxy_configure(NULL));
    cv_context_destroy(ctx);
    CHECK_EQ_INT(scratch_node_wait_sessions(&n, 5000), 0);
    scratch_node_stop(&n);

    /* An expired server certificate is refused by the client. */
    CHECK_OK(
        scratch_node_start_secured(&n, cv_mock_backend(), 1,
                                   &(cv_node_config){ .tls_cert_file = expired_pem, .tls_key_file = expired_key }));
    CHECK_EQ_INT(info_status(n.endpoint, &good, why, sizeof(why)), CV_RPC_STATUS_UNAVAILABLE);
    scratch_node_stop(&n);

    /* Mutual TLS: a client certificate of the node's client CA is needed. */
    CHECK_OK(scratch_node_start_secured(&n, cv_mock_backend(), 1,
                                        &(cv_node_config){ .tls_cert_file = server_pem,
                                                           .tls_key_file = server_key,
                                                           .tls_client_ca_file = ca_pem,
                                                           .token = TOKEN }));
    cv_rpc_client_config none = { .tls_ca_file = ca_pem, .bearer_token = TOKEN };
    cv_rpc_client_config stranger = {
        .tls_ca_file = ca_pem, .tls_cert_file = stranger_pem, .tls_key_file = stranger_key, .bearer_token = TOKEN
    };
    cv_rpc_client_config member = {
        .tls_ca_file = ca_pem, .tls_cert_file = client_pem, .tls_key_file = client_key, .bearer_token = TOKEN
    };
    CHECK_EQ_INT(info_status(n.endpoint, &none, why, sizeof(why)), CV_RPC_STATUS_UNAVAILABLE);
    CHECK_EQ_INT(info_status(n.endpoint, &stranger, why, sizeof(why)), CV_RPC_STATUS_UNAVAILABLE);
    raw_open_with(&c, n.endpoint, &stranger, NULL, 0);
    send_hello(&c);
    EXPECT_END(&c, CV_RPC_STATUS_UNAVAILABLE, NULL);
    raw_close(&c);
    CHECK_EQ_INT(info_status(n.endpoint, &member, why, sizeof(why)), 0);
    raw_open_with(&c, n.endpoint, &member, NULL, 0);
    CHECK(roundtrip(&c));
    raw_close(&c);
    CHECK_EQ_INT(cv_node_get_stats(n.node).unauthenticated, 0);
    CHECK_EQ_INT(scratch_node_wait_sessions(&n, 5000), 0);
    scratch_node_stop(&n);

    /* A node with a certificate and no key (or a client CA without TLS) does not start. */
    CHECK_RESULT(scratch_node_start_secured(&n, cv_mock_backend(), 1,
                                            &(cv_node_config){ .tls_cert_file = server_pem }),
                 CV_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(scratch_node_start_secured(&n, cv_mock_backend(), 1,
                                            &(cv_node_config){ .tls_client_ca_file = ca_pem }),
                 CV_ERROR_INVALID_ARGUMENT);
    CHECK_NOTHING_LIVE();
}

/* ---- quotas ------------------------------------------------------------------------- */

/* The mock backend with a gate on completion: submissions stay in flight until the gate opens. */
static cv_backend gated;
static atomic_bool gate_open;

static cv_result gated_wait(cv_backend_device *bd, uint64_t ticket, uint64_t timeout_ns) {
    if (!atomic_load(&gate_open)) {
        usleep((useconds_t)(timeout_ns / 1000 < 20000 ? timeout_ns / 1000 : 20000));
        if (!atomic_load(&gate_open))
            return cv_error(CV_ERROR_TIMEOUT, "gated mock: closed");
    }
    return cv_mock_backend()->wait(bd, ticket, timeout_ns);
}

static uint64_t gated_completed(cv_backend_device *bd) {
    return atomic_load(&gate_open) ? cv_mock_backend()->completed(bd) : 0;
}

static void quotas(void) {
    gated = *cv_mock_backend();
    gated.wait = gated_wait;
    gated.completed = gated_completed;
    atomic_store(&gate_open, true);

    scratch_node n;
    cv_node_config sec = { .quota = { .memory_bytes = 4096, .resources = 4, .inflight = 2, .upload_bytes = 1000 } };
    CHECK_OK(scratch_node_start_secured(&n, &gated, 1, &sec));
    raw_client c;
    raw_open_with(&c, n.endpoint, NULL, NULL, 0);
    CHECK(hello_ok(&c));

    /* Memory: 4096 bytes of buffers and textures. */
    cv_resource_desc b3k = buffer_of(3072), b1k = buffer_of(1024), b1 = buffer_of(1);
    cv_resource_desc tex = { .type = CV_HANDLE_TEXTURE,
                             .texture = { .width = 16, .height = 16, .format = CV_FORMAT_RGBA8_UNORM } }; /* 1024 */
    EXPECT_REPLY(&c, raw_send_create(&c, BUF_ID(1), &b3k), CV_OK, NULL);
    EXPECT_REPLY(&c, raw_send_create(&c, TEX_ID(1), &tex), CV_OK, NULL);
    EXPECT_REPLY(&c, raw_send_create(&c, BUF_ID(2), &b1), CV_ERROR_LIMIT_EXCEEDED, "--quota-memory 4096");
    EXPECT_REPLY(&c, raw_send_create(&c, BUF_ID(2), &b1), CV_ERROR_LIMIT_EXCEEDED,
                 "holds 4096 bytes of device memory");
    /* Destroying gives the memory back. */
    raw_send_destroy(&c, TEX_ID(1));
    EXPECT_REPLY(&c, raw_send_create(&c, BUF_ID(2), &b1k), CV_OK, NULL);
    /* Resources: 4 in all (3 now: BUF 1, BUF 2, and the list below). */
    EXPECT_REPLY(&c, raw_send_create(&c, LIST_ID(1), NULL), CV_OK, NULL);
    raw_send_destroy(&c, BUF_ID(2));
    cv_resource_desc b512 = buffer_of(512), b256 = buffer_of(256);
    EXPECT_REPLY(&c, raw_send_create(&c, BUF_ID(3), &b512), CV_OK, NULL);
    EXPECT_REPLY(&c, raw_send_create(&c, BUF_ID(4), &b256), CV_OK, NULL);
    EXPECT_REPLY(&c, raw_send_create(&c, BUF_ID(5), &b1), CV_ERROR_LIMIT_EXCEEDED, "--quota-resources 4");
    raw_send_destroy(&c, LIST_ID(1)); /* a list counts as a resource, and has no bytes */
    EXPECT_REPLY(&c, raw_send_create(&c, BUF_ID(5), &b1), CV_OK, NULL);
    /* The session still works. */
    uint8_t data[256], back[256];
    memset(data, 0x5a, sizeof(data));
    raw_send_write(&c, BUF_ID(4), 0, data, sizeof(data));
    CHECK(raw_read_back(&c, BUF_ID(4), sizeof(back), back) && memcmp(back, data, sizeof(data)) == 0);

    /* Upload cache bytes: 1000 per session; a blob past it is refused in full and its chunks dropped. */
    uint8_t blob[600], sha_a[32], sha_b[32];
    memset(blob, 1, sizeof(blob));
    CHECK_OK(cv_sha256(blob, sizeof(blob), sha_a));
    raw_send_chunk(&c, sha_a, sizeof(blob), 0, blob, sizeof(blob));
    EXPECT_REPLY(&c, raw_send_blob_write(&c, BUF_ID(1), sha_a), CV_OK, NULL);
    memset(blob, 2, sizeof(blob));
    CHECK_OK(cv_sha256(blob, sizeof(blob), sha_b));
    uint64_t first = raw_send_chunk(&c, sha_b, sizeof(blob), 0, blob, 300);
    raw_send_chunk(&c, sha_b, sizeof(blob), 300, blob + 300, 300); /* dropped, no second answer */
    EXPECT_REPLY(&c, first, CV_ERROR_LIMIT_EXCEEDED, "--quota-upload 1000");
    EXPECT_REPLY(&c, raw_send_blob_write(&c, BUF_ID(1), sha_b), CV_ERROR_NOT_FOUND, "not in the node's cache");
    /* A blob the cache already has costs nothing. */
    memset(blob, 1, sizeof(blob));
    raw_send_chunk(&c, sha_a, sizeof(blob), 0, blob, sizeof(blob));
    EXPECT_REPLY(&c, raw_send_blob_write(&c, BUF_ID(1), sha_a), CV_OK, NULL);
    CHECK(raw_read_back(&c, BUF_ID(4), sizeof(back), back) && memcmp(back, data, sizeof(data)) == 0);

    cv_rpc_stream_close_send(c.stream);
    EXPECT_END(&c, CV_RPC_STATUS_OK, NULL);
    raw_close(&c);
    CHECK_EQ_INT(cv_node_get_stats(n.node).quota_refusals, 4);

    /* Lists in flight: 2, while the device holds them; a new session has its own quotas. */
    raw_open_with(&c, n.endpoint, NULL, NULL, 0);
    CHECK(hello_ok(&c));
    EXPECT_REPLY(&c, raw_send_create(&c, BUF_ID(1), &b256), CV_OK, NULL);
    EXPECT_REPLY(&c, raw_send_create(&c, BUF_ID(2), &b256), CV_OK, NULL);
    EXPECT_REPLY(&c, raw_send_create(&c, LIST_ID(1), NULL), CV_OK, NULL);
    EXPECT_REPLY(&c, raw_send_create(&c, LIST_ID(2), NULL), CV_OK, NULL);
    raw_send_write(&c, BUF_ID(1), 0, data, sizeof(data));
    send_compile_copy(&c, LIST_ID(1), BUF_ID(1), BUF_ID(2), 256);
    send_compile_copy(&c, LIST_ID(2), BUF_ID(1), BUF_ID(2), 128);
    atomic_store(&gate_open, false);
    raw_send_submit(&c, LIST_ID(1), 1);
    raw_send_submit(&c, LIST_ID(2), 2);
    raw_send_submit(&c, LIST_ID(1), 3); /* refused; reported in ticket order */
    /* An answer to a later request: the node has handled the submits (their reports wait for the gate). */
    EXPECT_REPLY(&c, raw_send_create(&c, BUF_ID(1), &b256), CV_ERROR_ALREADY_LOADED, NULL);
    atomic_store(&gate_open, true);
    EXPECT_COMPLETED(&c, 1, CV_OK, NULL);
    EXPECT_COMPLETED(&c, 2, CV_OK, NULL);
    EXPECT_COMPLETED(&c, 3, CV_ERROR_LIMIT_EXCEEDED, "--quota-inflight 2");
    raw_send_submit(&c, LIST_ID(1), 4); /* the session goes on */
    EXPECT_COMPLETED(&c, 4, CV_OK, NULL);
    memset(back, 0, sizeof(back));
    CHECK(raw_read_back(&c, BUF_ID(2), 256, back) && memcmp(back, data, 256) == 0);
    cv_rpc_stream_close_send(c.stream);
    EXPECT_END(&c, CV_RPC_STATUS_OK, NULL);
    raw_close(&c);
    CHECK_EQ_INT(cv_node_get_stats(n.node).quota_refusals, 5);
    CHECK_EQ_INT(scratch_node_wait_sessions(&n, 5000), 0);
    scratch_node_stop(&n);

    /* Quotas out of range do not start a node. */
    CHECK_RESULT(scratch_node_start_secured(&n, cv_mock_backend(), 1,
                                            &(cv_node_config){
                                                .quota = { .inflight = CV_NODE_MAX_QUOTA_INFLIGHT + 1 } }),
                 CV_ERROR_OUT_OF_RANGE);
    CHECK_NOTHING_LIVE();
}

/* The proxy keeps within the quotas the node announced (HelloReply.quotas): submissions past the in-flight
 * quota wait for earlier ones instead of being refused by the node (which would fail the device's later
 * calls), and an upload past the upload quota is refused locally, the device going on. */
typedef struct gate_opener {
    scratch_node *node;
    uint64_t submissions_seen; /* by the node while the gate was closed */
} gate_opener;

static void *open_gate_later(void *arg) {
    gate_opener *g = arg;
    usleep(300 * 1000);
    g->submissions_seen = cv_node_get_stats(g->node->node).submissions;
    atomic_store(&gate_open, true);
    return NULL;
}

static void proxy_quotas(void) {
    gated = *cv_mock_backend();
    gated.wait = gated_wait;
    gated.completed = gated_completed;
    atomic_store(&gate_open, true);
    scratch_node n;
    cv_node_config sec = { .quota = { .inflight = 2, .upload_bytes = 1u << 20 } };
    CHECK_OK(scratch_node_start_secured(&n, &gated, 1, &sec));
    cv_context *ctx;
    cv_device *dev = NULL;
    CHECK_OK(cv_context_create(NULL, &ctx));
    CHECK_OK(cv_device_create(ctx, cv_proxy_backend(), &(cv_device_desc){ .endpoint = n.endpoint }, &dev));
    if (dev) {
        cv_buffer src, dst, big;
        CHECK_OK(cv_buffer_create(ctx, &(cv_buffer_desc){ .size = 4096 }, &src));
        CHECK_OK(cv_buffer_create(ctx, &(cv_buffer_desc){ .size = 4096 }, &dst));
        CHECK_OK(cv_buffer_create(ctx, &(cv_buffer_desc){ .size = 2u << 20 }, &big));
        CHECK_OK(cv_device_load(dev, cv_any(src)));
        CHECK_OK(cv_device_load(dev, cv_any(dst)));
        CHECK_OK(cv_device_load(dev, cv_any(big)));
        uint8_t bytes[4096], back[4096];
        for (int i = 0; i < 4096; i++)
            bytes[i] = (uint8_t)(i * 13);
        CHECK_OK(cv_device_write_buffer(dev, src, 0, sizeof(bytes), bytes));
        cv_cmdlist list;
        cv_command_list *l;
        CHECK_OK(cv_cmdlist_create(ctx, &list));
        CHECK_OK(cv_cmdlist_begin(ctx, list, &l));
        cv_cmd_copy_buffer(l, CV_QUEUE_COPY, &(cv_copy_buffer_args){ .src = src, .dst = dst, .size = 4096 });
        CHECK_OK(cv_command_list_end(l));
        /* Nothing completes until the gate opens: the node sees 2 submissions, the proxy holds the rest. */
        atomic_store(&gate_open, false);
        gate_opener g = { .node = &n };
        pthread_t opener;
        CHECK(pthread_create(&opener, NULL, open_gate_later, &g) == 0);
        uint64_t ticket = 0;
        for (int i = 0; i < 20; i++) /* no waits */
            CHECK_OK(cv_device_submit(dev, list, &ticket));
        pthread_join(opener, NULL);
        CHECK(g.submissions_seen <= 2);
        CHECK_OK(cv_device_wait(dev, ticket, 10ull * 1000 * 1000 * 1000));
        CHECK_OK(cv_device_read_buffer(dev, dst, 0, sizeof(back), back));
        CHECK(memcmp(back, bytes, sizeof(back)) == 0);
        CHECK_EQ_INT(cv_node_get_stats(n.node).quota_refusals, 0);

        uint8_t *two = calloc(1, 2u << 20);
        CHECK_RESULT(cv_device_write_buffer(dev, big, 0, 2u << 20, two), CV_ERROR_LIMIT_EXCEEDED);
        CHECK(strstr(cv_last_error(), "--quota-upload") && strstr(cv_last_error(), "refused here"));
        free(two);
        CHECK_EQ_INT(cv_node_get_stats(n.node).quota_refusals, 0);
        CHECK_OK(cv_device_write_buffer(dev, dst, 0, 16, bytes + 100)); /* the device goes on */
        CHECK_OK(cv_device_read_buffer(dev, dst, 0, 16, back));
        CHECK(memcmp(back, bytes + 100, 16) == 0);
    }
    cv_context_destroy(ctx);
    CHECK_EQ_INT(scratch_node_wait_sessions(&n, 5000), 0);
    scratch_node_stop(&n);
    CHECK_NOTHING_LIVE();
}

int main(void) {
    snprintf(dir, sizeof(dir), "/tmp/corvid-security-test-XXXXXX");
    bool made = mkdtemp(dir) != NULL; /* the certificates' directory */
    CHECK(made);
    if (!made)
        return check_report("node_security");
    bool certs = make_certificates();
    CHECK(certs);
    path_of(ca_pem, sizeof(ca_pem), "ca.pem");
    path_of(other_pem, sizeof(other_pem), "other.pem");
    path_of(server_pem, sizeof(server_pem), "server.pem");
    path_of(server_key, sizeof(server_key), "server.key");
    path_of(expired_pem, sizeof(expired_pem), "expired.pem");
    path_of(expired_key, sizeof(expired_key), "expired.key");
    path_of(client_pem, sizeof(client_pem), "client.pem");
    path_of(client_key, sizeof(client_key), "client.key");
    path_of(stranger_pem, sizeof(stranger_pem), "stranger.pem");
    path_of(stranger_key, sizeof(stranger_key), "stranger.key");

    tokens();
    listen_rules();
    if (certs) {
        tls();
        health_port();
    }
    quotas();
    proxy_quotas();

    char cmd[300];
    snprintf(cmd, sizeof(cmd), "rm -rf '%s'", dir);
    if (system(cmd) != 0)
        fprintf(stderr, "could not remove %s\n", dir);
    return check_report("node_security");
}
