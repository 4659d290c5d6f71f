/* The server's life: checking the desc, the lws context and its listening
 * vhost, the service thread, and stopping. */
#include "web_protocol.h"
#include "web_state.h"

#include <corvid/log.h>

#include <stdlib.h>
#include <string.h>

/* lws logs through one function per process: its errors go to our sink. */
static void lws_to_sink(int level, const char *line) {
    size_t n = strlen(line);
    while (n && (line[n - 1] == '\n' || line[n - 1] == '\r'))
        n--;
    cv_log(level == LLL_ERR ? CV_LOG_WARNING : CV_LOG_DEBUG, "lws", "%.*s", (int)n, line);
}

/* process-wide: lws has one log level and emitter per process; set once, by the first server. */
static pthread_once_t lws_log_once = PTHREAD_ONCE_INIT;
static void lws_log_init(void) { lws_set_log_level(LLL_ERR | LLL_WARN, lws_to_sink); }

static bool is_loopback(const char *host) {
    return strncmp(host, "127.", 4) == 0 || strcmp(host, "localhost") == 0 || strcmp(host, "::1") == 0;
}

static cv_result check_desc(const cv_web_desc *d) {
    const char *host = d->host ? d->host : "127.0.0.1";
    bool token = d->token && d->token[0];
    if (!host[0])
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "web: host: empty");
    if (!is_loopback(host) && !token)
        return cv_error(CV_ERROR_INVALID_ARGUMENT,
                        "web: host %s is not loopback: a token is required to serve beyond this machine", host);
    if (!d->tls_cert != !d->tls_key)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "web: tls: give both the certificate and the key, or neither");
    if (d->asset_count && !d->assets)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "web: assets: NULL with asset_count %u", d->asset_count);
    for (uint32_t i = 0; i < d->asset_count; i++) {
        const cv_web_asset *a = &d->assets[i];
        if (!a->path || a->path[0] != '/' || !a->content_type || (!a->data && a->size))
            return cv_error(CV_ERROR_INVALID_ARGUMENT, "web: assets[%u]: needs a path from '/', a type and bytes", i);
    }
    return CV_OK;
}

static char *dup_or_null(const char *s) { return s && s[0] ? strdup(s) : NULL; }

static void server_free(cv_web_server *s) {
    free(s->host);
    free(s->token);
    free(s->tls_cert);
    free(s->tls_key);
    free(s->assets);
    free(s->scratch);
    pthread_mutex_destroy(&s->lock);
    free(s);
}

static cv_web_server *server_new(const cv_web_desc *d) {
    cv_web_server *s = calloc(1, sizeof *s);
    if (!s)
        return NULL;
    pthread_mutex_init(&s->lock, NULL);
    s->host = strdup(d->host ? d->host : "127.0.0.1");
    s->token = dup_or_null(d->token);
    s->tls_cert = dup_or_null(d->tls_cert);
    s->tls_key = dup_or_null(d->tls_key);
    s->scratch = malloc(LWS_PRE + WEB_CHUNK_BYTES);
    s->assets = calloc(d->asset_count + 1, sizeof *s->assets);
    if (!s->host || !s->scratch || !s->assets || (d->token && d->token[0] && !s->token) ||
        (d->tls_cert && !s->tls_cert) || (d->tls_key && !s->tls_key)) {
        server_free(s);
        return NULL;
    }
    if (d->asset_count)
        memcpy(s->assets, d->assets, d->asset_count * sizeof *s->assets);
    s->asset_count = d->asset_count;
    s->max_body_bytes = d->max_body_bytes ? d->max_body_bytes : 1024 * 1024;
    s->ws_max_message_bytes = d->ws_max_message_bytes ? d->ws_max_message_bytes : 64 * 1024;
    s->text_queue_max = d->text_queue_max ? d->text_queue_max : 64;
    s->api = d->api;
    s->api_user = d->api_user;
    s->ws_open = d->ws_open;
    s->ws_text = d->ws_text;
    s->ws_close = d->ws_close;
    s->ws_user = d->ws_user;
    s->protocols[0] = (struct lws_protocols){ .name = "corvid",
                                              .callback = web_protocol_callback,
                                              .per_session_data_size = sizeof(web_session) };
    return s;
}

