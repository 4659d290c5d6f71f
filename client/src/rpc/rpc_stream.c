/* The stream machinery both sides share: one pump thread per call turning completions into a bounded
 * receive queue and an ordered send queue (one send in flight, as the core demands). See rpc_internal.h. */
#include "rpc_internal.h"

#include <errno.h>
#include <grpc/byte_buffer_reader.h>
#include <grpc/support/alloc.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "corvid/clock.h"
#include "corvid/log.h"

typedef enum stream_tag {
    TAG_INITIAL_SENT = 1, /* SEND_INITIAL_METADATA */
    TAG_INITIAL_RECEIVED, /* client: RECV_INITIAL_METADATA */
    TAG_END,              /* client: RECV_STATUS_ON_CLIENT; server: RECV_CLOSE_ON_SERVER */
    TAG_RECV,             /* RECV_MESSAGE */
    TAG_SEND,             /* the head of the send queue */
} stream_tag;

#define TAG(t) ((void *)(intptr_t)(t))

/* ---- shared helpers ---- */

char *cv_rpc_slice_to_string(grpc_slice slice) {
    size_t n = GRPC_SLICE_LENGTH(slice);
    char *s = malloc(n + 1);
    if (s) {
        memcpy(s, GRPC_SLICE_START_PTR(slice), n);
        s[n] = 0;
    }
    return s;
}

cv_result cv_rpc_buffer_read(grpc_byte_buffer *bb, uint8_t **data, size_t *size) {
    grpc_byte_buffer_reader reader;
    if (!grpc_byte_buffer_reader_init(&reader, bb))
        return cv_error(CV_ERROR_MALFORMED, "rpc: received message could not be decompressed");
    /* buffer_out is the decompressed buffer (the same as buffer_in when uncompressed). */
    size_t total = grpc_byte_buffer_length(reader.buffer_out);
    uint8_t *out = malloc(total ? total : 1);
    if (!out) {
        grpc_byte_buffer_reader_destroy(&reader);
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "rpc: received message of %zu bytes", total);
    }
    size_t at = 0;
    grpc_slice slice;
    while (grpc_byte_buffer_reader_next(&reader, &slice)) {
        size_t n = GRPC_SLICE_LENGTH(slice);
        if (at + n <= total)
            memcpy(out + at, GRPC_SLICE_START_PTR(slice), n);
        at += n;
        grpc_slice_unref(slice);
    }
    grpc_byte_buffer_reader_destroy(&reader);
    if (at != total) {
        free(out);
        return cv_error(CV_ERROR_MALFORMED, "rpc: received message has %zu bytes in slices, %zu in total", at, total);
    }
    *data = out;
    *size = total;
    return CV_OK;
}

grpc_byte_buffer *cv_rpc_buffer_copy(const void *data, size_t size) {
    grpc_slice slice = grpc_slice_malloc(size);
    if (size)
        memcpy(GRPC_SLICE_START_PTR(slice), data, size);
    grpc_byte_buffer *bb = grpc_raw_byte_buffer_create(&slice, 1);
    grpc_slice_unref(slice); /* the buffer holds its own reference */
    return bb;
}

void cv_rpc_cq_drain_and_destroy(grpc_completion_queue *cq) {
    grpc_completion_queue_shutdown(cq);
    while (grpc_completion_queue_next(cq, gpr_inf_future(GPR_CLOCK_REALTIME), NULL).type != GRPC_QUEUE_SHUTDOWN) {
    }
    grpc_completion_queue_destroy(cq);
}

gpr_timespec cv_rpc_deadline(uint32_t timeout_ms) {
    if (timeout_ms == CV_RPC_FOREVER)
        return gpr_inf_future(GPR_CLOCK_MONOTONIC);
    return gpr_time_add(gpr_now(GPR_CLOCK_MONOTONIC), gpr_time_from_millis(timeout_ms, GPR_TIMESPAN));
}

