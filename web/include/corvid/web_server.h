/* The web server: a page, an HTTP/JSON API and live frames to a browser.
 *
 * One libwebsockets context served by one thread. It serves files embedded in
 * the program (the viewer's page), hands every request under "/api/" to a
 * cv_http_handler, and keeps WebSocket connections on "/ws" that carry frames
 * to the page (binary) and input from it (text JSON). The program never writes
 * HTTP itself.
 *
 * Security follows the node's: the server binds 127.0.0.1 unless told
 * otherwise and refuses a non-loopback host without a token. With a token every
 * request must carry `Authorization: Bearer <token>`; the page and "/ws" may
 * carry it as `?token=<token>` instead (a browser cannot set headers on a
 * WebSocket or on the address a user opens). TLS when a certificate and key are
 * given. Refusals: 401 (token), 404 (unknown path), 405 (method), 411 (a body
 * without Content-Length), 413 (a body over max_body_bytes, before the handler runs).
 *
 *     static void api(void *user, const cv_http_request *req, cv_http_response *resp) {
 *         if (strcmp(req->path, "/api/v1/hello") == 0)
 *             cv_http_respond_json(resp, 200, "{\"hello\":\"world\"}");
 *     }                                            // not handled: resp->status 0 -> 404
 *     static void on_text(void *user, cv_web_conn *c, const char *text, size_t size) {
 *         cv_web_send_text(c, "{\"echo\":true}");
 *     }
 *     cv_web_desc desc = {.port = 0, .api = api, .ws_text = on_text};
 *     cv_web_server *s;
 *     if (cv_web_server_start(&desc, &s) == CV_OK) {
 *         printf("http://127.0.0.1:%u/\n", cv_web_server_port(s));
 *         ...                                      // cv_web_send_binary(c, frame, size) per frame
 *         cv_web_server_stop(s);
 *     }
 *
 * Frames: a connection holds at most one unsent replaceable binary message
 * (cv_web_send_binary): a newer one replaces it (counted in
 * cv_web_stats.binary_replaced), so a slow browser sees the newest frame, never a
 * queue of stale ones. Frames of a stream whose every frame counts (H.264: a
 * dropped frame breaks the ones after it) go with cv_web_send_binary_in_order:
 * never replaced, they wait behind each other (at most 8; the sender bounds
 * them, as the live view's credits do). Text messages queue, up to
 * text_queue_max per connection (more are dropped and counted). Sends are
 * thread-safe and wake the service thread.
 *
 * A cv_web_conn is valid from its ws_open callback until its ws_close callback
 * returns; a program that sends from other threads keeps its own set of open
 * connections under its own lock, taken in ws_open / ws_close too. All callbacks
 * (api, ws_open, ws_text, ws_close) run on the service thread, one at a time,
 * and must not block for long. */
#ifndef CORVID_WEB_SERVER_H
#define CORVID_WEB_SERVER_H

#include <corvid/result.h>

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

typedef struct cv_http_request {
    const char *method;       /* "GET", "POST", "PUT", "DELETE", "HEAD" */
    const char *path;         /* "/api/v1/jobs/3" (no query string) */
    const char *query;        /* after '?', "" if none */
    const char *content_type; /* "" if none */
    const uint8_t *body;
    size_t body_size;
} cv_http_request;

typedef struct cv_http_response {
    int status; /* 0 = not handled (404) */
    char content_type[64];
    char content_disposition[160]; /* "" = none */
    uint8_t *body;                 /* malloc'd by the handler; the server frees it */
    size_t body_size;
} cv_http_response;

/* Called on a server thread; must not block for long (start work, return). */
typedef void (*cv_http_handler)(void *user, const cv_http_request *req, cv_http_response *resp);

/* Sets status, "application/json" and a copy of `json` as the body. */
void cv_http_respond_json(cv_http_response *resp, int status, const char *json);
/* Sets status and the body {"error": "<message>"} (the message JSON-escaped). */
void cv_http_respond_error(cv_http_response *resp, int status, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));

typedef struct cv_web_server cv_web_server;
typedef struct cv_web_conn cv_web_conn;

/* One file served as it is, e.g. {"/", "text/html", page, page_size}. */
typedef struct cv_web_asset {
    const char *path; /* "/viewer.js"; "/" for the page */
    const char *content_type;
    const uint8_t *data;
    size_t size;
} cv_web_asset;

typedef struct cv_web_desc {
    const char *host;               /* NULL = "127.0.0.1" */
    uint16_t port;                  /* 0 = an ephemeral port (cv_web_server_port says which) */
    const char *token;              /* NULL or "" = none; required unless host is loopback */
    const char *tls_cert, *tls_key; /* PEM paths: both or neither */
    size_t max_body_bytes;          /* 0 = 1 MiB */
    const cv_web_asset *assets;
    uint32_t asset_count;
    cv_http_handler api; /* "/api/..."; NULL = every API path is 404 */
    void *api_user;
    /* WebSocket "/ws"; any callback may be NULL. `text` is NUL-terminated. */
    void (*ws_open)(void *user, cv_web_conn *c);
    void (*ws_text)(void *user, cv_web_conn *c, const char *text, size_t size);
    void (*ws_close)(void *user, cv_web_conn *c);
    void *ws_user;
    size_t ws_max_message_bytes; /* a longer incoming message closes the connection; 0 = 64 KiB */
    uint32_t text_queue_max;     /* unsent text messages per connection; 0 = 64 */
} cv_web_desc;

/* Checks the desc (a bad one changes nothing and names the field), binds and starts
 * the service thread. */
cv_result cv_web_server_start(const cv_web_desc *desc, cv_web_server **out);
/* The port bound (the ephemeral one when desc.port was 0). */
uint16_t cv_web_server_port(const cv_web_server *s);
/* Closes every connection (ws_close called for each), joins the thread, frees. */
void cv_web_server_stop(cv_web_server *s);

/* Queues a binary message, replacing an unsent replaceable one. Copies. Any thread. */
cv_result cv_web_send_binary(cv_web_conn *c, const void *data, size_t size);
/* Queues a binary message behind the unsent ones, never replaced (CV_ERROR_LIMIT_EXCEEDED
 * with 8 waiting, counted in binary_dropped). Copies. Any thread. */
cv_result cv_web_send_binary_in_order(cv_web_conn *c, const void *data, size_t size);
/* Queues a text message (NUL-terminated, copied) behind the unsent ones. Any thread. */
cv_result cv_web_send_text(cv_web_conn *c, const char *text);

typedef struct cv_web_stats {
    uint64_t http_requests, http_refused; /* refused: 401, 404, 405, 411, 413 */
    uint64_t ws_opened, ws_open_now;
    uint64_t binary_sent, binary_replaced; /* replaced: unsent frames a newer one replaced */
    uint64_t binary_dropped;               /* in-order frames refused: 8 already waited */
    uint64_t text_sent, text_dropped;      /* dropped: over text_queue_max */
    uint64_t bytes_sent;                   /* WebSocket payload bytes written */
} cv_web_stats;
void cv_web_server_get_stats(cv_web_server *s, cv_web_stats *out);

#endif
