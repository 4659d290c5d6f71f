/* The server side of the RPC layer: an acceptor thread on the server's completion queue, one handler thread
 * per accepted call (plus the stream's pump), refusals answered on the acceptor.
 *
 * Calls are requested with grpc_server_request_call (no registered methods): one path for every call,
 * and unknown methods can be answered UNIMPLEMENTED. Each outstanding request binds a fresh completion
 * queue of its own (cq_bound_to_call need not be the notification queue, nor registered), which the
 * accepted call then keeps. */
#include "rpc_internal.h"

#include <grpc/grpc_security.h>
#include <grpc/support/alloc.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "corvid/clock.h"
#include "corvid/log.h"

#define ACCEPT_SLOTS 4         /* calls requested at once */
#define REFUSE_TIMEOUT_MS 1000 /* a refusal's status must be out by then, or the call is cancelled */
#define UNARY_REQUEST_TIMEOUT_MS 10000

typedef struct accept_slot {
    cv_rpc_server *server;
    bool pending;
    grpc_call *call;
    grpc_call_details details;
    grpc_metadata_array metadata;
    grpc_completion_queue *cq;
} accept_slot;

/* One accepted call with a thread of its own. */
typedef struct handler {
    struct handler *next, *prev;
    cv_rpc_server *server;
    pthread_t thread;
    bool has_thread;
    const char *method; /* the server's copy */
    bool is_stream;
    cv_rpc_stream *stream; /* stream handlers */
    grpc_call *call;       /* unary handlers */
    grpc_completion_queue *cq;
} handler;

struct cv_rpc_server {
    grpc_server *server;
    grpc_completion_queue *cq;
    int port;
    pthread_t acceptor;
    bool acceptor_started;
    int shutdown_tag; /* its address is the tag */
    accept_slot slots[ACCEPT_SLOTS];

    pthread_mutex_t mu;
    pthread_cond_t cond; /* a handler finished */
    bool draining;
    bool shutting_down;
    uint32_t active_streams, active_unary, max_streams;
    handler *live; /* running handlers */
    handler *done; /* finished, to be joined */

    void (*on_stream)(cv_rpc_stream *, const char *, void *);
    int (*on_unary)(const char *, const void *, size_t, void **, size_t *, char *, size_t, void *);
    int (*on_call)(const char *, const char *, const cv_rpc_metadata *, uint32_t, char *, size_t, void *);
    void *user;
    char **stream_methods, **unary_methods; /* NULL-terminated copies */
};

/* The one place where the server's credentials are made: plaintext, or TLS with the certificate and key files,
 * requiring client certificates signed by the client CA when one is given. */
static cv_result server_credentials(const cv_rpc_server_config *cfg, grpc_server_credentials **out) {
    if (!cfg->tls_cert_file && !cfg->tls_key_file) {
        if (cfg->tls_client_ca_file)
            return cv_error(CV_ERROR_INVALID_ARGUMENT,
                            "rpc server: a TLS client CA ('%s') without the server's "
                            "certificate and key",
                            cfg->tls_client_ca_file);
        *out = grpc_insecure_server_credentials_create();
        return CV_OK;
    }
    if (!cfg->tls_cert_file || !cfg->tls_key_file)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "rpc server: TLS %s given without its %s",
                        cfg->tls_cert_file ? "certificate" : "key", cfg->tls_cert_file ? "key" : "certificate");
    char *cert = NULL, *key = NULL, *ca = NULL;
    cv_result r = cv_rpc_read_pem_file(cfg->tls_cert_file, "TLS certificate", &cert);
    if (r == CV_OK)
        r = cv_rpc_read_pem_file(cfg->tls_key_file, "TLS key", &key);
    if (r == CV_OK && cfg->tls_client_ca_file)
        r = cv_rpc_read_pem_file(cfg->tls_client_ca_file, "TLS client CA", &ca);
    if (r == CV_OK) {
        grpc_ssl_pem_key_cert_pair pair = { .private_key = key, .cert_chain = cert };
        *out = grpc_ssl_server_credentials_create_ex(ca, &pair, 1,
                                                     ca ? GRPC_SSL_REQUEST_AND_REQUIRE_CLIENT_CERTIFICATE_AND_VERIFY
                                                        : GRPC_SSL_DONT_REQUEST_CLIENT_CERTIFICATE,
                                                     NULL);
        if (!*out)
            r = cv_error(CV_ERROR_INVALID_ARGUMENT, "rpc server: gRPC refused the TLS files ('%s', '%s')",
                         cfg->tls_cert_file, cfg->tls_key_file);
    }
    free(cert);
    free(ca);
    if (key) {
        memset(key, 0, strlen(key));
        free(key);
    }
    return r;
}