const char *cv_rpc_status_name(int status) {
    static const char *const names[] = {
        "OK",        "CANCELLED",       "UNKNOWN",           "INVALID_ARGUMENT",   "DEADLINE_EXCEEDED",
        "NOT_FOUND", "ALREADY_EXISTS",  "PERMISSION_DENIED", "RESOURCE_EXHAUSTED", "FAILED_PRECONDITION",
        "ABORTED",   "OUT_OF_RANGE",    "UNIMPLEMENTED",     "INTERNAL",           "UNAVAILABLE",
        "DATA_LOSS", "UNAUTHENTICATED",
    };
    if (status >= 0 && status < (int)(sizeof names / sizeof names[0]))
        return names[status];
    return "?";
}

/* ---- creation ---- */

cv_result cv_rpc_stream_create(grpc_call *call, grpc_completion_queue *cq, bool is_server, cv_rpc_stream **out) {
    cv_rpc_stream *s = calloc(1, sizeof *s);
    if (!s)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "rpc: stream");
    cv_cond_init(&s->cond);
    pthread_mutex_init(&s->mu, NULL);
    s->is_server = is_server;
    s->call = call;
    s->cq = cq;
    s->status_details = grpc_empty_slice();
    grpc_metadata_array_init(&s->recv_initial);
    grpc_metadata_array_init(&s->recv_trailing);
    char *peer = grpc_call_get_peer(call);
    s->peer = strdup(peer ? peer : "");
    gpr_free(peer);
    *out = s;
    return CV_OK;
}

cv_result cv_rpc_stream_set_request_metadata(cv_rpc_stream *s, const grpc_metadata_array *md) {
    if (md->count == 0)
        return CV_OK;
    s->md = calloc(2 * md->count, sizeof *s->md);
    if (!s->md)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "rpc: request metadata");
    for (size_t i = 0; i < md->count; i++) {
        s->md[2 * i] = cv_rpc_slice_to_string(md->metadata[i].key);
        s->md[2 * i + 1] = cv_rpc_slice_to_string(md->metadata[i].value);
        s->md_count = i + 1;
        if (!s->md[2 * i] || !s->md[2 * i + 1])
            return cv_error(CV_ERROR_OUT_OF_MEMORY, "rpc: request metadata");
    }
    return CV_OK;
}

/* ---- batches (all under s->mu) ---- */

static void fail_locked(cv_rpc_stream *s) {
    s->failed = true;
    /* Queued sends will never go: free them (the one in flight, if any, completes and is freed then). */
    cv_rpc_out **link = s->out_in_flight ? &s->out_head->next : &s->out_head;
    while (*link) {
        cv_rpc_out *o = *link;
        *link = o->next;
        s->out_bytes -= o->size;
        if (o->buffer)
            grpc_byte_buffer_destroy(o->buffer);
        free(o);
    }
    s->out_tail = s->out_in_flight ? s->out_head : NULL;
    pthread_cond_broadcast(&s->cond);
}

static bool start_locked(cv_rpc_stream *s, const grpc_op *ops, size_t n, stream_tag tag) {
    if (s->closing)
        return false;
    grpc_call_error e = grpc_call_start_batch(s->call, ops, n, TAG(tag), NULL);
    if (e != GRPC_CALL_OK) {
        cv_log(CV_LOG_ERROR, "rpc", "start_batch (tag %d) failed: %s", (int)tag, grpc_call_error_to_string(e));
        fail_locked(s);
        return false;
    }
    return true;
}

static void start_recv_locked(cv_rpc_stream *s) {
    if (s->recv_in_flight || s->eof || s->failed || s->closing || s->in_count >= CV_RPC_RECV_QUEUE_MAX)
        return;
    grpc_op op = { .op = GRPC_OP_RECV_MESSAGE };
    op.data.recv_message.recv_message = &s->recv_buffer;
    s->recv_buffer = NULL;
    if (start_locked(s, &op, 1, TAG_RECV))
        s->recv_in_flight = true;
}

