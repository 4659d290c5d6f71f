/* The proxy device: the state its session with a node (proxy_session.h), its
 * peer path (proxy_peer.h) and the backend table (proxy_backend.c) share.
 *
 * One proxy device = one gRPC stream to one node device. The device's calls
 * come under the core's device lock, so at most one request waits for an answer
 * at a time (the `pending` slot), besides one encoded read, whose answer is
 * waited for outside the lock (`encode_pending`); a receiver thread reads every node message,
 * fills the pending request's answer, records finished tickets and wakes
 * whoever waits. Requests that need no answer (writes, destroy, compile, submit)
 * are sent and forgotten; if the node refuses one anyway, its error is kept
 * (`async_error`) and returned by every later call: the client's picture of the
 * device no longer matches the node's. */
#ifndef CORVID_PROXY_INTERNAL_H
#define CORVID_PROXY_INTERNAL_H

#include <pthread.h>
#include <stdatomic.h>

#include "corvid/backend.h"
#include "corvid/node_protocol.h"
#include "corvid/proxy.h"
#include "corvid/rpc.h"

#define PROXY_MAX_TIMINGS 32u
#define PROXY_INFLIGHT 1024u
#define PROXY_AWAITS 64u

/* A loaded resource: the node knows it by the client's id. */
typedef struct proxy_resource {
    uint64_t id;
} proxy_resource;

/* A list as compiled for the node: the node holds the list, this is its name. */
typedef struct proxy_list {
    uint64_t id;
    cv_pass_timing timings[PROXY_MAX_TIMINGS];
    uint32_t timing_count;
} proxy_list;

/* The answer a waiting request gets. */
typedef struct proxy_pending {
    uint64_t seq; /* 0: no request waits */
    bool done;
    cv_result result;
    char message[1024];
    Corvid__DeviceInfo *hello; /* hello: the node's device (copied into info) */
    cv_device_info *hello_info;
    uint64_t session_id;
    uint8_t *read_into; /* reads: destination and its size */
    uint64_t read_size, read_received;
    cv_encoded *encoded;                    /* encoded reads: the frame received (data malloc'd by the receiver) */
    uint64_t encoded_max, encoded_received; /* the most bytes the frame may have; bytes so far */
    cv_encoded frame; /* encoded reads: the frame, moved out of *encoded as the request ends (request_wait),
                       * before the slot is free for the next read's pieces */
    bool *present;    /* blob queries: one flag per hash */
    size_t present_count;
    uint8_t session_key[CV_NODE_SESSION_KEY_BYTES]; /* hello: the session's capability */
    bool has_session_key;
    uint32_t quota_inflight; /* hello: the node's quotas (0 = not told) */
    uint64_t quota_upload;
    uint64_t max_blob;
    uint64_t transfer_failure; /* refused because of this transfer failure (the caller learns of it) */
} proxy_pending;

typedef struct proxy_inflight {
    uint64_t ticket;
    proxy_list *list;
} proxy_inflight;

typedef struct proxy_known_list {
    uint64_t id;
    uint32_t refs; /* compiled forms alive; the node's list goes at 0 */
} proxy_known_list;

struct cv_backend_device {
    char endpoint[256];
    uint32_t remote_device;
    uint32_t timeout_ms; /* for one answer */
    cv_rpc_client *client;
    cv_rpc_stream *stream;
    pthread_t receiver;
    bool receiver_started;

    pthread_mutex_t lock; /* everything below */
    pthread_cond_t cond;
    atomic_uint_fast64_t next_seq;
    proxy_pending pending;
    proxy_pending encode_pending; /* an encoded read's answer, waited for without the device lock */
    cv_encoded encode_frame;      /* ... the frame it brings (the receiver fills it; encoder_receive moves it out) */
    uint64_t completed;           /* highest ticket the node finished */
    proxy_inflight inflight[PROXY_INFLIGHT]; /* submitted, not completed: ring by ticket */
    cv_result dead;                          /* CV_OK while the stream lives */
    char dead_message[512];
    cv_result async_error; /* first refused fire-and-forget request */
    char async_message[512];
    /* The first submission not yet reported that ran with a command the node's
       device refused (Completed.refused): the next wait covering it returns it,
       once (backend.h, refused). Not an async_error: the device goes on. */
    uint64_t refused_ticket; /* 0: none */
    cv_result refused_result;
    char refused_message[512];

    /* Blobs the node is known to have (answered present, or uploaded). */
    uint8_t (*known)[CV_SHA256_BYTES];
    uint32_t known_count, known_capacity;
    proxy_known_list *lists; /* lists that exist on the node */
    uint32_t list_count, list_capacity;

    cv_proxy_stats stats; /* under lock */

    /* Clusters (proxy_peer.c). The session's capability for node-to-node transfers (HelloReply). */
    uint8_t session_key[CV_NODE_SESSION_KEY_BYTES];
    bool has_session_key;
    /* The node's quotas for this session (HelloReply.quotas; 0 = not told): submissions past the in-flight
       quota wait here, uploads past the upload quota are refused here, so neither poisons the device.
       max_blob: the node's content store limit; a larger blob is refused here, with the same error every
       time (sent, the node's refusal would race the write that names the blob). */
    uint32_t quota_inflight;
    uint64_t quota_upload;
    uint64_t max_blob;
    uint32_t peer_deadline_ms; /* asked of the node for each await; 0 = the node's */
    /* A failed await the node reported (Reply or Completed.transfer_failure) and no caller has learned of yet:
       the next wait for a ticket >= soft_ticket returns it, once, and sends ResumeAfterFailure. Failures up to
       `resumed` belong to frames already reported and are ignored. Not an async_error: the device goes on. */
    uint64_t soft_failure, soft_ticket, soft_seq, resumed;
    cv_result soft_result;
    char soft_message[512];
    /* Awaits sent to this session, the last PROXY_AWAITS (a ring): when the caller has been told that an
       await's source device is lost, the await is given up (proxy_peer_settle) before anything else is sent
       here. `serial` names a device in the process's registry of proxy devices (proxy_peer.c). */
    uint64_t serial;
    bool loss_reported; /* a call returned this session's death to the caller */
    struct cv_backend_device *registry_next;
    struct proxy_await {
        uint64_t transfer_id, seq, source; /* source: its serial; 0 = a free slot */
        bool aborted;                      /* the node was told to fail it at once (its source died) */
        bool given_up;                     /* ... and the session resumed after it (the caller knows) */
    } awaits[PROXY_AWAITS];
    uint32_t awaits_next;
    /* Set by the peer path (proxy_peer_register): runs before every proxy_send, so the session need not know
       the peer path that sits above it. NULL: nothing. */
    void (*before_send)(struct cv_backend_device *p);
};

typedef struct cv_backend_device proxy_device;

#endif
