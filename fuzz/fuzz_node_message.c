/* libFuzzer target: one corvid-node session fed untrusted client messages.
 *
 * The session code is the node's own (server/node/session.c and metrics.c,
 * compiled in); only the gRPC stream under it is replaced by the
 * input (fuzz_input.h), so everything the node does with a client's bytes runs:
 * corvid.ClientMessage unpacking into the size-limited arena, the per-message
 * checks, handle translation, content-store uploads, command-list decoding, the
 * handle mapping and re-encoding, and validation and compilation against a mock
 * device. Answers the node sends are packed and dropped. The content store (in a
 * temporary directory, 64 MiB) and the metrics registry live across inputs, as
 * they do across a node's sessions.
 *
 *   scripts/fuzz.sh 60       (builds build-fuzz/ with clang, runs 60 s on fuzz/corpus) */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "fuzz_input.h"
#include "node_internal.h"
#include "node_log.h"
#include "peer.h"
#include "peer_members.h"

/* ---- the stream: the fuzz input instead of gRPC ----------------------------- */

struct cv_rpc_stream {
    const uint8_t *data;
    size_t size, pos;
};

cv_result cv_rpc_stream_recv(cv_rpc_stream *s, uint32_t timeout_ms, uint8_t **data, size_t *size) {
    (void)timeout_ms;
    *data = NULL;
    *size = 0;
    if (s->size - s->pos < 2)
        return CV_OK; /* the client closed its side */
    size_t n = (size_t)s->data[s->pos] | (size_t)s->data[s->pos + 1] << 8;
    s->pos += 2;
    if (n > s->size - s->pos)
        n = s->size - s->pos;
    uint8_t *copy = malloc(n ? n : 1); /* the session frees it */
    if (!copy)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "fuzz stream");
    memcpy(copy, s->data + s->pos, n);
    s->pos += n;
    *data = copy;
    *size = n;
    return CV_OK;
}

cv_result cv_rpc_stream_send_owned(cv_rpc_stream *s, void *data, size_t size) {
    (void)s;
    (void)size;
    free(data);
    return CV_OK;
}

void cv_rpc_stream_finish(cv_rpc_stream *s, int status, const char *message) {
    (void)s;
    (void)status;
    (void)message;
}

const char *cv_rpc_stream_peer(cv_rpc_stream *s) {
    (void)s;
    return "fuzz";
}

/* ---- node-to-node pushes: no network ------------------------------------------- */
/* peer.c (compiled in) sends a PushTransfer's region to the destination node
 * named by the client; here no node is reachable, as if the destination were
 * down: the sender thread's connection fails and the push is counted as failed,
 * the node's path for an unreachable peer. */
cv_result cv_rpc_client_create(const char *target, const cv_rpc_client_config *config, cv_rpc_client **out) {
    (void)config;
    *out = NULL;
    return cv_error(CV_ERROR_CONNECTION, "fuzz: node '%.64s' is not reachable (no network in the fuzzer)", target);
}

void cv_rpc_client_destroy(cv_rpc_client *c) { (void)c; }

cv_result cv_rpc_client_unary(cv_rpc_client *c, const char *method, const void *request, size_t size,
                              uint32_t timeout_ms, void **response, size_t *response_size, int *status) {
    (void)c, (void)request, (void)size, (void)timeout_ms;
    *response = NULL;
    *response_size = 0;
    *status = 14; /* UNAVAILABLE */
    return cv_error(CV_ERROR_CONNECTION, "fuzz: %s: no network in the fuzzer", method);
}

/* metrics.c renders the node's stats through this (node.c is not linked); the
 * fuzzer never renders them. */
cv_node_stats cv_node_get_stats(cv_node *node) {
    (void)node;
    return (cv_node_stats){ 0 };
}

/* node.c's memory accounting, as node.c does it (node.c is not linked). */
cv_result cv_node_memory_reserve(cv_node *n, uint64_t bytes) {
    if (bytes > n->memory_limit - atomic_load(&n->memory_used))
        return cv_error(CV_ERROR_LIMIT_EXCEEDED, "fuzz: node memory limit of %llu bytes",
                        (unsigned long long)n->memory_limit);
    atomic_fetch_add(&n->memory_used, bytes);
    return CV_OK;
}

void cv_node_memory_release(cv_node *n, uint64_t bytes) { atomic_fetch_sub(&n->memory_used, bytes); }

/* The mock completes every submission at once, so no session abandons its device. */
void cv_node_keep_abandoned(cv_context *ctx) {
    (void)ctx;
    fprintf(stderr, "fuzz: a session abandoned its device on the mock backend\n");
    abort();
}

/* ---- the node ------------------------------------------------------------------ */

int LLVMFuzzerInitialize(int *argc, char ***argv);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static cv_node node;
static cv_node_device_spec device;
static char cache_dir[] = "/tmp/corvid-fuzz-cache-XXXXXX";

static void remove_cache(void) {
    if (node.store)
        cv_content_store_close(node.store);
    char cmd[128];
    snprintf(cmd, sizeof(cmd), "rm -rf '%s'", cache_dir);
    if (system(cmd) != 0)
        fprintf(stderr, "fuzz: could not remove %s\n", cache_dir);
}

int LLVMFuzzerInitialize(int *argc, char ***argv) {
    (void)argc;
    (void)argv;
    device.backend = cv_mock_backend();
    snprintf(device.label, sizeof(device.label), "mock0");
    node.devices = &device;
    node.config.devices = &device;
    node.config.device_count = 1;
    node.config.idle_timeout_ms = 1000;
    node.config.peer_deadline_ms = 50; /* an AwaitTransfer no peer will answer gives up soon */
    node.config.log_sessions = getenv("CORVID_FUZZ_LOG") != NULL; /* the session's own log lines */
    node.config.name = node.name;
    snprintf(node.name, sizeof(node.name), "fuzz");
    node.device_info = calloc(1, sizeof(*node.device_info));
    node.metrics = cv_node_metrics_create(1);
    node.memory_limit = 1ull << 30;
    node_log_init(&node.log);
    if (!mkdtemp(cache_dir) || !node.device_info || !node.metrics ||
        cv_content_store_open(cache_dir, 64ull << 20, &node.store) != CV_OK ||
        peer_members_create(NULL, "fuzz: peers", true, &node.members) != CV_OK ||
        peer_state_create(&node, &node.peer) != CV_OK) {
        fprintf(stderr, "fuzz: cannot set up the node: %s\n", cv_last_error());
        abort();
    }
    atexit(remove_cache);
    return 0;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    cv_rpc_stream stream = { .data = data, .size = size };
    cv_node_session_run(&node, &stream);
    /* Whatever the input, the session freed everything it made. */
    if (cv_live_contexts() != 0 || cv_live_devices() != 0 || atomic_load(&node.sessions_active) != 0) {
        fprintf(stderr, "fuzz: session left %u contexts, %u devices, %u sessions live\n", cv_live_contexts(),
                cv_live_devices(), (unsigned)atomic_load(&node.sessions_active));
        abort();
    }
    return 0;
}