static void start_send_locked(cv_rpc_stream *s) {
    if (s->out_in_flight || !s->out_head || s->failed || s->closing)
        return;
    cv_rpc_out *o = s->out_head;
    grpc_op op = { 0 };
    switch (o->kind) {
    case CV_RPC_OUT_MESSAGE:
        op.op = GRPC_OP_SEND_MESSAGE;
        op.data.send_message.send_message = o->buffer;
        break;
    case CV_RPC_OUT_CLOSE: op.op = GRPC_OP_SEND_CLOSE_FROM_CLIENT; break;
    case CV_RPC_OUT_STATUS:
        op.op = GRPC_OP_SEND_STATUS_FROM_SERVER;
        op.data.send_status_from_server.status = s->status;
        op.data.send_status_from_server.status_details = &s->status_details;
        break;
    }
    if (start_locked(s, &op, 1, TAG_SEND))
        s->out_in_flight = true;
}

static void enqueue_locked(cv_rpc_stream *s, cv_rpc_out *o) {
    o->next = NULL;
    if (s->out_tail)
        s->out_tail->next = o;
    else
        s->out_head = o;
    s->out_tail = o;
    s->out_bytes += o->size;
    start_send_locked(s);
}

/* ---- the pump ---- */

static void on_recv(cv_rpc_stream *s, bool success) {
    s->recv_in_flight = false;
    if (!success) {
        fail_locked(s);
        return;
    }
    if (!s->recv_buffer) {
        s->eof = true;
        return;
    }
    cv_rpc_msg *m = calloc(1, sizeof *m);
    cv_result r = m ? cv_rpc_buffer_read(s->recv_buffer, &m->data, &m->size) : CV_ERROR_OUT_OF_MEMORY;
    grpc_byte_buffer_destroy(s->recv_buffer);
    s->recv_buffer = NULL;
    if (r != CV_OK) {
        free(m);
        cv_log(CV_LOG_WARNING, "rpc", "dropping stream from %s: %s", s->peer, cv_last_error());
        grpc_call_cancel(s->call, NULL);
        fail_locked(s);
        return;
    }
    if (s->in_tail)
        s->in_tail->next = m;
    else
        s->in_head = m;
    s->in_tail = m;
    s->in_count++;
    start_recv_locked(s);
}

static void on_send(cv_rpc_stream *s, bool success) {
    cv_rpc_out *o = s->out_head;
    s->out_head = o->next;
    if (!s->out_head)
        s->out_tail = NULL;
    s->out_in_flight = false;
    s->out_bytes -= o->size;
    if (o->buffer)
        grpc_byte_buffer_destroy(o->buffer);
    free(o);
    if (!success)
        fail_locked(s);
    else
        start_send_locked(s);
}

static void on_end(cv_rpc_stream *s) {
    s->ended = true;
    if (!s->is_server) {
        s->status_set = true;
        free(s->status_message);
        s->status_message = cv_rpc_slice_to_string(s->status_details);
        if (s->error_string && s->status != GRPC_STATUS_OK && s->status_message && !s->status_message[0]) {
            free(s->status_message);
            s->status_message = strdup(s->error_string);
        }
    }
    if (s->is_server && s->cancelled)
        fail_locked(s);
    else if (s->out_head && !s->out_in_flight)
        fail_locked(s); /* nothing queued can go out any more */
}

static void *pump_main(void *arg) {
    cv_rpc_stream *s = arg;
    for (;;) {
        grpc_event ev = grpc_completion_queue_next(s->cq, gpr_inf_future(GPR_CLOCK_REALTIME), NULL);
        if (ev.type == GRPC_QUEUE_SHUTDOWN)
            break;
        if (ev.type != GRPC_OP_COMPLETE)
            continue;
        pthread_mutex_lock(&s->mu);
        switch ((stream_tag)(intptr_t)ev.tag) {
        case TAG_INITIAL_SENT:
        case TAG_INITIAL_RECEIVED:
            if (!ev.success)
                fail_locked(s);
            break;
        case TAG_END: on_end(s); break;
        case TAG_RECV: on_recv(s, ev.success); break;
        case TAG_SEND: on_send(s, ev.success); break;
        }
        pthread_cond_broadcast(&s->cond);
        pthread_mutex_unlock(&s->mu);
    }
    return NULL;
}

