/* The client side: one channel per cv_rpc_client, bidirectional streams on it, unary calls. */
#include "rpc_internal.h"

#include <assert.h>
#include <grpc/grpc_security.h>
#include <grpc/support/alloc.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

struct cv_rpc_client {
    grpc_channel *channel;
    char *target;
    atomic_uint streams;   /* open streams, to catch destroy-before-streams */
};

/* The one place where the client's credentials are made: TLS or token credentials go here. */
static grpc_channel_credentials *client_credentials(void) {
    return grpc_insecure_credentials_create();
}

static grpc_arg int_arg(const char *key, int value) {
    grpc_arg a = {.type = GRPC_ARG_INTEGER, .key = (char *)key};
    a.value.integer = value;
    return a;
}

static int clamp_int(uint32_t v) {
    return v > INT32_MAX ? INT32_MAX : (int)v;
}

cv_result cv_rpc_client_create(const char *target, const cv_rpc_client_config *config, cv_rpc_client **out) {
    if (!target || !*target || !out)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_rpc_client_create: null or empty target, or null out");
    cv_rpc_client_config cfg = config ? *config : (cv_rpc_client_config){0};
    uint32_t max_message = cfg.max_message_bytes ? cfg.max_message_bytes : CV_RPC_DEFAULT_MAX_MESSAGE;
    uint32_t keepalive = cfg.keepalive_ms ? cfg.keepalive_ms : 10000;
    uint32_t keepalive_timeout = cfg.keepalive_timeout_ms ? cfg.keepalive_timeout_ms : 5000;
    uint32_t connect_timeout = cfg.connect_timeout_ms ? cfg.connect_timeout_ms : 5000;

    cv_rpc_client *c = calloc(1, sizeof *c);
    char *name = strdup(target);
    if (!c || !name) {
        free(c);
        free(name);
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "cv_rpc_client_create: '%s'", target);
    }
    grpc_arg args[] = {
        int_arg(GRPC_ARG_MAX_RECEIVE_MESSAGE_LENGTH, clamp_int(max_message)),
        int_arg(GRPC_ARG_MAX_SEND_MESSAGE_LENGTH, clamp_int(max_message)),
        int_arg(GRPC_ARG_KEEPALIVE_TIME_MS, clamp_int(keepalive)),
        int_arg(GRPC_ARG_KEEPALIVE_TIMEOUT_MS, clamp_int(keepalive_timeout)),
        int_arg(GRPC_ARG_KEEPALIVE_PERMIT_WITHOUT_CALLS, 1),
        int_arg(GRPC_ARG_HTTP2_MAX_PINGS_WITHOUT_DATA, 0),
        /* The core's minimum connect timeout: one attempt may take this long before calls fail. */
        int_arg(GRPC_ARG_MIN_RECONNECT_BACKOFF_MS, clamp_int(connect_timeout)),
        /* A restarted node is found again within seconds, not the default two minutes. */
        int_arg(GRPC_ARG_MAX_RECONNECT_BACKOFF_MS, 5000),
        /* Streams are long and large: no retry buffering. */
        int_arg(GRPC_ARG_ENABLE_RETRIES, 0),
        /* Each client has its own connection (the core otherwise shares subchannels process-wide). */
        int_arg(GRPC_ARG_USE_LOCAL_SUBCHANNEL_POOL, 1),
    };
    grpc_channel_args channel_args = {.num_args = sizeof args / sizeof args[0], .args = args};

    grpc_init();
    grpc_channel_credentials *creds = client_credentials();
    c->channel = grpc_channel_create(target, creds, &channel_args);
    grpc_channel_credentials_release(creds);
    c->target = name;
    *out = c;
    return CV_OK;
}

void cv_rpc_client_destroy(cv_rpc_client *c) {
    if (!c)
        return;
    unsigned open = atomic_load(&c->streams);
    if (open)
        fprintf(stderr, "corvid rpc: client '%s' destroyed with %u streams open\n", c->target, open);
    assert(open == 0 && "destroy the client's streams first");
    grpc_channel_destroy(c->channel);
    grpc_shutdown();
    free(c->target);
    free(c);
}

static cv_result check_metadata(const cv_rpc_metadata *md, uint32_t count) {
    for (uint32_t i = 0; i < count; i++) {
        if (!md[i].key || !md[i].value)
            return cv_error(CV_ERROR_INVALID_ARGUMENT, "rpc metadata %u: null key or value", i);
        grpc_slice key = grpc_slice_from_static_string(md[i].key);
        grpc_slice value = grpc_slice_from_static_string(md[i].value);
        if (!grpc_header_key_is_legal(key) || grpc_is_binary_header(key))
            return cv_error(CV_ERROR_INVALID_ARGUMENT, "rpc metadata %u: key '%s' is not a legal text header key",
                            i, md[i].key);
        if (!grpc_header_nonbin_value_is_legal(value))
            return cv_error(CV_ERROR_INVALID_ARGUMENT, "rpc metadata %u ('%s'): value is not printable ASCII", i,
                            md[i].key);
    }
    return CV_OK;
}

static grpc_call *create_call(cv_rpc_client *c, grpc_completion_queue *cq, const char *method,
                              gpr_timespec deadline) {
    grpc_slice m = grpc_slice_from_copied_string(method);
    grpc_call *call = grpc_channel_create_call(c->channel, NULL, GRPC_PROPAGATE_DEFAULTS, cq, m, NULL, deadline, NULL);
    grpc_slice_unref(m);
    return call;
}

