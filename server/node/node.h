/* corvid-node: serves a machine's devices to remote clients over gRPC.
 *
 * A node owns a list of devices (real GPUs, virtual GPUs, or mock devices), a
 * content-addressed cache of uploaded data shared by every session, and a gRPC
 * server (through the thin layer of corvid/rpc.h). Each client session is one
 * bidirectional stream (proto/node.proto): it gets its own context, handle table
 * and device instance, so nothing of one session is reachable from another, and
 * everything it held is freed when the stream ends, however it ends. The node
 * checks every message and every command list itself; a bad one is answered
 * with a clear error and the node goes on serving.
 *
 *     cv_node_device_spec dev = { .backend = cv_mock_backend(), .label = "mock0" };
 *     cv_node_config config = { .listen = "127.0.0.1:0", .devices = &dev, .device_count = 1,
 *                               .cache_dir = "/tmp/cache" };
 *     cv_node *node;
 *     if (cv_node_start(&config, &node) == CV_OK) {
 *         printf("port %d\n", cv_node_port(node));
 *         ...
 *         cv_node_drain(node);          // SIGTERM: refuse new sessions
 *         cv_node_stop(node, 30000);    // let running sessions finish, then stop
 *     }
 *
 * Thread-safe: sessions run on their own threads; the calls above may come from
 * any thread.
 *
 * Memory: every session has its own device instance (on lavapipe, a VkDevice
 * with its own threads and several MiB of heap), so a burst of sessions grows
 * the heap by that much per session. glibc keeps what they free in its
 * per-thread arenas, so after each session ends the node hands the heap's free
 * pages back to the system (malloc_trim(0); one trim at a time, and one more if
 * sessions ended meanwhile): 256 sessions leave the resident set where it was
 * (docs/node.md, "Memory"). */
#ifndef CORVID_NODE_H
#define CORVID_NODE_H

#include "corvid/device.h"

typedef struct cv_node cv_node;

/* One device the node serves: a backend and the adapter to open on it. */
typedef struct cv_node_device_spec {
    const cv_backend *backend;
    char adapter[64];            /* as cv_device_desc.adapter ("" = backend default) */
    char label[CV_LABEL_MAX];    /* the node's name for it ("gpu0") */
    const void *backend_options; /* as cv_device_desc.backend_options; kept by the caller while the node runs */
} cv_node_device_spec;

/* What one session may hold at once (docs/node.md, "Security"). A request past a quota is refused with
 * CV_ERROR_LIMIT_EXCEEDED and a message naming the quota and its limit; it changes nothing and the session
 * goes on. 0 = the default. */
typedef struct cv_node_quota {
    uint64_t memory_bytes; /* device memory created: buffer sizes + texture texels + acceleration structures
                                [CV_NODE_DEFAULT_QUOTA_MEMORY] */
    uint32_t resources; /* live resources of every type, command lists included [CV_NODE_DEFAULT_QUOTA_RESOURCES] */
    uint32_t inflight;  /* lists submitted and not yet completed [CV_NODE_DEFAULT_QUOTA_INFLIGHT], at most
                                CV_NODE_MAX_QUOTA_INFLIGHT */
    uint64_t upload_bytes; /* bytes the session adds to the content store, over its life
                                [CV_NODE_DEFAULT_QUOTA_UPLOAD] */
} cv_node_quota;

#define CV_NODE_DEFAULT_QUOTA_MEMORY (16ull << 30)
#define CV_NODE_DEFAULT_QUOTA_RESOURCES 65536u
#define CV_NODE_DEFAULT_QUOTA_INFLIGHT 256u
#define CV_NODE_MAX_QUOTA_INFLIGHT 1024u
#define CV_NODE_DEFAULT_QUOTA_UPLOAD (8ull << 30)