cv_result cv_rpc_stream_begin(cv_rpc_stream *s, const cv_rpc_metadata *md, uint32_t count) {
    if (count) {
        s->send_md = calloc(count, sizeof *s->send_md);
        if (!s->send_md)
            return cv_error(CV_ERROR_OUT_OF_MEMORY, "rpc: metadata");
        for (uint32_t i = 0; i < count; i++) {
            s->send_md[i].key = grpc_slice_from_copied_string(md[i].key);
            s->send_md[i].value = grpc_slice_from_copied_string(md[i].value);
            s->send_md_count = i + 1;
        }
    }
    if (pthread_create(&s->pump, NULL, pump_main, s) != 0)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "rpc: cannot start a stream's pump thread");
    s->pump_started = true;

    pthread_mutex_lock(&s->mu);
    grpc_op end = { 0 };
    if (s->is_server) {
        /* Completes when the call is over: at once if the client cancels or vanishes, so recv and send
           learn of it without waiting for their own ops. */
        end.op = GRPC_OP_RECV_CLOSE_ON_SERVER;
        end.data.recv_close_on_server.cancelled = &s->cancelled;
    } else {
        end.op = GRPC_OP_RECV_STATUS_ON_CLIENT;
        end.data.recv_status_on_client.trailing_metadata = &s->recv_trailing;
        end.data.recv_status_on_client.status = &s->status;
        end.data.recv_status_on_client.status_details = &s->status_details;
        end.data.recv_status_on_client.error_string = &s->error_string;
    }
    bool ok = start_locked(s, &end, 1, TAG_END);
    grpc_op initial = { .op = GRPC_OP_SEND_INITIAL_METADATA };
    initial.data.send_initial_metadata.count = s->send_md_count;
    initial.data.send_initial_metadata.metadata = s->send_md;
    ok = ok && start_locked(s, &initial, 1, TAG_INITIAL_SENT);
    if (ok && !s->is_server) {
        grpc_op op = { .op = GRPC_OP_RECV_INITIAL_METADATA };
        op.data.recv_initial_metadata.recv_initial_metadata = &s->recv_initial;
        ok = start_locked(s, &op, 1, TAG_INITIAL_RECEIVED);
    }
    if (ok)
        start_recv_locked(s);
    pthread_mutex_unlock(&s->mu);
    return ok ? CV_OK : cv_error(CV_ERROR_CONNECTION, "rpc: could not start the call's first operations");
}

/* ---- operations ---- */

/* Why a call is over, for cv_error: "status UNAVAILABLE (14): failed to connect" or "cancelled". */
static cv_result call_error_locked(cv_rpc_stream *s) {
    if (!s->is_server && s->status_set)
        return cv_error(CV_ERROR_CONNECTION, "rpc stream to %s: status %s (%d): %s", s->peer,
                        cv_rpc_status_name(s->status), (int)s->status, s->status_message ? s->status_message : "");
    if (s->is_server && s->cancelled)
        return cv_error(CV_ERROR_CONNECTION, "rpc stream from %s: cancelled by the client or the connection was lost",
                        s->peer);
    if (s->is_server && s->ended)
        return cv_error(CV_ERROR_CONNECTION, "rpc stream from %s: the call has ended", s->peer);
    return cv_error(CV_ERROR_CONNECTION, "rpc stream %s %s: the call failed", s->is_server ? "from" : "to", s->peer);
}

