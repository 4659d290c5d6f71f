/* corvid-node's metrics as Prometheus text (format 0.0.4): the node's own
 * counters (sessions, messages, bytes, submissions, errors, the content
 * store's) followed by the registry's series (metrics.h). It reads the node, so
 * it sits above it, and the registry below stays free of the node.
 *
 *     size_t need = cv_node_metrics_text(node, NULL, 0);
 *     char *text = malloc(need + 1);
 *     cv_node_metrics_text(node, text, need + 1);   // == need
 *
 * Thread-safe, like the registry. */
#ifndef CORVID_NODE_METRICS_TEXT_H
#define CORVID_NODE_METRICS_TEXT_H

#include <stddef.h>

#include "node.h"

/* snprintf-style: writes at most `cap` bytes including the NUL and returns the
 * length of the whole text, so a caller whose buffer was short can retry with
 * that length + 1. */
size_t cv_node_metrics_text(cv_node *node, char *buf, size_t cap);

#endif
