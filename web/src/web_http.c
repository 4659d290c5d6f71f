/* HTTP requests: token, route, body, handler, response. */
#include "web_http.h"

#include <corvid/log.h>

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Indexed by lws' LWSHUMETH_*. */
static const char *const METHOD_NAMES[] = { "GET", "POST", "OPTIONS", "PUT", "PATCH", "DELETE", "CONNECT", "HEAD" };

void web_http_reset(web_session *ss) {
    free(ss->path);
    free(ss->query);
    free(ss->content_type);
    free(ss->body);
    free(ss->resp.body);
    cv_web_conn *conn = ss->conn;
    *ss = (web_session){ 0 };
    ss->conn = conn;
}

static void count(cv_web_server *s, bool refused) {
    pthread_mutex_lock(&s->lock);
    s->stats.http_requests++;
    if (refused)
        s->stats.http_refused++;
    pthread_mutex_unlock(&s->lock);
}

/* A copy of header `h` ("" when absent); NULL only when out of memory. */
static char *header_copy(struct lws *wsi, enum lws_token_indexes h) {
    int n = lws_hdr_total_length(wsi, h);
    char *out = malloc((size_t)(n > 0 ? n : 0) + 1);
    if (out && (n <= 0 || lws_hdr_copy(wsi, out, n + 1, h) < 0))
        out[0] = 0;
    return out;
}

/* The query string as sent: lws splits it at '&' into fragments. */
static char *query_copy(struct lws *wsi) {
    int total = lws_hdr_total_length(wsi, WSI_TOKEN_HTTP_URI_ARGS);
    char *out = malloc((size_t)(total > 0 ? total : 0) * 2 + 2);
    if (!out)
        return NULL;
    size_t n = 0;
    out[0] = 0;
    for (int i = 0; total > 0; i++) {
        int len = lws_hdr_fragment_length(wsi, WSI_TOKEN_HTTP_URI_ARGS, i);
        if (len <= 0)
            break;
        if (n)
            out[n++] = '&';
        if (lws_hdr_copy_fragment(wsi, out + n, len + 1, WSI_TOKEN_HTTP_URI_ARGS, i) < 0)
            break;
        n += (size_t)len;
    }
    out[n] = 0;
    return out;
}

/* Compares in time independent of where the strings differ (the token is a secret). */
static bool same_secret(const char *a, const char *b) {
    size_t na = strlen(a), nb = strlen(b);
    unsigned diff = (unsigned)(na ^ nb);
    for (size_t i = 0; i < na; i++)
        diff |= (unsigned)(a[i] ^ b[i % (nb ? nb : 1)]);
    return diff == 0;
}

/* The token as `Authorization: Bearer <token>` or, where allowed (page, assets, "/ws":
 * what a browser opens or loads itself), `?token=<token>`. */
static bool token_ok(cv_web_server *s, struct lws *wsi, bool query_allowed) {
    if (!s->token)
        return true;
    char buf[512];
    if (lws_hdr_copy(wsi, buf, sizeof buf, WSI_TOKEN_HTTP_AUTHORIZATION) > 0 && strncmp(buf, "Bearer ", 7) == 0 &&
        same_secret(buf + 7, s->token))
        return true;
    const char *arg = query_allowed ? lws_get_urlarg_by_name(wsi, "token=", buf, sizeof buf) : NULL;
    return arg && same_secret(arg, s->token);
}

/* Writes the status line and headers; the body follows in web_http_writeable. */
static int send_headers(cv_web_server *s, struct lws *wsi, web_session *ss) {
    uint8_t *start = s->scratch + LWS_PRE, *p = start, *end = start + WEB_CHUNK_BYTES - 1;
    const char *type = ss->resp.content_type[0] ? ss->resp.content_type : "application/octet-stream";
    if (lws_add_http_common_headers(wsi, (unsigned)ss->resp.status, type, ss->out_size, &p, end))
        return -1;
    if (ss->resp.content_disposition[0] &&
        lws_add_http_header_by_name(wsi, (const uint8_t *)"content-disposition:",
                                    (const uint8_t *)ss->resp.content_disposition,
                                    (int)strlen(ss->resp.content_disposition), &p, end))
        return -1;
    if (lws_add_http_header_by_name(wsi, (const uint8_t *)"cache-control:", (const uint8_t *)"no-store", 8, &p, end))
        return -1;
    if (ss->resp.status == 401 &&
        lws_add_http_header_by_name(wsi, (const uint8_t *)"www-authenticate:", (const uint8_t *)"Bearer", 6, &p, end))
        return -1;
    if (lws_finalize_write_http_header(wsi, start, &p, end))
        return -1;
    if (ss->head || ss->out_size == 0)
        return ss->close_after || lws_http_transaction_completed(wsi) ? -1 : 0;
    lws_callback_on_writable(wsi);
    return 0;
}

