/* The client side: one channel per cv_rpc_client, bidirectional streams on it, unary calls. */
#include "rpc_internal.h"

#include "corvid/file_util.h"
#include "corvid/log.h"

#include <assert.h>
#include <errno.h>
#include <grpc/grpc_security.h>
#include <grpc/support/alloc.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define MAX_PEM_BYTES (1u << 20)
#define MAX_TOKEN_CHARS 1024u

struct cv_rpc_client {
    grpc_channel *channel;
    char *target;
    char *authorization; /* "Bearer <token>", or NULL: sent with every call */
    atomic_uint streams; /* open streams, to catch destroy-before-streams */
};

/* The one place where the client's credentials are made: plaintext, or TLS trusting the CA file's
 * certificates, with a client certificate for mutual TLS. The bearer token is not a gRPC call credential
 * (the core sends those only over TLS, and a loopback node takes tokens over plaintext too): it goes as
 * metadata on each call (with_authorization). */
static cv_result client_credentials(const cv_rpc_client_config *cfg, grpc_channel_credentials **out) {
    if (!cfg->tls_ca_file) {
        if (cfg->tls_cert_file || cfg->tls_key_file)
            return cv_error(CV_ERROR_INVALID_ARGUMENT,
                            "rpc client: a TLS client certificate needs the CA file "
                            "that the server's certificate is checked against (tls_ca_file)");
        *out = grpc_insecure_credentials_create();
        return CV_OK;
    }
    if (!cfg->tls_cert_file != !cfg->tls_key_file)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "rpc client: TLS client %s given without its %s",
                        cfg->tls_cert_file ? "certificate" : "key", cfg->tls_cert_file ? "key" : "certificate");
    char *ca = NULL, *cert = NULL, *key = NULL;
    cv_result r = cv_rpc_read_pem_file(cfg->tls_ca_file, "TLS CA", &ca);
    if (r == CV_OK && cfg->tls_cert_file)
        r = cv_rpc_read_pem_file(cfg->tls_cert_file, "TLS client certificate", &cert);
    if (r == CV_OK && cfg->tls_key_file)
        r = cv_rpc_read_pem_file(cfg->tls_key_file, "TLS client key", &key);
    if (r == CV_OK) {
        grpc_ssl_pem_key_cert_pair pair = { .private_key = key, .cert_chain = cert };
        *out = grpc_ssl_credentials_create(ca, cert ? &pair : NULL, NULL, NULL);
        if (!*out)
            r = cv_error(CV_ERROR_INVALID_ARGUMENT, "rpc client: gRPC refused the TLS files (CA '%s')",
                         cfg->tls_ca_file);
    }
    free(ca);
    free(cert);
    if (key) {
        memset(key, 0, strlen(key));
        free(key);
    }
    return r;
}

static bool token_char_ok(char ch) { return ch > ' ' && ch < 0x7f; }

static grpc_arg int_arg(const char *key, int value) {
    grpc_arg a = { .type = GRPC_ARG_INTEGER, .key = (char *)key };
    a.value.integer = value;
    return a;
}

static int clamp_int(uint32_t v) { return v > INT32_MAX ? INT32_MAX : (int)v; }

cv_result cv_rpc_client_create(const char *target, const cv_rpc_client_config *config, cv_rpc_client **out) {
    if (!target || !*target || !out)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_rpc_client_create: null or empty target, or null out");
    cv_rpc_client_config cfg = config ? *config : (cv_rpc_client_config){ 0 };
    uint32_t max_message = cfg.max_message_bytes ? cfg.max_message_bytes : CV_RPC_DEFAULT_MAX_MESSAGE;
    uint32_t keepalive = cfg.keepalive_ms ? cfg.keepalive_ms : 10000;
    uint32_t keepalive_timeout = cfg.keepalive_timeout_ms ? cfg.keepalive_timeout_ms : 5000;
    uint32_t connect_timeout = cfg.connect_timeout_ms ? cfg.connect_timeout_ms : 5000;

    if (cfg.bearer_token) {
        size_t n = strlen(cfg.bearer_token);
        bool ok = n > 0 && n <= MAX_TOKEN_CHARS;
        for (size_t i = 0; ok && i < n; i++)
            ok = token_char_ok(cfg.bearer_token[i]);
        if (!ok)
            return cv_error(CV_ERROR_INVALID_ARGUMENT,
                            "cv_rpc_client_create: the bearer token for '%s' must be "
                            "1..%u printable ASCII characters without spaces",
                            target, MAX_TOKEN_CHARS);
    }
    grpc_init();
    grpc_channel_credentials *creds = NULL;
    cv_result r = client_credentials(&cfg, &creds);
    if (r != CV_OK) {
        grpc_shutdown();
        return cv_error(r, "%s (target '%s')", cv_last_error(), target);
    }

    cv_rpc_client *c = calloc(1, sizeof *c);
    char *name = strdup(target);
    char *authorization = NULL;
    if (cfg.bearer_token && (authorization = malloc(strlen(cfg.bearer_token) + 8)))
        sprintf(authorization, "Bearer %s", cfg.bearer_token);
    if (!c || !name || (cfg.bearer_token && !authorization)) {
        free(c);
        free(name);
        free(authorization);
        grpc_channel_credentials_release(creds);
        grpc_shutdown();
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "cv_rpc_client_create: '%s'", target);
    }
    c->authorization = authorization;
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
    grpc_channel_args channel_args = { .num_args = sizeof args / sizeof args[0], .args = args };

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
        cv_log(CV_LOG_ERROR, "rpc", "client '%s' destroyed with %u streams open", c->target, open);
    assert(open == 0 && "destroy the client's streams first");
    grpc_channel_destroy(c->channel);
    grpc_shutdown();
    free(c->target);
    if (c->authorization) {
        memset(c->authorization, 0, strlen(c->authorization));
        free(c->authorization);
    }
    free(c);
}

