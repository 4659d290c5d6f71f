/* The node's /metrics endpoint (metrics.h), served by libmicrohttpd on its own
 * polling thread: GET or HEAD /metrics answers the Prometheus text, other paths
 * 404, other methods 405, and 401 without the bearer token when one is configured.
 * Each scrape renders the text afresh from the node.
 *
 * Idle or slow clients cannot hold the endpoint: it takes METRICS_MAX_CONNECTIONS
 * connections, each answers one request (Connection: close), and a reaper thread
 * shuts down every connection older than its deadline (5 s) however it trickles
 * its bytes (libmicrohttpd's own timeout counts from the last byte read, so a
 * client sending one byte a second would never reach it). */
#include <microhttpd.h>
#include <netdb.h>
#include <openssl/crypto.h>
#include <pthread.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/socket.h>

#include "corvid/clock.h"
#include "corvid/sha256.h"
#include "metrics.h"

#define CONTENT_TYPE "text/plain; version=0.0.4; charset=utf-8"
#define METRICS_MAX_CONNECTIONS 512u /* a scrape needs one; idle or slow ones are cut at the deadline */
#define METRICS_DEADLINE_MS 5000u    /* a connection's whole life: a scrape takes milliseconds */

/* A connection the reaper watches, from libmicrohttpd's STARTED notice to its CLOSED one (which comes before
 * the socket is closed, so the reaper never shuts down a descriptor that was reused). */
typedef struct watched {
    struct watched *next, *prev;
    MHD_socket fd;
    uint64_t started_ns;
    bool cut;
} watched;

struct cv_metrics_server {
    cv_node *node;
    struct MHD_Daemon *daemon;
    int port;
    uint32_t deadline_ms; /* a connection's whole life */
    bool has_token;
    uint8_t token_sha[CV_SHA256_SIZE];

    pthread_mutex_t lock; /* the list below and `stopping` */
    pthread_cond_t wake;
    watched *live;
    bool stopping;
    bool reaper_started;
    pthread_t reaper;
};

static enum MHD_Result answer_text(struct MHD_Connection *conn, unsigned status, const char *text) {
    struct MHD_Response *resp = MHD_create_response_from_buffer(strlen(text), (void *)text, MHD_RESPMEM_PERSISTENT);
    if (!resp)
        return MHD_NO;
    MHD_add_response_header(resp, MHD_HTTP_HEADER_CONTENT_TYPE, "text/plain; charset=utf-8");
    MHD_add_response_header(resp, MHD_HTTP_HEADER_CONNECTION, "close");
    enum MHD_Result ok = MHD_queue_response(conn, status, resp);
    MHD_destroy_response(resp);
    return ok;
}

/* The whole text in a buffer of its own (NULL when out of memory). */
static char *render(cv_node *node, size_t *size) {
    size_t cap = 16384;
    for (int attempt = 0; attempt < 4; attempt++) {
        char *buf = malloc(cap);
        if (!buf)
            return NULL;
        size_t n = cv_node_metrics_text(node, buf, cap);
        if (n < cap) {
            *size = n;
            return buf;
        }
        free(buf);
        cap = n + 1024; /* a histogram may have grown between the two passes */
    }
    return NULL;
}

/* "Authorization: Bearer <token>" with the right token, compared as SHA-256 digests in constant time. */
static bool authorized(const cv_metrics_server *server, struct MHD_Connection *conn) {
    if (!server->has_token)
        return true;
    const char *auth = MHD_lookup_connection_value(conn, MHD_HEADER_KIND, MHD_HTTP_HEADER_AUTHORIZATION);
    if (!auth || strncasecmp(auth, "Bearer ", 7) != 0)
        return false;
    uint8_t digest[CV_SHA256_SIZE];
    bool ok = cv_sha256(auth + 7, strlen(auth + 7), digest) == CV_OK &&
              CRYPTO_memcmp(digest, server->token_sha, sizeof(digest)) == 0;
    OPENSSL_cleanse(digest, sizeof(digest));
    return ok;
}

static enum MHD_Result answer_unauthorized(struct MHD_Connection *conn) {
    static const char text[] =
        "corvid-node metrics: unauthorized (send 'Authorization: Bearer <token>', the token "
        "of the node's --metrics-token-file)\n";
    struct MHD_Response *resp = MHD_create_response_from_buffer(strlen(text), (void *)text, MHD_RESPMEM_PERSISTENT);
    if (!resp)
        return MHD_NO;
    MHD_add_response_header(resp, MHD_HTTP_HEADER_CONTENT_TYPE, "text/plain; charset=utf-8");
    MHD_add_response_header(resp, MHD_HTTP_HEADER_WWW_AUTHENTICATE, "Bearer realm=\"corvid-node metrics\"");
    MHD_add_response_header(resp, MHD_HTTP_HEADER_CONNECTION, "close");
    enum MHD_Result ok = MHD_queue_response(conn, MHD_HTTP_UNAUTHORIZED, resp);
    MHD_destroy_response(resp);
    return ok;
}

