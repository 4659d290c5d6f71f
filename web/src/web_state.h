/* The web server's state, shared by its parts: the service (lifecycle and
 * thread), the protocol callback, HTTP requests and WebSocket connections.
 *
 * Locking: `lock` guards every connection's outgoing messages, the list of
 * connections that asked to be woken, the stats and `stopping`. Everything else
 * belongs to the service thread (lws calls us on it only). */
#ifndef CORVID_WEB_STATE_H
#define CORVID_WEB_STATE_H

#include <corvid/web_server.h>

#include <libwebsockets.h>
#include <pthread.h>
#include <stdbool.h>

/* One outgoing message, LWS_PRE bytes of room before its payload (lws writes
 * the frame header there). */
typedef struct web_message {
    uint8_t *buf; /* LWS_PRE + size bytes */
    size_t size;
} web_message;

/* Unsent binary messages a connection holds: in-order streams (H.264) wait here
 * behind each other; the live's credits keep them to one or two. */
#define WEB_BINARY_QUEUE 8u

struct cv_web_conn {
    cv_web_server *server;
    struct lws *wsi;
    cv_web_conn *prev, *next; /* the server's open connections (service thread) */
    /* Guarded by server->lock: */
    /* Unsent frames, oldest first: a replaceable one (cv_web_send_binary) gives way to
     * the next frame; an in-order one (cv_web_send_binary_in_order) never does. */
    web_message binary[WEB_BINARY_QUEUE];
    bool binary_replaceable[WEB_BINARY_QUEUE];
    uint32_t binary_head, binary_count;
    web_message *texts; /* ring of text_queue_max */
    uint32_t text_head, text_count;
    bool closing;     /* its close callback ran: sends are refused */
    bool wake_listed; /* on server->wake */
    cv_web_conn *wake_next;
    /* Service thread: */
    uint8_t *rx; /* the incoming message being assembled */
    size_t rx_size;
};

/* Per-connection session (lws' per_session_data): an HTTP transaction, or a
 * WebSocket connection after the upgrade. */
typedef struct web_session {
    cv_web_conn *conn;
    /* HTTP: the request being read, then the response being written. */
    char method[8];
    char *path, *query, *content_type;
    uint8_t *body;
    size_t body_size, body_expected;
    bool body_pending; /* waiting for body chunks before calling the handler */
    bool head;         /* HEAD: headers only */
    bool close_after;  /* 411, 413: the unread body would follow as a request: close instead */
    cv_http_response resp;
    const uint8_t *out; /* resp.body or an asset's bytes */
    size_t out_size, out_sent;
} web_session;

struct cv_web_server {
    char *host, *token, *tls_cert, *tls_key;
    cv_web_asset *assets;
    uint32_t asset_count;
    size_t max_body_bytes, ws_max_message_bytes;
    uint32_t text_queue_max;
    cv_http_handler api;
    void *api_user;
    void (*ws_open)(void *user, cv_web_conn *c);
    void (*ws_text)(void *user, cv_web_conn *c, const char *text, size_t size);
    void (*ws_close)(void *user, cv_web_conn *c);
    void *ws_user;

    struct lws_protocols protocols[2];
    struct lws_context *context;
    uint16_t port;
    pthread_t thread;
    uint8_t *scratch;   /* LWS_PRE + WEB_CHUNK_BYTES: HTTP headers and body chunks */
    cv_web_conn *conns; /* service thread */

    pthread_mutex_t lock;
    cv_web_conn *wake; /* connections with new messages to write */
    bool stopping;
    cv_web_stats stats;
};

/* HTTP bodies go out in pieces of this size (and headers are built in the same scratch). */
#define WEB_CHUNK_BYTES (64u * 1024u)

#endif