cv_result cv_rpc_client_open(cv_rpc_client *c, const char *method, const cv_rpc_metadata *metadata, uint32_t count,
                             cv_rpc_stream **out) {
    if (!c || !method || method[0] != '/' || !out || (count && !metadata))
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_rpc_client_open: null client/out/metadata or method '%s' "
                        "not of the form /package.Service/Method", method ? method : "(null)");
    cv_result r = check_metadata(metadata, count);
    if (r != CV_OK)
        return r;
    grpc_completion_queue *cq = grpc_completion_queue_create_for_next(NULL);
    grpc_call *call = create_call(c, cq, method, gpr_inf_future(GPR_CLOCK_REALTIME));
    if (!call) {
        cv_rpc_cq_drain_and_destroy(cq);
        return cv_error(CV_ERROR_CONNECTION, "cv_rpc_client_open: '%s' on %s: the core made no call", method,
                        c->target);
    }
    cv_rpc_stream *s;
    r = cv_rpc_stream_create(call, cq, false, &s);
    if (r != CV_OK) {
        grpc_call_unref(call);
        cv_rpc_cq_drain_and_destroy(cq);
        return r;
    }
    free(s->peer);
    s->peer = strdup(c->target);   /* the client's peer before it connects is the target we asked for */
    r = cv_rpc_stream_begin(s, metadata, count);
    if (r != CV_OK) {
        cv_rpc_stream_teardown(s);
        return r;
    }
    s->client_streams = &c->streams;
    atomic_fetch_add(&c->streams, 1);
    *out = s;
    return CV_OK;
}

void cv_rpc_stream_destroy(cv_rpc_stream *s) {
    if (!s || s->is_server)
        return;
    atomic_uint *counter = s->client_streams;
    cv_rpc_stream_teardown(s);
    if (counter)
        atomic_fetch_sub(counter, 1);
}

cv_result cv_rpc_client_unary(cv_rpc_client *c, const char *method, const void *request, size_t size,
                              uint32_t timeout_ms, void **response, size_t *response_size, int *status) {
    if (status)
        *status = -1;
    if (!c || !method || method[0] != '/' || (!request && size) || !response || !response_size)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_rpc_client_unary: null argument or bad method '%s'",
                        method ? method : "(null)");
    *response = NULL;
    *response_size = 0;
    grpc_completion_queue *cq = grpc_completion_queue_create_for_next(NULL);
    grpc_call *call = create_call(c, cq, method, cv_rpc_deadline(timeout_ms ? timeout_ms : 10000));
    if (!call) {
        cv_rpc_cq_drain_and_destroy(cq);
        return cv_error(CV_ERROR_CONNECTION, "rpc unary '%s' on %s: the core made no call", method, c->target);
    }
    grpc_byte_buffer *req = cv_rpc_buffer_copy(request, size);
    grpc_byte_buffer *resp = NULL;
    grpc_metadata_array initial, trailing;
    grpc_metadata_array_init(&initial);
    grpc_metadata_array_init(&trailing);
    grpc_status_code code = GRPC_STATUS_UNKNOWN;
    grpc_slice details = grpc_empty_slice();
    const char *error_string = NULL;

    grpc_op ops[6] = {{.op = GRPC_OP_SEND_INITIAL_METADATA}, {.op = GRPC_OP_SEND_MESSAGE},
                      {.op = GRPC_OP_SEND_CLOSE_FROM_CLIENT}, {.op = GRPC_OP_RECV_INITIAL_METADATA},
                      {.op = GRPC_OP_RECV_MESSAGE},           {.op = GRPC_OP_RECV_STATUS_ON_CLIENT}};
    ops[1].data.send_message.send_message = req;
    ops[3].data.recv_initial_metadata.recv_initial_metadata = &initial;
    ops[4].data.recv_message.recv_message = &resp;
    ops[5].data.recv_status_on_client.trailing_metadata = &trailing;
    ops[5].data.recv_status_on_client.status = &code;
    ops[5].data.recv_status_on_client.status_details = &details;
    ops[5].data.recv_status_on_client.error_string = &error_string;

    cv_result r = CV_OK;
    grpc_call_error e = grpc_call_start_batch(call, ops, 6, (void *)1, NULL);
    if (e != GRPC_CALL_OK) {
        r = cv_error(CV_ERROR_CONNECTION, "rpc unary '%s' on %s: start_batch: %s", method, c->target,
                     grpc_call_error_to_string(e));
    } else {
        /* The batch always completes: at the deadline at the latest. */
        grpc_completion_queue_next(cq, gpr_inf_future(GPR_CLOCK_REALTIME), NULL);
        if (status)
            *status = (int)code;
        if (code == GRPC_STATUS_OK) {
            if (resp) {
                uint8_t *data;
                r = cv_rpc_buffer_read(resp, &data, response_size);
                if (r == CV_OK)
                    *response = data;
            }
        } else {
            char *text = cv_rpc_slice_to_string(details);
            r = cv_error(code == GRPC_STATUS_DEADLINE_EXCEEDED ? CV_ERROR_TIMEOUT : CV_ERROR_CONNECTION,
                         "rpc unary '%s' on %s: status %s (%d): %s", method, c->target, cv_rpc_status_name(code),
                         (int)code, text && text[0] ? text : error_string ? error_string : "");
            free(text);
        }
    }
    grpc_call_unref(call);
    cv_rpc_cq_drain_and_destroy(cq);
    grpc_byte_buffer_destroy(req);
    if (resp)
        grpc_byte_buffer_destroy(resp);
    grpc_slice_unref(details);
    gpr_free((void *)error_string);
    grpc_metadata_array_destroy(&initial);
    grpc_metadata_array_destroy(&trailing);
    return r;
}
