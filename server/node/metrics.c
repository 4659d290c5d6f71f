/* corvid-node's metrics registry and its Prometheus text (metrics.h). */
#include "metrics.h"
#include "node_log.h"

#include <inttypes.h>
#include <pthread.h>
#include <stdarg.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "node_internal.h"

/* Upper bounds of the pass-time buckets, in seconds: a GPU pass takes from a
 * fraction of a millisecond (a small copy) to seconds (a big frame on lavapipe). */
static const double pass_buckets[] = { 0.0005, 0.001, 0.0025, 0.005, 0.01, 0.025, 0.05,
                                       0.1,    0.25,  0.5,    1.0,   2.5,  5.0,   10.0 };
#define BUCKETS (sizeof(pass_buckets) / sizeof(pass_buckets[0]))

typedef struct pass_histogram {
    char label[CV_LABEL_MAX];
    uint64_t buckets[BUCKETS]; /* not cumulative; the text makes them so */
    uint64_t count;
    double sum; /* seconds */
} pass_histogram;

struct cv_node_metrics {
    uint32_t device_count;
    atomic_int_fast64_t *device_bytes;
    atomic_uint_fast64_t node_loss_events;
    pthread_mutex_t lock;                                  /* the histograms */
    pass_histogram passes[CV_NODE_METRICS_MAX_PASSES + 1]; /* the last is "other" */
    uint32_t pass_count;
};

cv_node_metrics *cv_node_metrics_create(uint32_t device_count) {
    cv_node_metrics *m = calloc(1, sizeof(*m));
    if (!m)
        return NULL;
    m->device_bytes = calloc(device_count ? device_count : 1, sizeof(*m->device_bytes));
    if (!m->device_bytes) {
        free(m);
        return NULL;
    }
    m->device_count = device_count;
    for (uint32_t i = 0; i < device_count; i++)
        atomic_init(&m->device_bytes[i], 0);
    atomic_init(&m->node_loss_events, 0);
    pthread_mutex_init(&m->lock, NULL);
    snprintf(m->passes[CV_NODE_METRICS_MAX_PASSES].label, CV_LABEL_MAX, "other");
    return m;
}

void cv_node_metrics_destroy(cv_node_metrics *m) {
    if (!m)
        return;
    pthread_mutex_destroy(&m->lock);
    free(m->device_bytes);
    free(m);
}

uint64_t cv_node_resource_bytes(const cv_resource_desc *desc) {
    switch (desc->type) {
    case CV_HANDLE_BUFFER: return desc->buffer.size;
    case CV_HANDLE_TEXTURE:
        return (uint64_t)desc->texture.width * desc->texture.height * cv_format_bytes(desc->texture.format);
    case CV_HANDLE_ACCEL:
        return (uint64_t)desc->accel.node_count * CV_ACCEL_NODE_BYTES +
               (uint64_t)desc->accel.triangle_count * CV_ACCEL_TRIANGLE_BYTES;
    default: return 0;
    }
}

void cv_node_metrics_device_bytes(cv_node_metrics *m, uint32_t device, int64_t delta) {
    if (m && device < m->device_count && delta)
        atomic_fetch_add(&m->device_bytes[device], delta);
}

void cv_node_metrics_node_loss(cv_node_metrics *m) {
    if (m)
        atomic_fetch_add(&m->node_loss_events, 1);
}

/* The histogram of a label, created on first use; "other" once the table is full. */
static pass_histogram *histogram_for(cv_node_metrics *m, const char *label) {
    for (uint32_t i = 0; i < m->pass_count; i++)
        if (strcmp(m->passes[i].label, label) == 0)
            return &m->passes[i];
    if (m->pass_count == CV_NODE_METRICS_MAX_PASSES || !label[0])
        return &m->passes[CV_NODE_METRICS_MAX_PASSES];
    pass_histogram *h = &m->passes[m->pass_count++];
    snprintf(h->label, sizeof(h->label), "%s", label);
    return h;
}

void cv_node_metrics_passes(cv_node_metrics *m, const cv_pass_timing *timings, uint32_t count) {
    if (!m || !count)
        return;
    pthread_mutex_lock(&m->lock);
    for (uint32_t i = 0; i < count; i++) {
        char raw[CV_LABEL_MAX], label[CV_LABEL_MAX];
        snprintf(raw, sizeof(raw), "%s", timings[i].label); /* a device's label may lack its NUL */
        cv_log_escape(label, sizeof(label), raw);           /* a client's label: one line of valid UTF-8 */
        double seconds = timings[i].duration_ms > 0 ? timings[i].duration_ms / 1000.0 : 0.0;
        pass_histogram *h = histogram_for(m, label);
        uint32_t b = 0;
        while (b < BUCKETS && seconds > pass_buckets[b])
            b++;
        if (b < BUCKETS)
            h->buckets[b]++;
        h->count++;
        h->sum += seconds;
    }
    pthread_mutex_unlock(&m->lock);
}

/* ---- the text ------------------------------------------------------------------ */

typedef struct writer {
    char *buf;
    size_t cap, len; /* len counts what did not fit too */
} writer;