/* Answers with the handler's (or a refusal's) response. */
static int respond(cv_web_server *s, struct lws *wsi, web_session *ss) {
    if (ss->resp.status == 0) {
        free(ss->resp.body);
        ss->resp = (cv_http_response){ 0 };
        cv_http_respond_error(&ss->resp, 404, "%s: no such path", ss->path);
    }
    if (!ss->out) {
        ss->out = ss->resp.body;
        ss->out_size = ss->resp.body_size;
    }
    int st = ss->resp.status;
    ss->close_after = st == 411 || st == 413;
    count(s, st == 401 || st == 404 || st == 405 || st == 411 || st == 413);
    if (st >= 400)
        cv_log(CV_LOG_DEBUG, "web", "%s %s: %d", ss->method, ss->path, st);
    return send_headers(s, wsi, ss);
}

static const cv_web_asset *find_asset(cv_web_server *s, const char *path) {
    for (uint32_t i = 0; i < s->asset_count; i++)
        if (strcmp(s->assets[i].path, path) == 0)
            return &s->assets[i];
    return NULL;
}

static void call_api(cv_web_server *s, web_session *ss) {
    cv_http_request req = { .method = ss->method,
                            .path = ss->path,
                            .query = ss->query,
                            .content_type = ss->content_type,
                            .body = ss->body,
                            .body_size = ss->body_size };
    s->api(s->api_user, &req, &ss->resp);
}

/* Routes a request whose token was accepted: an asset, the API, or a refusal. */
static int route(cv_web_server *s, struct lws *wsi, web_session *ss, int method) {
    bool get = method == LWSHUMETH_GET || method == LWSHUMETH_HEAD;
    const cv_web_asset *asset = find_asset(s, ss->path);
    if (asset) {
        if (!get) {
            cv_http_respond_error(&ss->resp, 405, "%s: %s not allowed (GET or HEAD)", ss->path, ss->method);
            return respond(s, wsi, ss);
        }
        ss->resp.status = 200;
        snprintf(ss->resp.content_type, sizeof ss->resp.content_type, "%s", asset->content_type);
        ss->out = asset->data;
        ss->out_size = asset->size;
        return respond(s, wsi, ss);
    }
    if (strncmp(ss->path, "/api/", 5) != 0 || !s->api)
        return respond(s, wsi, ss); /* status 0: 404 */
    if (method == LWSHUMETH_OPTIONS || method == LWSHUMETH_CONNECT) {
        cv_http_respond_error(&ss->resp, 405, "%s: %s not allowed", ss->path, ss->method);
        return respond(s, wsi, ss);
    }
    char len_text[32];
    bool has_length = lws_hdr_copy(wsi, len_text, sizeof len_text, WSI_TOKEN_HTTP_CONTENT_LENGTH) > 0;
    if (!has_length && lws_hdr_total_length(wsi, WSI_TOKEN_HTTP_TRANSFER_ENCODING) > 0) {
        /* A chunked body has no size to check against the limit before it is read. */
        cv_http_respond_error(&ss->resp, 411, "%s: a body needs a Content-Length", ss->path);
        return respond(s, wsi, ss);
    }
    if (has_length) {
        unsigned long long n = strtoull(len_text, NULL, 10);
        if (n > s->max_body_bytes) {
            cv_http_respond_error(&ss->resp, 413, "%s: body of %llu bytes is over the limit of %zu", ss->path, n,
                                  s->max_body_bytes);
            return respond(s, wsi, ss);
        }
        if (n > 0) {
            ss->body_expected = (size_t)n;
            ss->body = malloc(ss->body_expected);
            if (!ss->body)
                return -1;
            ss->body_pending = true;
            return 0; /* the handler runs at the body's completion */
        }
    }
    call_api(s, ss);
    return respond(s, wsi, ss);
}