static cv_result check_metadata(const cv_rpc_metadata *md, uint32_t count) {
    for (uint32_t i = 0; i < count; i++) {
        if (!md[i].key || !md[i].value)
            return cv_error(CV_ERROR_INVALID_ARGUMENT, "rpc metadata %u: null key or value", i);
        grpc_slice key = grpc_slice_from_static_string(md[i].key);
        grpc_slice value = grpc_slice_from_static_string(md[i].value);
        if (!grpc_header_key_is_legal(key) || grpc_is_binary_header(key))
            return cv_error(CV_ERROR_INVALID_ARGUMENT, "rpc metadata %u: key '%s' is not a legal text header key", i,
                            md[i].key);
        if (!grpc_header_nonbin_value_is_legal(value))
            return cv_error(CV_ERROR_INVALID_ARGUMENT, "rpc metadata %u ('%s'): value is not printable ASCII", i,
                            md[i].key);
    }
    return CV_OK;
}

static cv_result open_call(cv_rpc_client *c, const char *method, const cv_rpc_metadata *metadata, uint32_t count,
                           cv_rpc_stream **out);

static grpc_call *create_call(cv_rpc_client *c, grpc_completion_queue *cq, const char *method,
                              gpr_timespec deadline) {
    grpc_slice m = grpc_slice_from_copied_string(method);
    grpc_call *call = grpc_channel_create_call(c->channel, NULL, GRPC_PROPAGATE_DEFAULTS, cq, m, NULL, deadline,
                                               NULL);
    grpc_slice_unref(m);
    return call;
}

cv_result cv_rpc_client_open(cv_rpc_client *c, const char *method, const cv_rpc_metadata *metadata, uint32_t count,
                             cv_rpc_stream **out) {
    if (!c || !method || method[0] != '/' || !out || (count && !metadata))
        return cv_error(CV_ERROR_INVALID_ARGUMENT,
                        "cv_rpc_client_open: null client/out/metadata or method '%s' "
                        "not of the form /package.Service/Method",
                        method ? method : "(null)");
    cv_result r = check_metadata(metadata, count);
    if (r != CV_OK)
        return r;
    for (uint32_t i = 0; c->authorization && i < count; i++)
        if (strcmp(metadata[i].key, "authorization") == 0)
            return cv_error(CV_ERROR_INVALID_ARGUMENT,
                            "cv_rpc_client_open: 'authorization' metadata on a client "
                            "that has a bearer token (it sends its own)");
    cv_rpc_metadata *all = NULL;
    if (c->authorization) {
        all = calloc(count + 1, sizeof *all);
        if (!all)
            return cv_error(CV_ERROR_OUT_OF_MEMORY, "cv_rpc_client_open");
        if (count)
            memcpy(all, metadata, count * sizeof *all);
        all[count++] = (cv_rpc_metadata){ "authorization", c->authorization };
        metadata = all;
    }
    r = open_call(c, method, metadata, count, out);
    free(all);
    return r;
}

