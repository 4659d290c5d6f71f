/* What node.c (the server, Info, health) shares with session.c (one client's
 * stream). The node's lower parts (metrics.h, node_log.h, peer.h) never see
 * this: the node hands them what they need. */
#ifndef CORVID_NODE_INTERNAL_H
#define CORVID_NODE_INTERNAL_H

#include <stdatomic.h>

#include "content_store.h"
#include "metrics.h"
#include "node_log.h"
#include "corvid/node_protocol.h"
#include "corvid/rpc.h"
#include "node.h"
#include "peer.h"

struct cv_node {
    cv_node_config config; /* pointers below are the node's own copies */
    char name[256];
    cv_node_device_spec *devices;
    cv_device_info *device_info; /* probed at start */
    cv_content_store *store;
    cv_rpc_server *server;
    cv_rpc_server *health_server; /* plaintext health only (config.health_listen); NULL = none */
    atomic_bool draining;
    atomic_uint_fast64_t next_session_id;
    atomic_uint_fast64_t sessions_started, sessions_active;
    atomic_uint_fast64_t messages_in, bytes_in, bytes_out, submissions, errors;
    atomic_uint_fast64_t unauthenticated, quota_refusals, devices_abandoned;
    atomic_uint_fast64_t transfer_failures;
    peer_state *peer;      /* node-to-node transfers, their counters and the peer token (peer.h) */
    peer_members *members; /* where transfers may go (peer_members.h) */
    bool has_token;
    uint8_t token_sha[32];    /* SHA-256 of the token; the token itself is not kept */
    cv_node_quota quota;      /* defaults filled in */
    cv_node_metrics *metrics; /* what the counters above do not hold (metrics.h) */
    node_log_state log;       /* the log's rate limit (node_log.h) */
    /* Set (stop_reason first) when cv_node_stop cancels the sessions still running: each one logs that as why
       it ended, and its client is told the same in the stream's status. */
    char stop_reason[128];
    atomic_bool stopping_sessions;
    uint64_t memory_limit;              /* config.memory_bytes, default filled in */
    atomic_uint_fast64_t memory_used;   /* device memory all sessions hold (cv_node_memory_reserve) */
    atomic_uint_fast64_t trim_requests; /* sessions ended since the last trim began */
    atomic_bool trimming;               /* a session's thread is trimming */
};

/* Takes `bytes` of the node-wide device memory limit for a create; CV_ERROR_LIMIT_EXCEEDED naming the limit
 * (and nothing taken) when the sessions together would pass it. */
cv_result cv_node_memory_reserve(cv_node *node, uint64_t bytes);
/* Gives back what cv_node_memory_reserve took, once the memory is freed. */
void cv_node_memory_release(cv_node *node, uint64_t bytes);
/* Keeps the context of a session whose device was abandoned (session.c): never freed, as its GPU may
 * still use its memory, but held where leak checkers see it as deliberate. */
void cv_node_keep_abandoned(cv_context *ctx);

/* Runs one session on the calling thread until its stream ends. */
void cv_node_session_run(cv_node *node, cv_rpc_stream *stream);

#endif
