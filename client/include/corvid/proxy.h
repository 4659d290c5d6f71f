/* The proxy backend: devices of a remote corvid-node, used like local ones.
 *
 * A proxy device is one device of a node (proto/node.proto), reached over one
 * gRPC stream, its session. It joins the application's context like any other
 * device: the application records command lists locally against its own
 * handles, and the proxy sends what the node needs to run them: resource
 * descriptions, encoded lists, data. Nothing costs a round trip per recorded
 * command; submit returns a ticket at once and the node reports finished work
 * by itself, so frame N+1 can be submitted before frame N's results arrive.
 * Writes travel without waiting; reads wait for their data (one round trip).
 * Large buffer writes and acceleration structures are content-addressed: they
 * are hashed (SHA-256) and only sent if the node's cache lacks them, so a scene
 * the node has already seen, in any session, costs no upload.
 *
 *     cv_device_desc desc = { .endpoint = "gpubox:7700", .adapter = "1" };   // the node's device 1
 *     cv_device *dev;
 *     if (cv_device_create(ctx, cv_proxy_backend(), &desc, &dev) != CV_OK)
 *         fprintf(stderr, "%s\n", cv_last_error());   // says which node and why
 *
 * desc.adapter is the index of the node's device ("" = 0). A node that cannot
 * be reached, speaks another protocol version, or dies mid-session makes calls
 * fail with CV_ERROR_CONNECTION (within the keepalive time, never a hang);
 * a request the node refuses fails with the node's code and message.
 *
 * Clusters: a transfer between two proxy devices on different sessions takes
 * the PEER path (transfer.h): the source node sends the bytes to the
 * destination node, which holds that session's later messages until they are
 * written. If they never come (the source died or stalled), the node skips the
 * submissions that needed them and the next cv_device_wait reports it, once;
 * the device stays usable (docs/node.md, "Clusters").
 * How devices reach nodes (timeouts, token, TLS) is the process's, set once by
 * the program (cv_proxy_configure; programs read it from CORVID_NODE_* with
 * apps/common/env_client.h). */
#ifndef CORVID_PROXY_H
#define CORVID_PROXY_H

#include "corvid/device.h"

const cv_backend *cv_proxy_backend(void);

/* How this process's proxy devices (and cv_proxy_query_node) reach nodes. Zero fields take the defaults. */
typedef struct cv_proxy_options {
    uint32_t timeout_ms;       /* one answer from a node, 1..86400000; 0 = 120000 */
    uint32_t peer_deadline_ms; /* how long a node waits for a peer's transfer, 1..86400000; 0 = the node's
                                  --peer-deadline-ms (also the most it allows) */
    uint32_t keepalive_ms;     /* ping interval and timeout, 100..3600000; 0 = 10000 + 5000: a silent node is
                                  noticed within about twice that */
    const char *bearer_token;  /* presented to nodes (--token-file of corvid-node); NULL or "" = none */
    const char *tls_ca_file;   /* NULL = plaintext; else TLS, trusting the PEM CA certificates in this file */
    const char *tls_cert_file; /* with tls_key_file (both or neither, and tls_ca_file): a client certificate */
    const char *tls_key_file;
} cv_proxy_options;

/* Sets the options of every proxy device created and node queried from now on (the strings are copied; NULL =
 * all defaults). Process-wide, from any thread; a device keeps what it was created with. A field out of range
 * or a certificate without key or CA is CV_ERROR_INVALID_ARGUMENT naming the field, and nothing changes. */
cv_result cv_proxy_configure(const cv_proxy_options *options);

/* Traffic of one proxy device's session. */
typedef struct cv_proxy_stats {
    uint64_t messages_sent, bytes_sent, bytes_received;
    uint64_t upload_bytes_sent;    /* content-addressed data actually sent */
    uint64_t upload_bytes_skipped; /* ... that the node had already */
    uint64_t round_trips;          /* requests that waited for an answer */
    uint64_t blocking_waits;       /* waits for a ticket the node had not yet reported finished:
                                        each costs at least the node's latency, like a round trip */
    /* Clusters: transfers this device's node sent to another node's session (pushes) and received from one
       (awaits), the bytes those moved node to node (never through this client), and transfer failures the
       node reported (a frame that lacked a partition; the device goes on). */
    uint64_t peer_pushes, peer_awaits, peer_push_bytes, peer_await_bytes, transfer_failures;
    /* Frames the node read and encoded (encoder streams, device.h) and their encoded bytes. */
    uint64_t encoded_frames, encoded_bytes;
} cv_proxy_stats;

/* CV_ERROR_INVALID_ARGUMENT if dev is not a proxy device. */
cv_result cv_proxy_get_stats(cv_device *dev, cv_proxy_stats *out);

/* What a node serves, without opening a session. */
typedef struct cv_proxy_node_info {
    char name[256];
    uint32_t protocol_version;
    uint32_t device_count;
    uint32_t sessions;
    cv_device_info devices[64];
    char labels[64][CV_LABEL_MAX];
} cv_proxy_node_info;

cv_result cv_proxy_query_node(const char *endpoint, uint32_t timeout_ms, cv_proxy_node_info *out);

#endif
