/* The client library's environment for programs (env_client.h). The messages
 * name the variables, as users set them. */
#include "env_client.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "corvid/parse.h"
#include "corvid/rpc.h"

static const char *env(const char *name) {
    const char *v = getenv(name);
    return v && *v ? v : NULL;
}

static cv_result read_ms(const char *name, uint64_t min, uint64_t max, uint32_t *out) {
    const char *text = env(name);
    uint64_t v = 0;
    if (text && cv_parse_uint_named(name, text, min, max, &v) != CV_OK)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "%s (milliseconds)", cv_last_error());
    *out = (uint32_t)v;
    return CV_OK;
}

static cv_result read_file_name(const char *name, char *out, size_t cap, const char **field) {
    const char *text = env(name);
    *field = NULL;
    if (!text)
        return CV_OK;
    if (strlen(text) >= cap)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "%s: a file name of %zu characters is too long", name,
                        strlen(text));
    snprintf(out, cap, "%s", text);
    *field = out;
    return CV_OK;
}

static cv_result read_tls(cv_env_client *out) {
    cv_proxy_options *o = &out->proxy;
    cv_result r = read_file_name("CORVID_NODE_TLS_CA", out->tls_ca, sizeof(out->tls_ca), &o->tls_ca_file);
    if (r == CV_OK)
        r = read_file_name("CORVID_NODE_TLS_CERT", out->tls_cert, sizeof(out->tls_cert), &o->tls_cert_file);
    if (r == CV_OK)
        r = read_file_name("CORVID_NODE_TLS_KEY", out->tls_key, sizeof(out->tls_key), &o->tls_key_file);
    if (r != CV_OK)
        return r;
    if ((o->tls_cert_file || o->tls_key_file) && !o->tls_ca_file)
        return cv_error(CV_ERROR_INVALID_ARGUMENT,
                        "CORVID_NODE_TLS_CERT/KEY (a client certificate) need "
                        "CORVID_NODE_TLS_CA (the CA that signed the node's certificate)");
    if (!o->tls_cert_file != !o->tls_key_file)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "%s is set without %s",
                        o->tls_cert_file ? "CORVID_NODE_TLS_CERT" : "CORVID_NODE_TLS_KEY",
                        o->tls_cert_file ? "CORVID_NODE_TLS_KEY" : "CORVID_NODE_TLS_CERT");
    return CV_OK;
}

cv_result cv_env_client_read(unsigned parts, cv_env_client *out) {
    memset(out, 0, sizeof(*out));
    const char *path = parts & CV_ENV_CLIENT_TRANSFER ? env("CORVID_TRANSFER_PATH") : NULL;
    if (path && cv_transfer_path_parse(path, &out->transfer_path) != CV_OK)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "CORVID_TRANSFER_PATH: %s", cv_last_error());
    if (!(parts & CV_ENV_CLIENT_PROXY))
        return CV_OK;
    cv_proxy_options *o = &out->proxy;
    cv_result r = read_ms("CORVID_NODE_TIMEOUT_MS", 1, 86400000, &o->timeout_ms);
    if (r == CV_OK)
        r = read_ms("CORVID_NODE_PEER_DEADLINE_MS", 1, 86400000, &o->peer_deadline_ms);
    if (r == CV_OK)
        r = read_ms("CORVID_NODE_KEEPALIVE_MS", 100, 3600000, &o->keepalive_ms);
    const char *token_file = env("CORVID_NODE_TOKEN_FILE");
    if (r == CV_OK && token_file) {
        r = cv_rpc_read_token_file(token_file, out->token, sizeof(out->token));
        if (r != CV_OK)
            return cv_error(r, "CORVID_NODE_TOKEN_FILE: %s", cv_last_error());
        o->bearer_token = out->token;
    }
    return r == CV_OK ? read_tls(out) : r;
}

cv_result cv_env_client_configure(unsigned parts) {
    cv_env_client *e = malloc(sizeof(*e));
    if (!e)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "reading the environment");
    cv_result r = cv_env_client_read(parts, e);
    if (r == CV_OK && (parts & CV_ENV_CLIENT_PROXY))
        r = cv_proxy_configure(&e->proxy);
    if (r == CV_OK && (parts & CV_ENV_CLIENT_TRANSFER))
        r = cv_transfer_set_path(e->transfer_path);
    memset(e->token, 0, sizeof(e->token));
    free(e);
    return r;
}