/* Asks the server's on_call whether a call may run: 0, or a refusal status with `reason` filled. */
static grpc_status_code admit(cv_rpc_server *s, accept_slot *slot, const char *method, char *reason, size_t cap) {
    if (!s->on_call)
        return GRPC_STATUS_OK;
    const grpc_metadata_array *md = &slot->metadata;
    cv_rpc_metadata *items = calloc(md->count ? md->count : 1, sizeof *items);
    char *peer = grpc_call_get_peer(slot->call);
    bool ok = items != NULL;
    for (size_t i = 0; ok && i < md->count; i++) {
        items[i].key = cv_rpc_slice_to_string(md->metadata[i].key);
        items[i].value = cv_rpc_slice_to_string(md->metadata[i].value);
        ok = items[i].key && items[i].value;
    }
    grpc_status_code code = GRPC_STATUS_RESOURCE_EXHAUSTED;
    snprintf(reason, cap, "node is out of memory");
    if (ok) {
        reason[0] = 0;
        code = (grpc_status_code)s->on_call(method, peer ? peer : "", items, (uint32_t)md->count, reason, cap,
                                            s->user);
        reason[cap - 1] = 0;
    }
    for (size_t i = 0; items && i < md->count; i++) {
        if (items[i].value) /* may be a secret */
            memset((char *)items[i].value, 0, strlen(items[i].value));
        free((char *)items[i].key);
        free((char *)items[i].value);
    }
    free(items);
    gpr_free(peer);
    return code;
}

static grpc_arg int_arg(const char *key, int value) {
    grpc_arg a = { .type = GRPC_ARG_INTEGER, .key = (char *)key };
    a.value.integer = value;
    return a;
}

static char **copy_methods(const char *const *list, bool *ok) {
    size_t n = 0;
    while (list && list[n])
        n++;
    char **copy = calloc(n + 1, sizeof *copy);
    if (!copy) {
        *ok = false;
        return NULL;
    }
    for (size_t i = 0; i < n; i++)
        if (!(copy[i] = strdup(list[i])))
            *ok = false;
    return copy;
}

static void free_methods(char **list) {
    for (size_t i = 0; list && list[i]; i++)
        free(list[i]);
    free(list);
}

static const char *find_method(char **list, grpc_slice method) {
    for (size_t i = 0; list && list[i]; i++)
        if (grpc_slice_str_cmp(method, list[i]) == 0)
            return list[i];
    return NULL;
}

/* ---- accepting ---- */

static bool request_call(cv_rpc_server *s, accept_slot *slot) {
    slot->cq = grpc_completion_queue_create_for_next(NULL);
    slot->call = NULL;
    grpc_call_details_init(&slot->details);
    grpc_metadata_array_init(&slot->metadata);
    grpc_call_error e = grpc_server_request_call(s->server, &slot->call, &slot->details, &slot->metadata, slot->cq,
                                                 s->cq, slot);
    if (e != GRPC_CALL_OK) {
        cv_log(CV_LOG_ERROR, "rpc", "server request_call: %s", grpc_call_error_to_string(e));
        grpc_call_details_destroy(&slot->details);
        grpc_metadata_array_destroy(&slot->metadata);
        cv_rpc_cq_drain_and_destroy(slot->cq);
        slot->cq = NULL;
        return false;
    }
    slot->pending = true;
    return true;
}