static enum MHD_Result on_request(void *cls, struct MHD_Connection *conn, const char *url, const char *method,
                                  const char *version, const char *upload_data, size_t *upload_data_size,
                                  void **req_cls) {
    (void)version;
    (void)upload_data;
    (void)req_cls;
    cv_metrics_server *server = cls;
    if (*upload_data_size) /* a body we do not want: drop it */
        *upload_data_size = 0;
    if (strcmp(method, MHD_HTTP_METHOD_GET) != 0 && strcmp(method, MHD_HTTP_METHOD_HEAD) != 0)
        return answer_text(conn, MHD_HTTP_METHOD_NOT_ALLOWED, "corvid-node metrics: only GET and HEAD\n");
    if (strcmp(url, "/metrics") != 0)
        return answer_text(conn, MHD_HTTP_NOT_FOUND,
                           "corvid-node metrics: not found (the metrics are at /metrics)\n");
    if (!authorized(server, conn))
        return answer_unauthorized(conn);
    size_t size = 0;
    char *text = render(server->node, &size);
    if (!text)
        return answer_text(conn, MHD_HTTP_INTERNAL_SERVER_ERROR, "corvid-node metrics: out of memory\n");
    struct MHD_Response *resp = MHD_create_response_from_buffer(size, text, MHD_RESPMEM_MUST_FREE);
    if (!resp) {
        free(text);
        return MHD_NO;
    }
    MHD_add_response_header(resp, MHD_HTTP_HEADER_CONTENT_TYPE, CONTENT_TYPE);
    MHD_add_response_header(resp, MHD_HTTP_HEADER_CONNECTION, "close"); /* one request each: the deadline holds */
    enum MHD_Result ok = MHD_queue_response(conn, MHD_HTTP_OK, resp);
    MHD_destroy_response(resp);
    return ok;
}

/* ---- the deadline ---------------------------------------------------------- */

static void on_connection(void *cls, struct MHD_Connection *conn, void **socket_context,
                          enum MHD_ConnectionNotificationCode code) {
    cv_metrics_server *server = cls;
    if (code == MHD_CONNECTION_NOTIFY_STARTED) {
        const union MHD_ConnectionInfo *info = MHD_get_connection_info(conn, MHD_CONNECTION_INFO_CONNECTION_FD);
        watched *w = info ? calloc(1, sizeof(*w)) : NULL;
        if (!w)
            return; /* out of memory: this one goes unwatched (libmicrohttpd's idle timeout still applies) */
        w->fd = info->connect_fd;
        w->started_ns = cv_now_ns();
        pthread_mutex_lock(&server->lock);
        w->next = server->live;
        if (server->live)
            server->live->prev = w;
        server->live = w;
        pthread_mutex_unlock(&server->lock);
        *socket_context = w;
    } else if (code == MHD_CONNECTION_NOTIFY_CLOSED && *socket_context) {
        watched *w = *socket_context;
        pthread_mutex_lock(&server->lock);
        if (w->prev)
            w->prev->next = w->next;
        else
            server->live = w->next;
        if (w->next)
            w->next->prev = w->prev;
        pthread_mutex_unlock(&server->lock);
        free(w);
        *socket_context = NULL;
    }
}

/* Every 100 ms: connections older than the deadline are shut down, and libmicrohttpd closes them (it reads
 * the end of the stream). */
static void *reaper_main(void *arg) {
    cv_metrics_server *server = arg;
    pthread_mutex_lock(&server->lock);
    while (!server->stopping) {
        uint64_t now = cv_now_ns();
        for (watched *w = server->live; w; w = w->next)
            if (!w->cut && (now - w->started_ns) / 1000000u >= server->deadline_ms) {
                shutdown(w->fd, SHUT_RDWR);
                w->cut = true;
            }
        cv_cond_wait_until(&server->wake, &server->lock, cv_deadline_after_ms(100));
    }
    pthread_mutex_unlock(&server->lock);
    return NULL;
}

/* ---- the server ------------------------------------------------------------- */

