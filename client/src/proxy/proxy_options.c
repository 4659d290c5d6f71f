/* How this process's proxy devices reach nodes (proxy.h, cv_proxy_configure):
 * one copy of the options, taken by every device create and node query. */
#include <pthread.h>
#include <stdio.h>
#include <string.h>

#include "proxy_options.h"

#include "corvid/node_protocol.h"

#define DEFAULT_TIMEOUT_MS 120000u

/* process-wide: the client's identity towards nodes (its token, its TLS
 * certificate) and its patience are the program's, set once at start; proxy
 * devices are made deep inside libraries (the renderer's device list, a node
 * query) that carry no connection settings of their own. */
static pthread_mutex_t options_lock = PTHREAD_MUTEX_INITIALIZER;
static proxy_settings current;

/* A copy whose strings point into its own buffers. */
static void settings_copy(proxy_settings *dst, const proxy_settings *src) {
    *dst = *src;
    dst->options.bearer_token = src->options.bearer_token ? dst->token : NULL;
    dst->options.tls_ca_file = src->options.tls_ca_file ? dst->tls_ca : NULL;
    dst->options.tls_cert_file = src->options.tls_cert_file ? dst->tls_cert : NULL;
    dst->options.tls_key_file = src->options.tls_key_file ? dst->tls_key : NULL;
}

static cv_result copy_text(const char *what, const char *text, char *out, size_t cap, const char **field) {
    *field = NULL;
    if (!text || !text[0])
        return CV_OK;
    if (strlen(text) >= cap)
        return cv_error(CV_ERROR_INVALID_ARGUMENT,
                        "cv_proxy_configure: %s of %zu characters is too long (at most %zu)", what, strlen(text),
                        cap - 1);
    snprintf(out, cap, "%s", text);
    *field = out;
    return CV_OK;
}

static cv_result check_ms(const char *what, uint32_t v, uint32_t min, uint32_t max) {
    if (v && (v < min || v > max))
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_proxy_configure: %s %u is not in %u..%u (milliseconds)", what,
                        v, min, max);
    return CV_OK;
}

cv_result cv_proxy_configure(const cv_proxy_options *options) {
    cv_proxy_options o = options ? *options : (cv_proxy_options){ 0 };
    cv_result r = check_ms("timeout_ms", o.timeout_ms, 1, 86400000);
    if (r == CV_OK)
        r = check_ms("peer_deadline_ms", o.peer_deadline_ms, 1, 86400000);
    if (r == CV_OK)
        r = check_ms("keepalive_ms", o.keepalive_ms, 100, 3600000);
    bool ca = o.tls_ca_file && o.tls_ca_file[0], cert = o.tls_cert_file && o.tls_cert_file[0],
         key = o.tls_key_file && o.tls_key_file[0];
    if (r == CV_OK && (cert || key) && !ca)
        r = cv_error(CV_ERROR_INVALID_ARGUMENT,
                     "cv_proxy_configure: a client certificate (tls_cert_file/tls_key_file) needs tls_ca_file "
                     "(the CA that signed the node's certificate)");
    if (r == CV_OK && cert != key)
        r = cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_proxy_configure: %s is set without %s",
                     cert ? "tls_cert_file" : "tls_key_file", cert ? "tls_key_file" : "tls_cert_file");
    proxy_settings c = { .options = o };
    if (r == CV_OK)
        r = copy_text("bearer_token", o.bearer_token, c.token, sizeof(c.token), &c.options.bearer_token);
    if (r == CV_OK)
        r = copy_text("tls_ca_file", o.tls_ca_file, c.tls_ca, sizeof(c.tls_ca), &c.options.tls_ca_file);
    if (r == CV_OK)
        r = copy_text("tls_cert_file", o.tls_cert_file, c.tls_cert, sizeof(c.tls_cert), &c.options.tls_cert_file);
    if (r == CV_OK)
        r = copy_text("tls_key_file", o.tls_key_file, c.tls_key, sizeof(c.tls_key), &c.options.tls_key_file);
    if (r == CV_OK) {
        pthread_mutex_lock(&options_lock);
        settings_copy(&current, &c);
        pthread_mutex_unlock(&options_lock);
    }
    memset(c.token, 0, sizeof(c.token));
    return r;
}

void proxy_settings_get(proxy_settings *out) {
    pthread_mutex_lock(&options_lock);
    settings_copy(out, &current);
    pthread_mutex_unlock(&options_lock);
    if (!out->options.timeout_ms)
        out->options.timeout_ms = DEFAULT_TIMEOUT_MS;
}

void proxy_client_config(const proxy_settings *s, cv_rpc_client_config *cc) {
    const cv_proxy_options *o = &s->options;
    *cc = (cv_rpc_client_config){ .max_message_bytes = CV_NODE_MAX_MESSAGE_BYTES,
                                  .keepalive_ms = o->keepalive_ms,
                                  .keepalive_timeout_ms = o->keepalive_ms,
                                  .bearer_token = o->bearer_token,
                                  .tls_ca_file = o->tls_ca_file,
                                  .tls_cert_file = o->tls_cert_file,
                                  .tls_key_file = o->tls_key_file };
}
