/* Node-to-node transfers: how a cluster's partitions go from the node that
 * traced them to the node that needs them, without passing through the client.
 *
 * The receiving side: every session has an inbox, registered under a random
 * 128-bit key (HelloReply.session_key) that only its client learns. A peer
 * node delivers a transfer's zstd-compressed bytes in pieces
 * (/corvid.Node/PeerPiece, unary, each checked: key compared in constant time,
 * sizes bounded, pieces in order); the session's AwaitTransfer takes them out
 * (peer_inbox_take), decompresses them to exactly the size its client expects
 * and writes them, on the session's own thread.
 * The sending side: a session's PushTransfer reads the region and hands it to
 * peer_send, which compresses it and queues it for the node's sender thread;
 * that thread keeps one rpc channel per destination node and presents the
 * node's peer token (cv_node_config.peer_token) there.
 * The machinery sits below the node: the node gives it its settings and where
 * to count and log (peer_config), and calls it; it never reaches into the node.
 *
 *     peer_state_create(&(peer_config){ .deadline_ms = 10000, .members = members, ... }, &node->peer);
 *     uint8_t key[CV_NODE_SESSION_KEY_BYTES];
 *     peer_inbox *in;
 *     peer_inbox_open(node->peer, key, &in);           // session start (hello)
 *     ...
 *     uint8_t *data; size_t size;
 *     if (peer_inbox_take(in, transfer_id, raw_bytes, 1000, &data, &size) == CV_OK) {
 *         peer_decompress(data, size, out, raw_bytes);  // exactly raw_bytes or an error
 *         free(data);
 *     }
 *     peer_inbox_close(node->peer, in);                 // session end
 *
 * Thread-safe: pieces arrive on the rpc layer's unary threads, takes happen on
 * session threads; one lock per node guards the inboxes (its peer_state). */
#ifndef CORVID_NODE_PEER_H
#define CORVID_NODE_PEER_H

#include <stdatomic.h>
#include <stddef.h>
#include <stdint.h>

#include "corvid/node_protocol.h"
#include "metrics.h"
#include "node_log.h"
#include "peer_members.h"

typedef struct peer_inbox peer_inbox;
typedef struct peer_state peer_state;

/* At most this many transfers wait in one inbox, with at most this many compressed bytes. */
#define PEER_INBOX_MAX_ENTRIES 64u
#define PEER_INBOX_MAX_BYTES (512ull << 20)
/* Pieces of a transfer on the wire. */
#define PEER_PIECE_BYTES (1u << 20)

/* Node-to-node traffic (cv_node_stats.peer_*). */
typedef struct peer_counters {
    uint64_t raw_out, bytes_out, bytes_in, failures;
} peer_counters;

/* What the node gives its peer machinery. The strings are copied; the pointers must outlive the state. */
typedef struct peer_config {
    uint32_t keepalive_ms;        /* of each channel to a peer; 0 = the rpc default */
    uint32_t deadline_ms;         /* one piece's call to a peer */
    const char *token;            /* presented to peers; NULL = none */
    const char *tls_ca_file;      /* NULL = plaintext to peers */
    peer_members *members;        /* where transfers may go */
    cv_node_metrics *metrics;     /* node-loss events */
    node_log_state *log;          /* refusals and failed deliveries */
    atomic_uint_fast64_t *errors; /* the node's error count, bumped by each of those */
} peer_config;

/* The node's peer machinery: inbox registry and sender thread. */
cv_result peer_state_create(const peer_config *config, peer_state **out);
void peer_state_destroy(peer_state *ps);
peer_counters peer_get_counters(peer_state *ps);

/* Registers a new inbox; key gets its capability (random). */
cv_result peer_inbox_open(peer_state *ps, uint8_t key[CV_NODE_SESSION_KEY_BYTES], peer_inbox **out);
/* Unregisters and frees it, with whatever arrived and was never taken. NULL is ignored. */
void peer_inbox_close(peer_state *ps, peer_inbox *in);
/* Waits up to deadline_ms for transfer `transfer_id` to have arrived whole, then hands its compressed bytes
 * over (*data malloc'd, caller frees). Transfers with smaller ids that were never taken are dropped, and
 * pieces for ids up to this one are refused from now on (clients await in id order). Fails with
 * CV_ERROR_TIMEOUT ("... N of M bytes arrived within D ms") or CV_ERROR_MALFORMED (its raw size is not
 * raw_bytes). *data is NULL on failure. */
cv_result peer_inbox_take(peer_inbox *in, uint64_t transfer_id, uint64_t raw_bytes, uint32_t deadline_ms,
                          uint8_t **data, size_t *size);

/* The unary handler of /corvid.Node/PeerPiece: 0, or a gRPC status with a message naming what is wrong. */
int peer_on_piece(peer_state *ps, const void *request, size_t size, char *message, size_t cap);

/* Whether this node may send a transfer to `destination` (a cluster member, peer_members.h): CV_OK with the
 * channel target to pass to peer_send, or the refusal (CV_ERROR_MALFORMED / CV_ERROR_INVALID_ARGUMENT, the
 * message naming push_transfer.destination). Resolves nothing and connects nowhere. */
cv_result peer_check_destination(peer_state *ps, const char *destination, char *target, size_t cap);

/* Compresses `raw` and queues it for `destination`'s session `key` (destination: a target from
 * peer_check_destination); returns once queued (the sender thread
 * delivers it; a failure there is logged and counted, and the destination's await fails at its deadline). */
cv_result peer_send(peer_state *ps, const char *destination, const uint8_t key[CV_NODE_SESSION_KEY_BYTES],
                    uint64_t transfer_id, const void *raw, size_t raw_size);

/* Decompresses exactly raw_size bytes into out; anything else (corrupt data, another size) is
 * CV_ERROR_MALFORMED. */
cv_result peer_decompress(const void *data, size_t size, void *out, size_t raw_size);

#endif