static void emit(writer *w, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void emit(writer *w, const char *fmt, ...) {
    va_list ap;
    va_start(ap, fmt);
    size_t room = w->len < w->cap ? w->cap - w->len : 0;
    int n = vsnprintf(room ? w->buf + w->len : NULL, room, fmt, ap);
    va_end(ap);
    if (n > 0)
        w->len += (size_t)n;
}

/* A label value with \, " and newline escaped, as the format requires. */
static void escape_label(const char *in, char *out, size_t cap) {
    size_t o = 0;
    for (; *in && o + 3 < cap; in++) {
        if (*in == '\\' || *in == '"') {
            out[o++] = '\\';
            out[o++] = *in;
        } else if (*in == '\n') {
            out[o++] = '\\';
            out[o++] = 'n';
        } else {
            out[o++] = *in;
        }
    }
    out[o] = '\0';
}

static void header(writer *w, const char *name, const char *type, const char *help) {
    emit(w, "# HELP %s %s\n# TYPE %s %s\n", name, help, name, type);
}

static void scalar(writer *w, const char *name, const char *type, const char *help, uint64_t value) {
    header(w, name, type, help);
    emit(w, "%s %" PRIu64 "\n", name, value);
}

size_t cv_node_metrics_text(cv_node *node, char *buf, size_t cap) {
    writer w = { .buf = buf, .cap = cap };
    if (buf && cap)
        buf[0] = '\0';
    cv_node_stats st = cv_node_get_stats(node);
    cv_node_metrics *m = node->metrics;

    scalar(&w, "corvid_node_sessions_active", "gauge", "Client sessions running now.", st.sessions_active);
    scalar(&w, "corvid_node_sessions_total", "counter", "Client sessions started since the node started.",
           st.sessions_started);
    scalar(&w, "corvid_node_draining", "gauge", "1 once the node drains (new sessions refused), else 0.",
           atomic_load(&node->draining) ? 1 : 0);
    scalar(&w, "corvid_node_messages_received_total", "counter", "Client messages received, all sessions.",
           st.messages_in);
    scalar(&w, "corvid_node_submissions_total", "counter",
           "Command-list submissions (a frame is one or more), including failed ones.", st.submissions);
    scalar(&w, "corvid_node_bytes_received_total", "counter", "Bytes of session messages received from clients.",
           st.bytes_in);
    scalar(&w, "corvid_node_bytes_sent_total", "counter", "Bytes of session messages sent to clients.", st.bytes_out);
    scalar(&w, "corvid_node_cache_hits_total", "counter", "Content store lookups that found their blob.",
           st.cache_hits);
    scalar(&w, "corvid_node_cache_misses_total", "counter", "Content store lookups that did not.", st.cache_misses);
    scalar(&w, "corvid_node_cache_bytes", "gauge", "Bytes held by the content store.", st.cache_bytes);
    scalar(&w, "corvid_node_errors_total", "counter",
           "Requests answered with an error, failed submissions and sessions ended with an error status.", st.errors);
    scalar(&w, "corvid_node_devices_abandoned_total", "counter",
           "Session devices leaked because their GPU work did not finish (--submit-timeout, or still running "
           "at the session's end).",
           st.devices_abandoned);

    header(&w, "corvid_node_device_memory_bytes", "gauge",
           "Bytes of live resources (buffers, textures, acceleration structures) sessions hold on each node device.");
    for (uint32_t i = 0; i < node->config.device_count; i++) {
        char label[2 * CV_LABEL_MAX + 1];
        escape_label(node->devices[i].label, label, sizeof(label));
        int64_t bytes = m && i < m->device_count ? atomic_load(&m->device_bytes[i]) : 0;
        emit(&w, "corvid_node_device_memory_bytes{device=\"%s\"} %" PRId64 "\n", label, bytes < 0 ? 0 : bytes);
    }

    header(&w, "corvid_node_gpu_pass_seconds", "histogram",
           "GPU time of each marked pass of finished submissions, by pass label (at most 32 labels, then "
           "\"other\"); a submission whose list was submitted again before it finished has no timings.");
    if (m) {
        pthread_mutex_lock(&m->lock);
        for (uint32_t i = 0; i <= CV_NODE_METRICS_MAX_PASSES; i++) {
            const pass_histogram *h = &m->passes[i];
            if (i >= m->pass_count && i != CV_NODE_METRICS_MAX_PASSES)
                continue;
            if (i == CV_NODE_METRICS_MAX_PASSES && h->count == 0)
                continue;
            char label[2 * CV_LABEL_MAX + 1];
            escape_label(h->label, label, sizeof(label));
            uint64_t cumulative = 0;
            for (uint32_t b = 0; b < BUCKETS; b++) {
                cumulative += h->buckets[b];
                emit(&w, "corvid_node_gpu_pass_seconds_bucket{pass=\"%s\",le=\"%g\"} %" PRIu64 "\n", label,
                     pass_buckets[b], cumulative);
            }
            emit(&w, "corvid_node_gpu_pass_seconds_bucket{pass=\"%s\",le=\"+Inf\"} %" PRIu64 "\n", label, h->count);
            emit(&w, "corvid_node_gpu_pass_seconds_sum{pass=\"%s\"} %.9g\n", label, h->sum);
            emit(&w, "corvid_node_gpu_pass_seconds_count{pass=\"%s\"} %" PRIu64 "\n", label, h->count);
        }
        pthread_mutex_unlock(&m->lock);
    }

    scalar(&w, "corvid_node_node_loss_events_total", "counter",
           "Cluster nodes lost (fed by the cluster work; always 0 on a node without it).",
           m ? atomic_load(&m->node_loss_events) : 0);
    return w.len;
}