/* The listen address as a socket address (freeaddrinfo it). */
static cv_result listen_address(const char *address, int port, struct addrinfo **ai) {
    char port_text[8];
    snprintf(port_text, sizeof(port_text), "%d", port);
    struct addrinfo hints = { .ai_flags = AI_NUMERICHOST | AI_NUMERICSERV | AI_PASSIVE, .ai_socktype = SOCK_STREAM };
    /* "[::1]" as well as "::1". */
    char host[64];
    size_t len = strlen(address);
    if (len >= 2 && address[0] == '[' && address[len - 1] == ']')
        snprintf(host, sizeof(host), "%.*s", (int)(len - 2), address + 1);
    else
        snprintf(host, sizeof(host), "%s", address);
    int gai = getaddrinfo(host, port_text, &hints, ai);
    if (gai != 0)
        return cv_error(CV_ERROR_INVALID_ARGUMENT,
                        "metrics: listen address '%s' is not a numeric IPv4 or IPv6 address (%s)", address,
                        gai_strerror(gai));
    return CV_OK;
}

static void free_server(cv_metrics_server *s) {
    if (s->reaper_started) {
        pthread_mutex_lock(&s->lock);
        s->stopping = true;
        pthread_cond_signal(&s->wake);
        pthread_mutex_unlock(&s->lock);
        pthread_join(s->reaper, NULL);
    }
    pthread_cond_destroy(&s->wake);
    pthread_mutex_destroy(&s->lock);
    OPENSSL_cleanse(s->token_sha, sizeof(s->token_sha));
    free(s);
}

cv_result cv_metrics_server_start(cv_node *node, const cv_metrics_server_config *config, cv_metrics_server **out) {
    if (!node || !config || !out)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_metrics_server_start: NULL node, config or out");
    if (config->port < 0 || config->port > 65535)
        return cv_error(CV_ERROR_OUT_OF_RANGE, "metrics: port %d (0..65535; 0 picks a free one)", config->port);
    if (config->token && !config->token[0])
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "metrics: the token is empty");
    const char *address = config->address && *config->address ? config->address : "127.0.0.1";
    struct addrinfo *ai = NULL;
    cv_result r = listen_address(address, config->port, &ai);
    if (r != CV_OK)
        return r;
    cv_metrics_server *s = calloc(1, sizeof(*s));
    if (!s) {
        freeaddrinfo(ai);
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "cv_metrics_server_start");
    }
    s->node = node;
    s->deadline_ms = config->deadline_ms ? config->deadline_ms : METRICS_DEADLINE_MS;
    pthread_mutex_init(&s->lock, NULL);
    cv_cond_init(&s->wake);
    if (config->token) {
        s->has_token = true;
        r = cv_sha256(config->token, strlen(config->token), s->token_sha);
    }
    if (r == CV_OK && pthread_create(&s->reaper, NULL, reaper_main, s) != 0)
        r = cv_error(CV_ERROR_OUT_OF_MEMORY, "metrics: cannot start the connection reaper thread");
    s->reaper_started = r == CV_OK;
    /* epoll (MHD_USE_AUTO): no FD_SETSIZE ceiling on the descriptors. */
    unsigned flags = MHD_USE_AUTO_INTERNAL_THREAD | MHD_USE_ERROR_LOG;
    if (ai->ai_family == AF_INET6)
        flags |= MHD_USE_IPv6;
    if (r == CV_OK)
        s->daemon = MHD_start_daemon(flags, (uint16_t)config->port, NULL, NULL, on_request, s, MHD_OPTION_SOCK_ADDR,
                                     ai->ai_addr, MHD_OPTION_CONNECTION_LIMIT, (unsigned)METRICS_MAX_CONNECTIONS,
                                     MHD_OPTION_CONNECTION_TIMEOUT, (unsigned)(s->deadline_ms + 999) / 1000,
                                     MHD_OPTION_NOTIFY_CONNECTION, on_connection, s, MHD_OPTION_END);
    freeaddrinfo(ai);
    if (r == CV_OK && !s->daemon)
        r = cv_error(CV_ERROR_IO, "metrics: cannot listen on %s port %d (in use, or not an address of this machine)",
                     address, config->port);
    if (r != CV_OK) {
        free_server(s);
        return r;
    }
    const union MHD_DaemonInfo *info = MHD_get_daemon_info(s->daemon, MHD_DAEMON_INFO_BIND_PORT);
    s->port = info ? info->port : config->port;
    *out = s;
    return CV_OK;
}

int cv_metrics_server_port(const cv_metrics_server *server) { return server ? server->port : 0; }

void cv_metrics_server_stop(cv_metrics_server *server) {
    if (!server)
        return;
    MHD_stop_daemon(server->daemon); /* closes every connection: CLOSED notices empty the list */
    free_server(server);
}
