/* corvid-node's metrics registry (metrics.h): what it counts, and its own series of the Prometheus text. */
#include "metrics.h"
#include "node_log.h"

#include <inttypes.h>
#include <pthread.h>
#include <stdarg.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

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

void cv_metrics_emit(cv_metrics_writer *w, const char *fmt, ...) {
    va_list ap;
    va_start(ap, fmt);
    size_t room = w->len < w->cap ? w->cap - w->len : 0;
    int n = vsnprintf(room ? w->buf + w->len : NULL, room, fmt, ap);
    va_end(ap);
    if (n > 0)
        w->len += (size_t)n;
}

/* A label value with \, " and newline escaped, as the format requires. */
void cv_metrics_escape_label(const char *in, char *out, size_t cap) {
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

void cv_metrics_header(cv_metrics_writer *w, const char *name, const char *type, const char *help) {
    cv_metrics_emit(w, "# HELP %s %s\n# TYPE %s %s\n", name, help, name, type);
}

void cv_metrics_scalar(cv_metrics_writer *w, const char *name, const char *type, const char *help, uint64_t value) {
    cv_metrics_header(w, name, type, help);
    cv_metrics_emit(w, "%s %" PRIu64 "\n", name, value);
}

void cv_node_metrics_write(cv_node_metrics *m, const char *const *device_labels, uint32_t device_count,
                           cv_metrics_writer *w) {
    cv_metrics_header(w, "corvid_node_device_memory_bytes", "gauge",
                      "Bytes of live resources (buffers, textures, acceleration structures) sessions hold on each "
                      "node device.");
    for (uint32_t i = 0; i < device_count; i++) {
        char label[2 * CV_LABEL_MAX + 1];
        cv_metrics_escape_label(device_labels[i], label, sizeof(label));
        int64_t bytes = m && i < m->device_count ? atomic_load(&m->device_bytes[i]) : 0;
        cv_metrics_emit(w, "corvid_node_device_memory_bytes{device=\"%s\"} %" PRId64 "\n", label,
                        bytes < 0 ? 0 : bytes);
    }

    cv_metrics_header(w, "corvid_node_gpu_pass_seconds", "histogram",
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
            cv_metrics_escape_label(h->label, label, sizeof(label));
            uint64_t cumulative = 0;
            for (uint32_t b = 0; b < BUCKETS; b++) {
                cumulative += h->buckets[b];
                cv_metrics_emit(w, "corvid_node_gpu_pass_seconds_bucket{pass=\"%s\",le=\"%g\"} %" PRIu64 "\n", label,
                                pass_buckets[b], cumulative);
            }
            cv_metrics_emit(w, "corvid_node_gpu_pass_seconds_bucket{pass=\"%s\",le=\"+Inf\"} %" PRIu64 "\n", label,
                            h->count);
            cv_metrics_emit(w, "corvid_node_gpu_pass_seconds_sum{pass=\"%s\"} %.9g\n", label, h->sum);
            cv_metrics_emit(w, "corvid_node_gpu_pass_seconds_count{pass=\"%s\"} %" PRIu64 "\n", label, h->count);
        }
        pthread_mutex_unlock(&m->lock);
    }

    cv_metrics_scalar(w, "corvid_node_node_loss_events_total", "counter",
                      "Cluster nodes lost (fed by the cluster work; always 0 on a node without it).",
                      m ? atomic_load(&m->node_loss_events) : 0);
}
