/* The node's Prometheus text (metrics_text.h): the node's own counters, then
 * the registry's series (metrics.c). */
#include "metrics_text.h"

#include <stdatomic.h>

#include "node_internal.h"

size_t cv_node_metrics_text(cv_node *node, char *buf, size_t cap) {
    cv_metrics_writer w = { .buf = buf, .cap = cap };
    if (buf && cap)
        buf[0] = '\0';
    cv_node_stats st = cv_node_get_stats(node);

    cv_metrics_scalar(&w, "corvid_node_sessions_active", "gauge", "Client sessions running now.", st.sessions_active);
    cv_metrics_scalar(&w, "corvid_node_sessions_total", "counter", "Client sessions started since the node started.",
                      st.sessions_started);
    cv_metrics_scalar(&w, "corvid_node_draining", "gauge", "1 once the node drains (new sessions refused), else 0.",
                      atomic_load(&node->draining) ? 1 : 0);
    cv_metrics_scalar(&w, "corvid_node_messages_received_total", "counter", "Client messages received, all sessions.",
                      st.messages_in);
    cv_metrics_scalar(&w, "corvid_node_submissions_total", "counter",
                      "Command-list submissions (a frame is one or more), including failed ones.", st.submissions);
    cv_metrics_scalar(&w, "corvid_node_bytes_received_total", "counter",
                      "Bytes of session messages received from clients.", st.bytes_in);
    cv_metrics_scalar(&w, "corvid_node_bytes_sent_total", "counter", "Bytes of session messages sent to clients.",
                      st.bytes_out);
    cv_metrics_scalar(&w, "corvid_node_cache_hits_total", "counter", "Content store lookups that found their blob.",
                      st.cache_hits);
    cv_metrics_scalar(&w, "corvid_node_cache_misses_total", "counter", "Content store lookups that did not.",
                      st.cache_misses);
    cv_metrics_scalar(&w, "corvid_node_cache_bytes", "gauge", "Bytes held by the content store.", st.cache_bytes);
    cv_metrics_scalar(&w, "corvid_node_errors_total", "counter",
                      "Requests answered with an error, failed submissions and sessions ended with an error status.",
                      st.errors);
    cv_metrics_scalar(&w, "corvid_node_devices_abandoned_total", "counter",
                      "Session devices leaked because their GPU work did not finish (--submit-timeout, or still "
                      "running "
                      "at the session's end).",
                      st.devices_abandoned);

    const char *labels[CV_MAX_DEVICES];
    uint32_t count = node->config.device_count < CV_MAX_DEVICES ? node->config.device_count : CV_MAX_DEVICES;
    for (uint32_t i = 0; i < count; i++)
        labels[i] = node->devices[i].label;
    cv_node_metrics_write(node->metrics, labels, count, &w);
    return w.len;
}