/* Answers a call with a status and nothing else, on the calling thread, then frees it and its queue.
 * Initial metadata goes too: in 1.51 a status batch without it never completed (seen here: the batch
 * waited out REFUSE_TIMEOUT_MS and the client saw CANCELLED instead of our status). */
static void refuse(grpc_call *call, grpc_completion_queue *cq, grpc_status_code code, const char *message) {
    int cancelled = 0;
    grpc_slice details = grpc_slice_from_copied_string(message);
    grpc_op ops[3] = { { .op = GRPC_OP_SEND_STATUS_FROM_SERVER },
                       { .op = GRPC_OP_RECV_CLOSE_ON_SERVER },
                       { .op = GRPC_OP_SEND_INITIAL_METADATA } };
    ops[0].data.send_status_from_server.status = code;
    ops[0].data.send_status_from_server.status_details = &details;
    ops[1].data.recv_close_on_server.cancelled = &cancelled;
    if (grpc_call_start_batch(call, ops, 3, (void *)1, NULL) == GRPC_CALL_OK) {
        grpc_event ev = grpc_completion_queue_next(cq, cv_rpc_deadline(REFUSE_TIMEOUT_MS), NULL);
        if (ev.type == GRPC_QUEUE_TIMEOUT) {
            grpc_call_cancel(call, NULL);
            grpc_completion_queue_next(cq, gpr_inf_future(GPR_CLOCK_REALTIME), NULL);
        }
    }
    grpc_call_unref(call);
    cv_rpc_cq_drain_and_destroy(cq);
    grpc_slice_unref(details);
}

static void handler_done(handler *h) {
    cv_rpc_server *s = h->server;
    pthread_mutex_lock(&s->mu);
    if (h->is_stream)
        s->active_streams--;
    else
        s->active_unary--;
    if (h->prev)
        h->prev->next = h->next;
    else
        s->live = h->next;
    if (h->next)
        h->next->prev = h->prev;
    h->prev = NULL;
    h->next = s->done;
    s->done = h;
    pthread_cond_broadcast(&s->cond);
    pthread_mutex_unlock(&s->mu);
}

static void *stream_main(void *arg) {
    handler *h = arg;
    cv_rpc_server *s = h->server;
    if (cv_rpc_stream_begin(h->stream, NULL, 0) == CV_OK) {
        s->on_stream(h->stream, h->method, s->user);
        cv_rpc_stream_finish(h->stream, GRPC_STATUS_OK, "");
        cv_rpc_stream_wait_ended(h->stream);
    } else {
        cv_log(CV_LOG_WARNING, "rpc", "stream '%s': %s", h->method, cv_last_error());
    }
    /* Out of the handler under the lock first: cv_rpc_server_finish_streams may be looking at it. */
    pthread_mutex_lock(&s->mu);
    cv_rpc_stream *stream = h->stream;
    h->stream = NULL;
    pthread_mutex_unlock(&s->mu);
    cv_rpc_stream_teardown(stream);
    handler_done(h);
    return NULL;
}

/* Waits for the one batch in flight on a unary call's queue; cancels the call if it takes too long. */
static bool unary_wait(handler *h, uint32_t timeout_ms) {
    grpc_event ev = grpc_completion_queue_next(h->cq, cv_rpc_deadline(timeout_ms), NULL);
    if (ev.type == GRPC_QUEUE_TIMEOUT) {
        grpc_call_cancel(h->call, NULL);
        ev = grpc_completion_queue_next(h->cq, gpr_inf_future(GPR_CLOCK_REALTIME), NULL);
    }
    return ev.type == GRPC_OP_COMPLETE && ev.success;
}