cv_result cv_rpc_stream_recv(cv_rpc_stream *s, uint32_t timeout_ms, uint8_t **data, size_t *size) {
    if (!s || !data || !size)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_rpc_stream_recv: null stream or output");
    *data = NULL;
    *size = 0;
    uint64_t deadline = timeout_ms == CV_RPC_FOREVER ? CV_DEADLINE_NEVER : cv_deadline_after_ms(timeout_ms);
    cv_result r = CV_OK;
    bool timed_out = false;
    pthread_mutex_lock(&s->mu);
    for (;;) {
        if (s->in_head) {
            cv_rpc_msg *m = s->in_head;
            s->in_head = m->next;
            if (!s->in_head)
                s->in_tail = NULL;
            s->in_count--;
            *data = m->data;
            *size = m->size;
            free(m);
            start_recv_locked(s);
            break;
        }
        if (s->is_server) {
            if (s->eof)
                break; /* the client half-closed */
            if ((s->failed || s->ended) && !s->recv_in_flight) {
                r = call_error_locked(s);
                break;
            }
        } else if (s->ended && !s->recv_in_flight) { /* wait for the status, then for the last message */
            if (s->status != GRPC_STATUS_OK)
                r = call_error_locked(s);
            break; /* OK status: end of stream */
        }
        if (timed_out) {
            r = cv_error(CV_ERROR_TIMEOUT, "rpc stream %s %s: no message within %u ms", s->is_server ? "from" : "to",
                         s->peer, timeout_ms);
            break;
        }
        if (cv_cond_wait_until(&s->cond, &s->mu, deadline) == ETIMEDOUT)
            timed_out = true; /* one more look at the state before giving up */
    }
    pthread_mutex_unlock(&s->mu);
    return r;
}

/* Queues a byte buffer made from the message (copied, or wrapped). */
static cv_result send_buffer(cv_rpc_stream *s, grpc_byte_buffer *buffer, size_t size) {
    cv_rpc_out *o = calloc(1, sizeof *o);
    if (!o) {
        grpc_byte_buffer_destroy(buffer);
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "cv_rpc_stream_send: %zu bytes", size);
    }
    o->kind = CV_RPC_OUT_MESSAGE;
    o->size = size;
    o->buffer = buffer;
    cv_result r = CV_OK;
    pthread_mutex_lock(&s->mu);
    while (!s->failed && !s->ended && !s->send_closed && s->out_bytes > 0 &&
           s->out_bytes + size > CV_RPC_SEND_QUEUE_BYTES)
        pthread_cond_wait(&s->cond, &s->mu);
    if (s->send_closed)
        r = cv_error(CV_ERROR_BAD_STATE, "cv_rpc_stream_send: the stream's sending side was closed (%s)",
                     s->is_server ? "finish" : "close_send");
    else if (s->failed || s->ended || s->closing)
        r = call_error_locked(s);
    else
        enqueue_locked(s, o);
    pthread_mutex_unlock(&s->mu);
    if (r != CV_OK) {
        grpc_byte_buffer_destroy(o->buffer);
        free(o);
    }
    return r;
}

cv_result cv_rpc_stream_send(cv_rpc_stream *s, const void *data, size_t size) {
    if (!s || (!data && size))
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_rpc_stream_send: null stream or data");
    return send_buffer(s, cv_rpc_buffer_copy(data, size), size);
}

cv_result cv_rpc_stream_send_owned(cv_rpc_stream *s, void *data, size_t size) {
    if (!s || !data) {
        free(data);
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_rpc_stream_send_owned: null stream or data");
    }
    grpc_slice slice = grpc_slice_new(data, size, free); /* gRPC frees it once sent */
    grpc_byte_buffer *bb = grpc_raw_byte_buffer_create(&slice, 1);
    grpc_slice_unref(slice);
    return send_buffer(s, bb, size);
}

cv_result cv_rpc_stream_close_send(cv_rpc_stream *s) {
    if (!s)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_rpc_stream_close_send: null stream");
    if (s->is_server)
        return cv_error(CV_ERROR_BAD_STATE, "cv_rpc_stream_close_send: server streams end with finish");
    cv_rpc_out *o = calloc(1, sizeof *o);
    if (!o)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "cv_rpc_stream_close_send");
    o->kind = CV_RPC_OUT_CLOSE;
    cv_result r = CV_OK;
    pthread_mutex_lock(&s->mu);
    if (s->send_closed || s->failed || s->ended || s->closing) {
        free(o); /* already closed, or nothing left to close */
    } else {
        s->send_closed = true;
        enqueue_locked(s, o);
    }
    pthread_mutex_unlock(&s->mu);
    return r;
}

