/* corvid-node's /metrics endpoint over HTTP (libmicrohttpd): serves the
 * node's Prometheus text (metrics_text.h) to scrapers.
 *
 *     cv_metrics_server *ms;
 *     cv_metrics_server_config mc = { .address = "127.0.0.1", .port = 0, .token = NULL };
 *     if (cv_metrics_server_start(node, &mc, &ms) == CV_OK) {
 *         printf("metrics on port %d\n", cv_metrics_server_port(ms));
 *         ...
 *         cv_metrics_server_stop(ms);   // before cv_node_stop
 *     }
 */
#ifndef CORVID_NODE_METRICS_HTTP_H
#define CORVID_NODE_METRICS_HTTP_H

#include "node.h"

/* The HTTP endpoint (metrics_http.c, libmicrohttpd): GET /metrics answers the
 * node's text (cv_node_metrics_text), any other path 404. The server reads the node on every scrape: stop
 * it before stopping the node. Idle and slow clients cannot block it: 512
 * connections, each closed after one request or 5 s, whichever comes first. */
typedef struct cv_metrics_server_config {
    const char *address; /* numeric IPv4 or IPv6 address; NULL = 127.0.0.1 */
    int port;            /* 0 picks a free one */
    /* NULL = none; else /metrics answers 401 without "Authorization: Bearer <token>" (Prometheus:
       authorization.credentials_file). Only its SHA-256 is kept, compared in constant time. */
    const char *token;
    uint32_t deadline_ms; /* a connection's whole life, however slowly it sends; 0 = 5000 */
} cv_metrics_server_config;
typedef struct cv_metrics_server cv_metrics_server;
cv_result cv_metrics_server_start(cv_node *node, const cv_metrics_server_config *config, cv_metrics_server **out);
int cv_metrics_server_port(const cv_metrics_server *server);
void cv_metrics_server_stop(cv_metrics_server *server);

#endif