static void *unary_main(void *arg) {
    handler *h = arg;
    cv_rpc_server *s = h->server;
    grpc_byte_buffer *request = NULL;
    grpc_op first[2] = { { .op = GRPC_OP_SEND_INITIAL_METADATA }, { .op = GRPC_OP_RECV_MESSAGE } };
    first[1].data.recv_message.recv_message = &request;
    bool ok = grpc_call_start_batch(h->call, first, 2, (void *)1, NULL) == GRPC_CALL_OK &&
              unary_wait(h, UNARY_REQUEST_TIMEOUT_MS);

    grpc_status_code code = GRPC_STATUS_OK;
    char message[512] = "";
    void *response = NULL;
    size_t response_size = 0;
    if (ok && !request) {
        code = GRPC_STATUS_INVALID_ARGUMENT;
        snprintf(message, sizeof message, "unary call '%s' without a request message", h->method);
    } else if (ok) {
        uint8_t *data = NULL;
        size_t size = 0;
        if (cv_rpc_buffer_read(request, &data, &size) != CV_OK) {
            code = GRPC_STATUS_INTERNAL;
            snprintf(message, sizeof message, "%s", cv_last_error());
        } else {
            code = (grpc_status_code)s->on_unary(h->method, data, size, &response, &response_size, message,
                                                 sizeof message, s->user);
            message[sizeof message - 1] = 0;
        }
        free(data);
    }
    if (request)
        grpc_byte_buffer_destroy(request);

    if (ok) {
        int cancelled = 0;
        grpc_slice details = grpc_slice_from_copied_string(message);
        grpc_byte_buffer *reply = code == GRPC_STATUS_OK ? cv_rpc_buffer_copy(response, response_size) : NULL;
        grpc_op last[3] = { { .op = GRPC_OP_SEND_STATUS_FROM_SERVER },
                            { .op = GRPC_OP_RECV_CLOSE_ON_SERVER },
                            { .op = GRPC_OP_SEND_MESSAGE } };
        last[0].data.send_status_from_server.status = code;
        last[0].data.send_status_from_server.status_details = &details;
        last[1].data.recv_close_on_server.cancelled = &cancelled;
        last[2].data.send_message.send_message = reply;
        if (grpc_call_start_batch(h->call, last, reply ? 3 : 2, (void *)2, NULL) == GRPC_CALL_OK)
            unary_wait(h, UNARY_REQUEST_TIMEOUT_MS);
        if (reply)
            grpc_byte_buffer_destroy(reply);
        grpc_slice_unref(details);
    }
    free(response);
    grpc_call_unref(h->call);
    cv_rpc_cq_drain_and_destroy(h->cq);
    h->call = NULL;
    h->cq = NULL;
    handler_done(h);
    return NULL;
}

