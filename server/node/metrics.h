/* corvid-node's Prometheus metrics: the registry (counters, gauges and the
 * pass-time histogram) and its text exposition, format 0.0.4.
 *
 * The node's own counters (sessions, messages, bytes, submissions, errors) and
 * the content store's (hits, misses, bytes) stay where they are; the registry
 * adds what has no other home: live resource bytes per node device, a histogram
 * of GPU pass times by pass label (fed from the timings a session reads for
 * Completed), and node-loss events (transfers into this node's sessions that a client gave up because
 * their source node was lost: peer.c).
 * cv_node_metrics_text renders all of it; metrics_http.c serves that text at
 * /metrics with libmicrohttpd.
 *
 *     cv_metrics_server *ms;
 *     cv_metrics_server_config mc = { .address = "127.0.0.1", .port = 0, .token = NULL };
 *     if (cv_metrics_server_start(node, &mc, &ms) == CV_OK) {
 *         printf("metrics on port %d\n", cv_metrics_server_port(ms));
 *         ...
 *         cv_metrics_server_stop(ms);   // before cv_node_stop
 *     }
 *
 * Thread-safe: sessions feed the registry from their threads while a scrape
 * reads it. */
#ifndef CORVID_NODE_METRICS_H
#define CORVID_NODE_METRICS_H

#include <stddef.h>
#include <stdint.h>

#include "corvid/device.h"
#include "corvid/types.h"
#include "node.h"

typedef struct cv_node_metrics cv_node_metrics;

/* Distinct pass labels the histogram keeps; later labels are counted as pass="other",
 * so a client cannot grow the node's memory or the scrape with made-up labels. */
#define CV_NODE_METRICS_MAX_PASSES 32u

/* The registry, for `device_count` node devices (NULL when out of memory). */
cv_node_metrics *cv_node_metrics_create(uint32_t device_count);
void cv_node_metrics_destroy(cv_node_metrics *m);

/* Bytes a resource takes on a device as the node counts them: a buffer's size,
 * a texture's texels times texel size, an acceleration structure's nodes and
 * triangles; 0 for samplers, pipelines and command lists. */
uint64_t cv_node_resource_bytes(const cv_resource_desc *desc);
/* Adds `delta` (negative when freed) to device `device`'s live resource bytes. */
void cv_node_metrics_device_bytes(cv_node_metrics *m, uint32_t device, int64_t delta);
/* Records one finished submission's pass timings (milliseconds, as the device reports them). */
void cv_node_metrics_passes(cv_node_metrics *m, const cv_pass_timing *timings, uint32_t count);
/* One node of a cluster lost (the cluster work calls this). */
void cv_node_metrics_node_loss(cv_node_metrics *m);

/* The node's metrics as Prometheus text (format 0.0.4), snprintf-style: writes
 * at most `cap` bytes including the NUL and returns the length of the whole text,
 * so a caller whose buffer was short can retry with that length + 1. */
size_t cv_node_metrics_text(cv_node *node, char *buf, size_t cap);

/* The HTTP endpoint (metrics_http.c, libmicrohttpd): GET /metrics answers the
 * text above, any other path 404. The server reads the node on every scrape: stop
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