typedef struct cv_node_config {
    const char *listen; /* "host:port"; port 0 picks a free one */
    const char *name;   /* reported to clients; NULL = the host name */
    const cv_node_device_spec *devices;
    uint32_t device_count;    /* 1..CV_MAX_DEVICES */
    bool validation;          /* API validation on session devices */
    const char *cache_dir;    /* content store directory (created) */
    uint64_t cache_bytes;     /* content store size limit; 0 = 4 GiB; less than CV_NODE_MIN_CACHE_BYTES is
                                 refused at start (a blob larger than the limit is refused per blob) */
    uint32_t idle_timeout_ms; /* a session with no message for this long ends; 0 = 300 s */
    /* The watchdog: a submission that has not completed this long after the one before it did ends its
       session with DEADLINE_EXCEEDED, and the session's device is abandoned (leaked: its GPU may still run
       that work; counted in devices_abandoned). Other sessions and the drain go on. 0 =
       CV_NODE_DEFAULT_SUBMIT_TIMEOUT_MS. */
    uint32_t submit_timeout_ms;
    uint32_t max_sessions; /* concurrent sessions; 0 = 256 */
    bool log_sessions;     /* one line per session start/end, per error and per refused call on stderr */
    /* Where those lines go: each line without its newline, escaped (client-supplied text cannot forge a line or
       send terminal escapes) and rate-limited per kind (node_log.h). Called from session threads, so it must be
       thread-safe. NULL = the process's log (corvid/log.h), origin "node", level CV_LOG_INFO. */
    void (*log_sink)(const char *line, void *user);
    void *log_user;

    /* Security. token: NULL = none; else every Session stream and Info call must carry the initial metadata
       "authorization: Bearer <token>" (health checks stay open); others are refused with UNAUTHENTICATED and
       logged with their peer address. Only the token's SHA-256 is kept, compared in constant time. A node
       listening on anything but loopback (127.0.0.0/8, ::1, localhost) or a unix: socket refuses to start
       without one. */
    const char *token;
    const char *tls_cert_file, *tls_key_file; /* TLS (PEM files): both or neither */
    const char *tls_client_ca_file;           /* mutual TLS: clients need a certificate signed by this CA */
    cv_node_quota quota;
    /* Device memory all sessions together may hold (buffer sizes + texture texels + acceleration structures,
       as the per-session quota counts them): a create that would take the node past it is refused with
       CV_ERROR_LIMIT_EXCEEDED naming this limit, whatever the session's own quota says. 0 = the machine's
       physical memory (CV_NODE_FALLBACK_MEMORY_LIMIT where it cannot be read). */
    uint64_t memory_bytes;

    /* Clusters (docs/node.md, "Clusters"): node-to-node transfers. peer_token: the bearer token this node
       presents to the nodes it sends partitions to (NULL = none; corvid-node uses its own --token-file, so a
       cluster shares one token); peer_tls_ca_file: TLS to those nodes, trusting this CA (NULL = plaintext).
       peer_deadline_ms: how long a session's AwaitTransfer waits for a peer's data, and a piece's send may
       take [CV_NODE_DEFAULT_PEER_DEADLINE_MS]; peer_keepalive_ms: keepalive ping interval (and timeout) of
       the channels to peers (0 = the rpc layer's 10 s + 5 s). */
    const char *peer_token;
    const char *peer_tls_ca_file;
    /* The cluster's members: the only nodes this node sends transfers to (PushTransfer.destination), as
       comma-separated "host:port" (names are compared in lower case and never resolved before the check; see
       cv_node_check_peers). NULL: a node listening on loopback or a unix socket sends to loopback addresses
       only, any other node to none. A push elsewhere is answered CV_ERROR_INVALID_ARGUMENT before any
       connection. */
    const char *peers;
    uint32_t peer_deadline_ms;
    uint32_t peer_keepalive_ms;

    /* A second, plaintext port that serves only grpc.health.v1 Health/Check ("host:port", port 0 picks a free
       one; NULL = none), for probes that cannot speak TLS (Kubernetes' grpc probes) next to a TLS port. It
       says what the main port's health says (NOT_SERVING while draining); everything else there is
       UNIMPLEMENTED. */
    const char *health_listen;
} cv_node_config;

#define CV_NODE_DEFAULT_PEER_DEADLINE_MS 10000u
/* The smallest content store a node starts with: less could not hold one scene's geometry, and every
   render would fail on its first large upload (docs/node.md, "Content store"). */
#define CV_NODE_MIN_CACHE_BYTES (16ull << 20)
#define CV_NODE_FALLBACK_MEMORY_LIMIT (32ull << 30)
#define CV_NODE_DEFAULT_SUBMIT_TIMEOUT_MS 60000u

typedef struct cv_node_stats {
    uint64_t sessions_started, sessions_active;
    uint64_t messages_in, bytes_in, bytes_out;
    uint64_t submissions, errors;
    uint64_t cache_hits, cache_misses, cache_bytes;
    uint64_t unauthenticated;            /* calls refused for a missing or wrong token */
    uint64_t quota_refusals;             /* requests refused by a session quota or the node's memory limit */
    uint64_t memory_bytes, memory_limit; /* device memory the sessions hold now, and config.memory_bytes */
    /* Clusters: partitions this node sent to peers (raw bytes read, compressed bytes on the wire), compressed
       bytes it received from peers, transfers it could not deliver, and awaits that failed here. */
    uint64_t peer_raw_out, peer_bytes_out, peer_bytes_in, peer_failures, transfer_failures;
    /* Session devices leaked because their GPU work did not finish (the submit watchdog, or a session that
       ended with work still running past its bounded wait): each holds its device memory until the node
       exits. */
    uint64_t devices_abandoned;
} cv_node_stats;

/* Checks a cv_node_config.peers list: each entry a "host:port" (an IPv4 dotted quad, a bracketed IPv6
 * address or a DNS name; no unix: or other URI targets), at most 256. CV_ERROR_MALFORMED names `what` (the
 * option, "--peers") and the entry. */
cv_result cv_node_check_peers(const char *peers, const char *what);

/* True if `listen` ("host:port") is reachable from this machine only: 127.0.0.0/8, ::1, localhost, unix:. */
bool cv_node_listen_is_local(const char *listen);

cv_result cv_node_start(const cv_node_config *config, cv_node **out);
int cv_node_port(const cv_node *node);
/* The plaintext health port (config.health_listen), 0 if none. */
int cv_node_health_port(const cv_node *node);
/* Refuses new sessions (health answers NOT_SERVING); running ones go on. */
void cv_node_drain(cv_node *node);
/* Waits up to timeout_ms (a deadline, not a count of naps) for running sessions to end; returns how many are
 * left. */
uint32_t cv_node_wait_sessions(cv_node *node, uint32_t timeout_ms);
/* Ends every running session now: its client gets the stream status UNAVAILABLE "node shutting down:
 * <reason>", and the node logs "session N ...: ended: <reason>" ("drain timeout (30 s) expired"). Sessions
 * return once their current request is done. Only the first call's reason is kept. */
void cv_node_cancel_sessions(cv_node *node, const char *reason);
/* Drains, waits up to timeout_ms for sessions to end, ends the rest (cv_node_cancel_sessions, "stop timeout
 * (N ms) expired"), gives them CV_NODE_CANCEL_GRACE_MS to return before their calls are cancelled, frees
 * everything. */
void cv_node_stop(cv_node *node, uint32_t timeout_ms);
#define CV_NODE_CANCEL_GRACE_MS 1000u
cv_node_stats cv_node_get_stats(cv_node *node);
/* Nodes started and not yet stopped in this process (tests check it is 0 at their end). */
uint32_t cv_live_nodes(void);

#endif