/* Takes the accepted call out of the slot: runs it on a handler thread or refuses it. */
static void dispatch(cv_rpc_server *s, accept_slot *slot) {
    grpc_call *call = slot->call;
    grpc_completion_queue *cq = slot->cq;
    const char *stream_method = find_method(s->stream_methods, slot->details.method);
    const char *unary_method = stream_method ? NULL : find_method(s->unary_methods, slot->details.method);
    char reason[300];

    if (!stream_method && !unary_method) {
        char *name = cv_rpc_slice_to_string(slot->details.method);
        snprintf(reason, sizeof reason, "method '%s' is not served by this node", name ? name : "?");
        free(name);
        refuse(call, cq, GRPC_STATUS_UNIMPLEMENTED, reason);
        return;
    }
    grpc_status_code denied = admit(s, slot, stream_method ? stream_method : unary_method, reason, sizeof reason);
    if (denied != GRPC_STATUS_OK) {
        refuse(call, cq, denied, reason);
        return;
    }
    pthread_mutex_lock(&s->mu);
    grpc_status_code refusal = GRPC_STATUS_OK;
    if (stream_method && s->draining) {
        refusal = GRPC_STATUS_UNAVAILABLE;
        snprintf(reason, sizeof reason, "node is draining");
    } else if (stream_method && s->active_streams >= s->max_streams) {
        refusal = GRPC_STATUS_RESOURCE_EXHAUSTED;
        snprintf(reason, sizeof reason, "node runs %u streams, its limit", s->max_streams);
    } else if (unary_method && s->active_unary >= CV_RPC_MAX_UNARY_CALLS) {
        refusal = GRPC_STATUS_RESOURCE_EXHAUSTED;
        snprintf(reason, sizeof reason, "node runs %u unary calls, its limit", CV_RPC_MAX_UNARY_CALLS);
    }
    handler *h = refusal == GRPC_STATUS_OK ? calloc(1, sizeof *h) : NULL;
    if (refusal == GRPC_STATUS_OK && !h) {
        refusal = GRPC_STATUS_RESOURCE_EXHAUSTED;
        snprintf(reason, sizeof reason, "node is out of memory");
    }
    if (h) {
        h->server = s;
        h->is_stream = stream_method != NULL;
        h->method = stream_method ? stream_method : unary_method;
        if (h->is_stream)
            s->active_streams++;
        else
            s->active_unary++;
        h->next = s->live;
        if (s->live)
            s->live->prev = h;
        s->live = h;
    }
    pthread_mutex_unlock(&s->mu);
    if (!h) {
        refuse(call, cq, refusal, reason);
        return;
    }

    int started = -1;
    if (h->is_stream) {
        if (cv_rpc_stream_create(call, cq, true, &h->stream) == CV_OK) {
            call = NULL; /* the stream owns call and queue now */
            cq = NULL;
            if (cv_rpc_stream_set_request_metadata(h->stream, &slot->metadata) == CV_OK)
                started = pthread_create(&h->thread, NULL, stream_main, h);
        }
    } else {
        h->call = call;
        h->cq = cq;
        started = pthread_create(&h->thread, NULL, unary_main, h);
        if (started == 0)
            call = NULL, cq = NULL;
    }
    if (started == 0) {
        h->has_thread = true;
        return;
    }
    cv_log(CV_LOG_ERROR, "rpc", "cannot start a handler for '%s'", h->method);
    if (h->stream)
        cv_rpc_stream_teardown(h->stream); /* cancels the call */
    if (call)
        refuse(call, cq, GRPC_STATUS_RESOURCE_EXHAUSTED, "node cannot start a thread");
    handler_done(h); /* freed by the next reap; no thread to join */
}

/* Joins and frees finished handlers. */
static void reap(cv_rpc_server *s) {
    pthread_mutex_lock(&s->mu);
    handler *list = s->done;
    s->done = NULL;
    pthread_mutex_unlock(&s->mu);
    while (list) {
        handler *h = list;
        list = h->next;
        if (h->has_thread)
            pthread_join(h->thread, NULL);
        free(h);
    }
}

static void *acceptor_main(void *arg) {
    cv_rpc_server *s = arg;
    bool shutdown_seen = false;
    for (;;) {
        grpc_event ev = grpc_completion_queue_next(s->cq, gpr_inf_future(GPR_CLOCK_REALTIME), NULL);
        if (ev.type == GRPC_QUEUE_SHUTDOWN)
            break;
        if (ev.type != GRPC_OP_COMPLETE)
            continue;
        if (ev.tag == &s->shutdown_tag) {
            shutdown_seen = true;
        } else {
            accept_slot *slot = ev.tag;
            slot->pending = false;
            if (ev.success && slot->call) {
                dispatch(s, slot);
            } else {
                if (slot->call)
                    grpc_call_unref(slot->call);
                cv_rpc_cq_drain_and_destroy(slot->cq);
            }
            slot->cq = NULL;
            grpc_call_details_destroy(&slot->details);
            grpc_metadata_array_destroy(&slot->metadata);
            pthread_mutex_lock(&s->mu);
            bool stop = s->shutting_down;
            pthread_mutex_unlock(&s->mu);
            if (!stop)
                request_call(s, slot);
        }
        reap(s);
        bool pending = false;
        for (int i = 0; i < ACCEPT_SLOTS; i++)
            pending |= s->slots[i].pending;
        if (shutdown_seen && !pending)
            break;
    }
    return NULL;
}