/* The context and the one vhost that listens on host:port. */
static cv_result create_context(cv_web_server *s, uint16_t port) {
    struct lws_context_creation_info info;
    memset(&info, 0, sizeof info);
    info.options = LWS_SERVER_OPTION_EXPLICIT_VHOSTS | LWS_SERVER_OPTION_DISABLE_IPV6 |
                   (s->tls_cert ? LWS_SERVER_OPTION_DO_SSL_GLOBAL_INIT : 0);
    info.user = s;
    info.max_http_header_data = 8192;
    info.server_string = "corvid";
    s->context = lws_create_context(&info);
    if (!s->context)
        return cv_error(CV_ERROR_BACKEND, "web: libwebsockets could not create its context");
    info.vhost_name = "corvid";
    info.port = port;
    info.iface = strcmp(s->host, "localhost") == 0 ? "127.0.0.1" : s->host;
    info.protocols = s->protocols;
    info.ssl_cert_filepath = s->tls_cert;
    info.ssl_private_key_filepath = s->tls_key;
    info.alpn = "http/1.1"; /* no HTTP/2: "/ws" is an HTTP/1.1 upgrade */
    struct lws_vhost *vh = lws_create_vhost(s->context, &info);
    if (!vh) {
        lws_context_destroy(s->context);
        s->context = NULL;
        return cv_error(CV_ERROR_CONNECTION, "web: cannot listen on %s:%u%s (address in use or not here?)", s->host,
                        port, s->tls_cert ? " with TLS (are the certificate and key readable PEM?)" : "");
    }
    s->port = (uint16_t)lws_get_vhost_listen_port(vh);
    return CV_OK;
}

static void *service_main(void *arg) {
    cv_web_server *s = arg;
    for (;;) {
        pthread_mutex_lock(&s->lock);
        bool stop = s->stopping;
        pthread_mutex_unlock(&s->lock);
        if (stop || lws_service(s->context, 0) < 0)
            break;
    }
    return NULL;
}

cv_result cv_web_server_start(const cv_web_desc *desc, cv_web_server **out) {
    if (!desc || !out)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "web: start: NULL desc or out");
    cv_result r = check_desc(desc);
    if (r != CV_OK)
        return r;
    pthread_once(&lws_log_once, lws_log_init);
    cv_web_server *s = server_new(desc);
    if (!s)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "web: start: out of memory");
    r = create_context(s, desc->port);
    if (r != CV_OK) {
        server_free(s);
        return r;
    }
    if (pthread_create(&s->thread, NULL, service_main, s) != 0) {
        lws_context_destroy(s->context);
        server_free(s);
        return cv_error(CV_ERROR_BACKEND, "web: start: cannot start the service thread");
    }
    cv_log(CV_LOG_DEBUG, "web", "serving on %s:%u%s", s->host, s->port, s->tls_cert ? " (TLS)" : "");
    *out = s;
    return CV_OK;
}

uint16_t cv_web_server_port(const cv_web_server *s) { return s ? s->port : 0; }

void cv_web_server_stop(cv_web_server *s) {
    if (!s)
        return;
    pthread_mutex_lock(&s->lock);
    s->stopping = true; /* from here no send wakes the context (it is about to go) */
    lws_cancel_service(s->context);
    pthread_mutex_unlock(&s->lock);
    pthread_join(s->thread, NULL);
    /* Closes every connection: their close callbacks run here, the service thread is gone. */
    lws_context_destroy(s->context);
    server_free(s);
}

void cv_web_server_get_stats(cv_web_server *s, cv_web_stats *out) {
    pthread_mutex_lock(&s->lock);
    *out = s->stats;
    pthread_mutex_unlock(&s->lock);
}