static cv_result open_call(cv_rpc_client *c, const char *method, const cv_rpc_metadata *metadata, uint32_t count,
                           cv_rpc_stream **out) {
    cv_result r;
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
    s->peer = strdup(c->target); /* the client's peer before it connects is the target we asked for */
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

    grpc_op ops[6] = { { .op = GRPC_OP_SEND_INITIAL_METADATA },  { .op = GRPC_OP_SEND_MESSAGE },
                       { .op = GRPC_OP_SEND_CLOSE_FROM_CLIENT }, { .op = GRPC_OP_RECV_INITIAL_METADATA },
                       { .op = GRPC_OP_RECV_MESSAGE },           { .op = GRPC_OP_RECV_STATUS_ON_CLIENT } };
    grpc_metadata auth;
    if (c->authorization) {
        auth.key = grpc_slice_from_static_string("authorization");
        auth.value = grpc_slice_from_copied_string(c->authorization);
        ops[0].data.send_initial_metadata.count = 1;
        ops[0].data.send_initial_metadata.metadata = &auth;
    }
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
                         (int)code,
                         text && text[0] ? text
                         : error_string  ? error_string
                                         : "");
            free(text);
        }
    }
    grpc_call_unref(call);
    cv_rpc_cq_drain_and_destroy(cq);
    if (c->authorization)
        grpc_slice_unref(auth.value);
    grpc_byte_buffer_destroy(req);
    if (resp)
        grpc_byte_buffer_destroy(resp);
    grpc_slice_unref(details);
    gpr_free((void *)error_string);
    grpc_metadata_array_destroy(&initial);
    grpc_metadata_array_destroy(&trailing);
    return r;
}

/* ---- files ---- */

/* The reason of cv_file_fopen_regular's failure, without the path it starts with. */
static const char *reason_of(const char *path) {
    const char *e = cv_last_error();
    size_t n = strlen(path);
    return strncmp(e, path, n) == 0 && e[n] == ':' && e[n + 1] == ' ' ? e + n + 2 : e;
}

cv_result cv_rpc_read_pem_file(const char *path, const char *what, char **out) {
    if (!path || !*path || !what || !out)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_rpc_read_pem_file: null or empty argument");
    FILE *f;
    if (cv_file_fopen_regular(path, "rb", &f) != CV_OK)
        return cv_error(CV_ERROR_IO, "%s file '%s': %s", what, path, reason_of(path));
    char *text = malloc(MAX_PEM_BYTES + 1);
    size_t n = text ? fread(text, 1, MAX_PEM_BYTES + 1, f) : 0;
    bool failed = text && ferror(f);
    fclose(f);
    if (!text)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "%s file '%s'", what, path);
    cv_result r = CV_OK;
    if (failed)
        r = cv_error(CV_ERROR_IO, "%s file '%s': read error", what, path);
    else if (n > MAX_PEM_BYTES)
        r = cv_error(CV_ERROR_LIMIT_EXCEEDED, "%s file '%s': larger than %u bytes", what, path, MAX_PEM_BYTES);
    else if (n == 0 || memchr(text, 0, n))
        r = cv_error(CV_ERROR_MALFORMED, "%s file '%s': %s", what, path, n ? "binary, not PEM" : "empty");
    else {
        text[n] = 0;
        if (!strstr(text, "-----BEGIN "))
            r = cv_error(CV_ERROR_MALFORMED, "%s file '%s': not PEM (no '-----BEGIN' line)", what, path);
    }
    if (r != CV_OK) {
        memset(text, 0, n < MAX_PEM_BYTES ? n : MAX_PEM_BYTES);
        free(text);
        return r;
    }
    *out = text;
    return CV_OK;
}

cv_result cv_rpc_read_token_file(const char *path, char *out, size_t cap) {
    if (!path || !*path || !out || cap == 0)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_rpc_read_token_file: null or empty argument");
    FILE *f;
    if (cv_file_fopen_regular(path, "rb", &f) != CV_OK)
        return cv_error(CV_ERROR_IO, "token file '%s': %s", path, reason_of(path));
    char line[MAX_TOKEN_CHARS + 3];
    size_t n = fread(line, 1, sizeof line - 1, f);
    bool failed = ferror(f);
    fclose(f);
    line[n] = 0;
    char *end = strchr(line, '\n'); /* the first line */
    size_t len = end ? (size_t)(end - line) : n;
    while (len && (line[len - 1] == '\r' || line[len - 1] == ' ' || line[len - 1] == '\t'))
        len--;
    bool ok = !failed && len > 0 && len <= MAX_TOKEN_CHARS && len < cap;
    for (size_t i = 0; ok && i < len; i++)
        ok = token_char_ok(line[i]);
    cv_result r = CV_OK;
    if (failed)
        r = cv_error(CV_ERROR_IO, "token file '%s': read error", path);
    else if (len == 0)
        r = cv_error(CV_ERROR_MALFORMED, "token file '%s' is empty (the token is its first line)", path);
    else if (!ok)
        r = cv_error(CV_ERROR_MALFORMED,
                     "token file '%s': the token (its first line) must be 1..%u printable "
                     "ASCII characters without spaces",
                     path, (unsigned)(cap - 1 < MAX_TOKEN_CHARS ? cap - 1 : MAX_TOKEN_CHARS));
    else {
        memcpy(out, line, len);
        out[len] = 0;
    }
    memset(line, 0, sizeof line);
    return r;
}