/* ---- the server object ---- */

static void free_server(cv_rpc_server *s) {
    free_methods(s->stream_methods);
    free_methods(s->unary_methods);
    pthread_cond_destroy(&s->cond);
    pthread_mutex_destroy(&s->mu);
    free(s);
}

cv_result cv_rpc_server_start(const cv_rpc_server_config *config, cv_rpc_server **out) {
    if (!config || !out || !config->listen)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_rpc_server_start: null config, out or listen address");
    if ((config->stream_methods && config->stream_methods[0] && !config->on_stream) ||
        (config->unary_methods && config->unary_methods[0] && !config->on_unary))
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_rpc_server_start: methods listed without their handler");
    cv_rpc_server *s = calloc(1, sizeof *s);
    if (!s)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "cv_rpc_server_start");
    pthread_mutex_init(&s->mu, NULL);
    cv_cond_init(&s->cond);
    bool ok = true;
    s->stream_methods = copy_methods(config->stream_methods, &ok);
    s->unary_methods = copy_methods(config->unary_methods, &ok);
    if (!ok) {
        free_server(s);
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "cv_rpc_server_start: method lists");
    }
    s->on_stream = config->on_stream;
    s->on_unary = config->on_unary;
    s->on_call = config->on_call;
    s->user = config->user;
    s->max_streams = config->max_streams ? config->max_streams : 1024;
    uint32_t max_message = config->max_message_bytes ? config->max_message_bytes : CV_RPC_DEFAULT_MAX_MESSAGE;
    int max_int = max_message > INT32_MAX ? INT32_MAX : (int)max_message;

    grpc_arg args[] = {
        int_arg(GRPC_ARG_MAX_RECEIVE_MESSAGE_LENGTH, max_int),
        int_arg(GRPC_ARG_MAX_SEND_MESSAGE_LENGTH, max_int),
        /* Clients ping every keepalive_ms (default 10 s), with or without calls: allow it, never strike. */
        int_arg(GRPC_ARG_HTTP2_MIN_RECV_PING_INTERVAL_WITHOUT_DATA_MS, 1000),
        int_arg(GRPC_ARG_HTTP2_MAX_PING_STRIKES, 0),
        /* The server pings too, so a vanished client frees its stream. */
        int_arg(GRPC_ARG_KEEPALIVE_TIME_MS, 10000),
        int_arg(GRPC_ARG_KEEPALIVE_TIMEOUT_MS, 5000),
        int_arg(GRPC_ARG_HTTP2_MAX_PINGS_WITHOUT_DATA, 0),
        /* Two servers must not silently share one port. */
        int_arg(GRPC_ARG_ALLOW_REUSEPORT, 0),
    };
    grpc_channel_args server_args = { .num_args = sizeof args / sizeof args[0], .args = args };

    grpc_init();
    grpc_server_credentials *creds = NULL;
    cv_result r = server_credentials(config, &creds);
    if (r != CV_OK) {
        grpc_shutdown();
        free_server(s);
        return r;
    }
    s->server = grpc_server_create(&server_args, NULL);
    s->cq = grpc_completion_queue_create_for_next(NULL);
    grpc_server_register_completion_queue(s->server, s->cq, NULL);
    s->port = grpc_server_add_http2_port(s->server, config->listen, creds);
    grpc_server_credentials_release(creds);
    if (s->port == 0) {
        grpc_server_destroy(s->server);
        cv_rpc_cq_drain_and_destroy(s->cq);
        grpc_shutdown();
        free_server(s);
        return cv_error(CV_ERROR_CONNECTION, "cv_rpc_server_start: cannot listen on '%s'", config->listen);
    }
    grpc_server_start(s->server);
    for (int i = 0; i < ACCEPT_SLOTS; i++) {
        s->slots[i].server = s;
        request_call(s, &s->slots[i]);
    }
    if (pthread_create(&s->acceptor, NULL, acceptor_main, s) != 0) {
        /* The acceptor is what drains the queue: with none, shut down here. */
        cv_rpc_server_destroy(s, 0);
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "cv_rpc_server_start: cannot start the acceptor thread");
    }
    s->acceptor_started = true;
    *out = s;
    return CV_OK;
}

