/* Inside the RPC layer: the stream object both sides share, and helpers for the client and server files.
 *
 * A stream owns one grpc_call, its own completion queue and one pump thread that polls the queue. Any thread
 * may start a batch, always under the stream's mutex (the core wants start_batch serialized per call);
 * the pump only handles completions. Tags are small integers (one queue per call, so the kind suffices).
 * Everything an op points to lives in the stream until the stream is torn down, after the queue drained. */
#ifndef CORVID_RPC_INTERNAL_H
#define CORVID_RPC_INTERNAL_H

#include <grpc/grpc.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdbool.h>
#include "corvid/rpc.h"

typedef struct cv_rpc_msg {
    struct cv_rpc_msg *next;
    uint8_t *data;
    size_t size;
} cv_rpc_msg;

typedef enum cv_rpc_out_kind { CV_RPC_OUT_MESSAGE, CV_RPC_OUT_CLOSE, CV_RPC_OUT_STATUS } cv_rpc_out_kind;

/* One queued outgoing operation; they go out one at a time, in order. */
typedef struct cv_rpc_out {
    struct cv_rpc_out *next;
    cv_rpc_out_kind kind;
    grpc_byte_buffer *buffer; /* MESSAGE */
    size_t size;
} cv_rpc_out;

struct cv_rpc_stream {
    bool is_server;
    grpc_call *call;
    grpc_completion_queue *cq;
    pthread_t pump;
    bool pump_started;
    char *peer;

    pthread_mutex_t mu;
    pthread_cond_t cond; /* any change below: messages in, sends done, the call ending */

    /* receiving */
    cv_rpc_msg *in_head, *in_tail;
    uint32_t in_count;
    grpc_byte_buffer *recv_buffer;
    bool recv_in_flight;
    bool eof; /* the peer closed its sending side */

    /* sending */
    cv_rpc_out *out_head, *out_tail;
    bool out_in_flight; /* out_head is the op in flight */
    size_t out_bytes;   /* queued + in flight */
    bool send_closed;   /* close_send or finish was queued */

    /* the call's life */
    bool failed;   /* an op failed: the call is dead */
    bool ended;    /* client: status received; server: RECV_CLOSE_ON_SERVER completed */
    bool closing;  /* teardown began: no new batches */
    int cancelled; /* server: RECV_CLOSE_ON_SERVER's verdict */

    /* status: client, received; server, sent */
    bool status_set;
    grpc_status_code status;
    char *status_message;
    grpc_slice status_details; /* client: filled by the core; server: what we send */
    const char *error_string;  /* client: the core's debug text (gpr_free) */
    grpc_metadata_array recv_initial, recv_trailing;

    /* client: initial metadata we send */
    grpc_metadata *send_md;
    size_t send_md_count;
    /* server: initial metadata the client sent, copied as "key\0value\0" pairs */
    char **md; /* 2 * md_count strings */
    size_t md_count;
    atomic_uint *client_streams; /* client: the owning client's count of open streams */
};

/* Allocates a stream around `call` (whose completion queue is `cq`); takes ownership of both. */
cv_result cv_rpc_stream_create(grpc_call *call, grpc_completion_queue *cq, bool is_server, cv_rpc_stream **out);
/* Starts the pump and the first batches (initial metadata, status/close, first recv). On failure the
 * stream is left for cv_rpc_stream_teardown. Client: `md` is copied and sent as initial metadata. */
cv_result cv_rpc_stream_begin(cv_rpc_stream *s, const cv_rpc_metadata *md, uint32_t count);
/* Server: copies the client's initial metadata. */
cv_result cv_rpc_stream_set_request_metadata(cv_rpc_stream *s, const grpc_metadata_array *md);
/* Server: waits until the call is over (status sent or cancelled). */
void cv_rpc_stream_wait_ended(cv_rpc_stream *s);
/* Server: ends the call now with `status` and `message` for the client, ahead of anything still queued to send
 * (cv_rpc_stream_finish waits behind it); the handler's recv and send then fail. Any thread. */
void cv_rpc_stream_cancel_with_status(cv_rpc_stream *s, int status, const char *message);
/* Cancels the call if it is not over, drains the queue, joins the pump, frees everything. */
void cv_rpc_stream_teardown(cv_rpc_stream *s);

/* Shared helpers. */
char *cv_rpc_slice_to_string(grpc_slice slice);                                   /* malloc'd, NUL-terminated */
cv_result cv_rpc_buffer_read(grpc_byte_buffer *bb, uint8_t **data, size_t *size); /* malloc(>=1) */
grpc_byte_buffer *cv_rpc_buffer_copy(const void *data, size_t size);
void cv_rpc_cq_drain_and_destroy(grpc_completion_queue *cq); /* shutdown, next until SHUTDOWN, destroy */
gpr_timespec cv_rpc_deadline(uint32_t timeout_ms);           /* CV_RPC_FOREVER: infinite */
const char *cv_rpc_status_name(int status);

#endif
