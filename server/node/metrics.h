/* corvid-node's Prometheus metrics registry (counters, gauges and the
 * pass-time histogram) and the writing of Prometheus text, format 0.0.4.
 *
 * The node's own counters (sessions, messages, bytes, submissions, errors) and
 * the content store's (hits, misses, bytes) stay where they are; the registry
 * adds what has no other home: live resource bytes per node device, a histogram
 * of GPU pass times by pass label (fed from the timings a session reads for
 * Completed), and node-loss events (transfers into this node's sessions that a client gave up because
 * their source node was lost: peer.c).
 * cv_node_metrics_text (metrics_text.h) renders the node's text with it;
 * metrics_http.c serves that at /metrics with libmicrohttpd (metrics_http.h).
 *
 *     cv_node_metrics *m = cv_node_metrics_create(device_count);
 *     cv_node_metrics_device_bytes(m, 0, (int64_t)cv_node_resource_bytes(&desc));  // a create on device 0
 *     cv_node_metrics_passes(m, timings, count);                                  // a finished submission
 *
 * Thread-safe: sessions feed the registry from their threads while a scrape
 * reads it. */
#ifndef CORVID_NODE_METRICS_H
#define CORVID_NODE_METRICS_H

#include <stddef.h>
#include <stdint.h>

#include "corvid/context.h"
#include "corvid/device_info.h"
#include "corvid/types.h"

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

/* Writing Prometheus text, snprintf-style: what does not fit in `cap` is
 * counted in `len` but not written. */
typedef struct cv_metrics_writer {
    char *buf;
    size_t cap, len;
} cv_metrics_writer;
void cv_metrics_emit(cv_metrics_writer *w, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
/* A label value with \, " and newline escaped, as the format requires. */
void cv_metrics_escape_label(const char *in, char *out, size_t cap);
void cv_metrics_header(cv_metrics_writer *w, const char *name, const char *type, const char *help);
void cv_metrics_scalar(cv_metrics_writer *w, const char *name, const char *type, const char *help, uint64_t value);

/* Appends the registry's series: device memory (one per label of the node's
 * devices, in order), the pass-time histogram, node-loss events. */
void cv_node_metrics_write(cv_node_metrics *m, const char *const *device_labels, uint32_t device_count,
                           cv_metrics_writer *w);

#endif