int cv_rpc_server_port(const cv_rpc_server *s) { return s ? s->port : 0; }

void cv_rpc_server_drain(cv_rpc_server *s) {
    if (!s)
        return;
    pthread_mutex_lock(&s->mu);
    s->draining = true;
    pthread_mutex_unlock(&s->mu);
}

uint32_t cv_rpc_server_active_streams(const cv_rpc_server *s) {
    if (!s)
        return 0;
    cv_rpc_server *m = (cv_rpc_server *)s;
    pthread_mutex_lock(&m->mu);
    uint32_t n = m->active_streams;
    pthread_mutex_unlock(&m->mu);
    return n;
}

/* Waits on s->cond (s->mu held) until no stream runs or the deadline timeout_ms from now passes. */
static void wait_streams_locked(cv_rpc_server *s, uint32_t timeout_ms) {
    uint64_t deadline = cv_deadline_after_ms(timeout_ms);
    while (s->active_streams > 0 && timeout_ms > 0 && cv_cond_wait_until(&s->cond, &s->mu, deadline) == 0) {
    }
}

uint32_t cv_rpc_server_wait_streams(cv_rpc_server *s, uint32_t timeout_ms) {
    if (!s)
        return 0;
    pthread_mutex_lock(&s->mu);
    wait_streams_locked(s, timeout_ms);
    uint32_t left = s->active_streams;
    pthread_mutex_unlock(&s->mu);
    return left;
}

void cv_rpc_server_finish_streams(cv_rpc_server *s, int status, const char *message) {
    if (!s)
        return;
    pthread_mutex_lock(&s->mu);
    for (handler *h = s->live; h; h = h->next)
        if (h->is_stream && h->stream)
            cv_rpc_stream_cancel_with_status(h->stream, status, message);
    pthread_mutex_unlock(&s->mu);
}

void cv_rpc_server_destroy(cv_rpc_server *s, uint32_t timeout_ms) {
    if (!s)
        return;
    /* 1. Refuse new streams; give running ones their time. */
    pthread_mutex_lock(&s->mu);
    s->draining = true;
    wait_streams_locked(s, timeout_ms);
    s->shutting_down = true;
    pthread_mutex_unlock(&s->mu);

    /* 2. Stop the core: no new calls, then every call still running fails (handlers see recv/send fail). */
    grpc_server_shutdown_and_notify(s->server, s->cq, &s->shutdown_tag);
    grpc_server_cancel_all_calls(s->server);

    /* 3. The acceptor ends once the shutdown tag and every outstanding request came back. */
    if (s->acceptor_started)
        pthread_join(s->acceptor, NULL);
    else
        acceptor_main(s); /* start failed to make the thread: drain here */

    /* 4. Every handler returns (their calls are dead); join them. */
    pthread_mutex_lock(&s->mu);
    while (s->active_streams > 0 || s->active_unary > 0)
        pthread_cond_wait(&s->cond, &s->mu);
    pthread_mutex_unlock(&s->mu);
    reap(s);

    /* 5. Free the core's objects, in the order the core wants. */
    grpc_server_destroy(s->server);
    cv_rpc_cq_drain_and_destroy(s->cq);
    for (int i = 0; i < ACCEPT_SLOTS; i++)
        if (s->slots[i].cq) {
            grpc_call_details_destroy(&s->slots[i].details);
            grpc_metadata_array_destroy(&s->slots[i].metadata);
            cv_rpc_cq_drain_and_destroy(s->slots[i].cq);
        }
    grpc_shutdown();
    free_server(s);
}
