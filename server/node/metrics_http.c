/* The node's /metrics endpoint (metrics.h), served by libmicrohttpd on its own
 * polling thread: GET or HEAD /metrics answers the Prometheus text, other paths
 * 404, other methods 405. Each scrape renders the text afresh from the node. */
#include <microhttpd.h>
#include <netdb.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>

#include "metrics.h"

#define CONTENT_TYPE "text/plain; version=0.0.4; charset=utf-8"

struct cv_metrics_server {
    cv_node *node;
    struct MHD_Daemon *daemon;
    int port;
};

static enum MHD_Result answer_text(struct MHD_Connection *conn, unsigned status, const char *text) {
    struct MHD_Response *resp = MHD_create_response_from_buffer(strlen(text), (void *)text, MHD_RESPMEM_PERSISTENT);
    if (!resp)
        return MHD_NO;
    MHD_add_response_header(resp, MHD_HTTP_HEADER_CONTENT_TYPE, "text/plain; charset=utf-8");
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
    enum MHD_Result ok = MHD_queue_response(conn, MHD_HTTP_OK, resp);
    MHD_destroy_response(resp);
    return ok;
}

cv_result cv_metrics_server_start(cv_node *node, const char *address, int port, cv_metrics_server **out) {
    if (!node || !out)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_metrics_server_start: NULL node or out");
    if (port < 0 || port > 65535)
        return cv_error(CV_ERROR_OUT_OF_RANGE, "metrics: port %d (0..65535; 0 picks a free one)", port);
    if (!address || !*address)
        address = "127.0.0.1";
    char port_text[8];
    snprintf(port_text, sizeof(port_text), "%d", port);
    struct addrinfo hints = { .ai_flags = AI_NUMERICHOST | AI_NUMERICSERV | AI_PASSIVE, .ai_socktype = SOCK_STREAM },
                    *ai = NULL;
    /* "[::1]" as well as "::1". */
    char host[64];
    size_t len = strlen(address);
    if (len >= 2 && address[0] == '[' && address[len - 1] == ']')
        snprintf(host, sizeof(host), "%.*s", (int)(len - 2), address + 1);
    else
        snprintf(host, sizeof(host), "%s", address);
    int gai = getaddrinfo(host, port_text, &hints, &ai);
    if (gai != 0)
        return cv_error(CV_ERROR_INVALID_ARGUMENT,
                        "metrics: listen address '%s' is not a numeric IPv4 or IPv6 "
                        "address (%s)",
                        address, gai_strerror(gai));
    cv_metrics_server *s = calloc(1, sizeof(*s));
    if (!s) {
        freeaddrinfo(ai);
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "cv_metrics_server_start");
    }
    s->node = node;
    unsigned flags = MHD_USE_INTERNAL_POLLING_THREAD | MHD_USE_ERROR_LOG;
    if (ai->ai_family == AF_INET6)
        flags |= MHD_USE_IPv6;
    s->daemon = MHD_start_daemon(flags, (uint16_t)port, NULL, NULL, on_request, s, MHD_OPTION_SOCK_ADDR, ai->ai_addr,
                                 MHD_OPTION_CONNECTION_LIMIT, (unsigned)32, MHD_OPTION_CONNECTION_TIMEOUT,
                                 (unsigned)10, MHD_OPTION_END);
    freeaddrinfo(ai);
    if (!s->daemon) {
        free(s);
        return cv_error(CV_ERROR_IO,
                        "metrics: cannot listen on %s port %d (in use, or not an address of this "
                        "machine)",
                        address, port);
    }
    const union MHD_DaemonInfo *info = MHD_get_daemon_info(s->daemon, MHD_DAEMON_INFO_BIND_PORT);
    s->port = info ? info->port : port;
    *out = s;
    return CV_OK;
}

int cv_metrics_server_port(const cv_metrics_server *server) { return server ? server->port : 0; }

void cv_metrics_server_stop(cv_metrics_server *server) {
    if (!server)
        return;
    MHD_stop_daemon(server->daemon);
    free(server);
}