void cv_rpc_stream_finish(cv_rpc_stream *s, int status, const char *message) {
    if (!s || !s->is_server)
        return;
    cv_rpc_out *o = calloc(1, sizeof *o);
    pthread_mutex_lock(&s->mu);
    if (!o || s->send_closed || s->failed || s->ended || s->closing) {
        free(o);
    } else {
        s->send_closed = true;
        s->status_set = true;
        s->status = (grpc_status_code)status;
        s->status_message = strdup(message ? message : "");
        s->status_details = grpc_slice_from_copied_string(message ? message : "");
        o->kind = CV_RPC_OUT_STATUS;
        enqueue_locked(s, o);
    }
    pthread_mutex_unlock(&s->mu);
}

int cv_rpc_stream_status(cv_rpc_stream *s, char *message, size_t cap) {
    if (message && cap)
        message[0] = 0;
    if (!s)
        return -1;
    pthread_mutex_lock(&s->mu);
    int status = -1;
    if (s->status_set && (s->is_server || s->ended)) {
        status = (int)s->status;
        if (message && cap && s->status_message)
            snprintf(message, cap, "%s", s->status_message);
    }
    pthread_mutex_unlock(&s->mu);
    return status;
}

void cv_rpc_stream_cancel(cv_rpc_stream *s) {
    if (!s)
        return;
    pthread_mutex_lock(&s->mu);
    if (!s->closing && !s->ended)
        grpc_call_cancel(s->call, NULL);
    pthread_mutex_unlock(&s->mu);
}

void cv_rpc_stream_cancel_with_status(cv_rpc_stream *s, int status, const char *message) {
    if (!s || !s->is_server)
        return;
    pthread_mutex_lock(&s->mu);
    if (!s->closing && !s->ended)
        grpc_call_cancel_with_status(s->call, (grpc_status_code)status, message ? message : "", NULL);
    pthread_mutex_unlock(&s->mu);
}

const char *cv_rpc_stream_peer(cv_rpc_stream *s) { return s ? s->peer : ""; }

const char *cv_rpc_stream_metadata(cv_rpc_stream *s, const char *key) {
    if (!s || !key)
        return NULL;
    for (size_t i = 0; i < s->md_count; i++)
        if (strcmp(s->md[2 * i], key) == 0)
            return s->md[2 * i + 1];
    return NULL;
}

void cv_rpc_stream_wait_ended(cv_rpc_stream *s) {
    pthread_mutex_lock(&s->mu);
    while (!s->ended && s->pump_started)
        pthread_cond_wait(&s->cond, &s->mu);
    pthread_mutex_unlock(&s->mu);
}

void cv_rpc_stream_teardown(cv_rpc_stream *s) {
    if (!s)
        return;
    pthread_mutex_lock(&s->mu);
    if (!s->ended)
        grpc_call_cancel(s->call, NULL); /* every op in flight completes (failed) */
    s->closing = true;
    pthread_mutex_unlock(&s->mu);
    if (s->pump_started) {
        grpc_completion_queue_shutdown(s->cq);
        pthread_join(s->pump, NULL);
        grpc_completion_queue_destroy(s->cq);
    } else {
        cv_rpc_cq_drain_and_destroy(s->cq);
    }
    grpc_call_unref(s->call);

    while (s->in_head) {
        cv_rpc_msg *m = s->in_head;
        s->in_head = m->next;
        free(m->data);
        free(m);
    }
    while (s->out_head) {
        cv_rpc_out *o = s->out_head;
        s->out_head = o->next;
        if (o->buffer)
            grpc_byte_buffer_destroy(o->buffer);
        free(o);
    }
    if (s->recv_buffer)
        grpc_byte_buffer_destroy(s->recv_buffer);
    for (size_t i = 0; i < s->send_md_count; i++) {
        grpc_slice_unref(s->send_md[i].key);
        grpc_slice_unref(s->send_md[i].value);
    }
    free(s->send_md);
    for (size_t i = 0; i < 2 * s->md_count; i++)
        free(s->md[i]);
    free(s->md);
    grpc_slice_unref(s->status_details);
    gpr_free((void *)s->error_string);
    grpc_metadata_array_destroy(&s->recv_initial);
    grpc_metadata_array_destroy(&s->recv_trailing);
    free(s->status_message);
    free(s->peer);
    pthread_cond_destroy(&s->cond);
    pthread_mutex_destroy(&s->mu);
    free(s);
}