int web_http_request(cv_web_server *s, struct lws *wsi, web_session *ss) {
    web_http_reset(ss);
    char *uri = NULL;
    int uri_len = 0;
    int method = lws_http_get_uri_and_method(wsi, &uri, &uri_len);
    if (method < 0 || method > LWSHUMETH_HEAD)
        return -1;
    snprintf(ss->method, sizeof ss->method, "%s", METHOD_NAMES[method]);
    ss->head = method == LWSHUMETH_HEAD;
    ss->path = malloc((size_t)uri_len + 1);
    ss->query = query_copy(wsi);
    ss->content_type = header_copy(wsi, WSI_TOKEN_HTTP_CONTENT_TYPE);
    if (!ss->path || !ss->query || !ss->content_type)
        return -1;
    memcpy(ss->path, uri, (size_t)uri_len);
    ss->path[uri_len] = 0;
    bool api = strncmp(ss->path, "/api/", 5) == 0;
    if (!token_ok(s, wsi, !api)) {
        cv_http_respond_error(&ss->resp, 401, "%s: a valid bearer token is required", ss->path);
        return respond(s, wsi, ss);
    }
    return route(s, wsi, ss, method);
}

int web_http_body(cv_web_server *s, struct lws *wsi, web_session *ss, const void *in, size_t len) {
    (void)s;
    (void)wsi;
    if (!ss->body_pending)
        return 0;
    if (len > ss->body_expected - ss->body_size) {
        cv_log(CV_LOG_INFO, "web", "%s %s: body longer than its content-length: closing", ss->method, ss->path);
        return -1;
    }
    memcpy(ss->body + ss->body_size, in, len);
    ss->body_size += len;
    return 0;
}

int web_http_body_done(cv_web_server *s, struct lws *wsi, web_session *ss) {
    if (!ss->body_pending)
        return 0;
    ss->body_pending = false;
    call_api(s, ss);
    return respond(s, wsi, ss);
}

int web_http_writeable(cv_web_server *s, struct lws *wsi, web_session *ss) {
    if (!ss->out || ss->out_sent >= ss->out_size)
        return 0;
    size_t n = ss->out_size - ss->out_sent;
    if (n > WEB_CHUNK_BYTES)
        n = WEB_CHUNK_BYTES;
    bool last = ss->out_sent + n == ss->out_size;
    memcpy(s->scratch + LWS_PRE, ss->out + ss->out_sent, n);
    if (lws_write(wsi, s->scratch + LWS_PRE, n, last ? LWS_WRITE_HTTP_FINAL : LWS_WRITE_HTTP) != (int)n)
        return -1;
    ss->out_sent += n;
    if (!last) {
        lws_callback_on_writable(wsi);
        return 0;
    }
    bool close_after = ss->close_after;
    web_http_reset(ss);
    return close_after || lws_http_transaction_completed(wsi) ? -1 : 0;
}

/* A refusal of an upgrade, answered at once (small JSON body, no keep-alive). */
static int refuse_upgrade(cv_web_server *s, struct lws *wsi, int status, const char *message) {
    char body[160];
    int n = snprintf(body, sizeof body, "{\"error\":\"%s\"}", message);
    uint8_t *start = s->scratch + LWS_PRE, *p = start, *end = start + WEB_CHUNK_BYTES - 1;
    count(s, true);
    if (lws_add_http_common_headers(wsi, (unsigned)status, "application/json", (lws_filepos_t)n, &p, end) ||
        lws_finalize_http_header(wsi, &p, end))
        return -1;
    memcpy(p, body, (size_t)n);
    p += n;
    if (lws_write(wsi, start, (size_t)(p - start), LWS_WRITE_HTTP_HEADERS) != (int)(p - start))
        return -1;
    return 1;
}

int web_http_confirm_upgrade(cv_web_server *s, struct lws *wsi) {
    char path[64];
    if (lws_hdr_copy(wsi, path, sizeof path, WSI_TOKEN_GET_URI) <= 0 || strcmp(path, "/ws") != 0)
        return refuse_upgrade(s, wsi, 404, "WebSocket connections go to /ws");
    if (!token_ok(s, wsi, true))
        return refuse_upgrade(s, wsi, 401, "/ws: a valid token is required (?token= or Authorization: Bearer)");
    return 0;
}
