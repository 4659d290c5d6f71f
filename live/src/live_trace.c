/* The live loop's trace (corvid/live_trace.h): events kept in memory under a
 * lock, written sorted by time as Chrome trace event JSON. */
#include "corvid/live_trace.h"

#include <errno.h>
#include <pthread.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* One span (end >= start) or instant. */
typedef struct trace_event {
    double start_ms, end_ms;
    uint64_t frame, step;
    uint32_t track;
    bool instant;
} trace_event;

struct cv_live_trace {
    pthread_mutex_t lock;
    const char *tracks[CV_LIVE_TRACE_MAX_TRACKS];
    uint32_t track_count;
    trace_event *events;
    size_t count, capacity;
    uint64_t dropped;
};

cv_result cv_live_trace_create(cv_live_trace **out) {
    if (!out)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "live trace: create: NULL out");
    cv_live_trace *t = calloc(1, sizeof(*t));
    if (!t)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "live trace: create: no memory");
    pthread_mutex_init(&t->lock, NULL);
    *out = t;
    return CV_OK;
}

void cv_live_trace_destroy(cv_live_trace *t) {
    if (!t)
        return;
    pthread_mutex_destroy(&t->lock);
    free(t->events);
    free(t);
}

/* The track's index, made on first use (lock held); CV_LIVE_TRACE_MAX_TRACKS when full. */
static uint32_t track_of(cv_live_trace *t, const char *name) {
    for (uint32_t i = 0; i < t->track_count; i++)
        if (!strcmp(t->tracks[i], name))
            return i;
    if (t->track_count == CV_LIVE_TRACE_MAX_TRACKS)
        return CV_LIVE_TRACE_MAX_TRACKS;
    t->tracks[t->track_count] = name;
    return t->track_count++;
}

static void add(cv_live_trace *t, const char *track, trace_event e) {
    if (!t || !track)
        return;
    pthread_mutex_lock(&t->lock);
    e.track = track_of(t, track);
    if (e.track < CV_LIVE_TRACE_MAX_TRACKS && t->count == t->capacity && t->capacity < CV_LIVE_TRACE_MAX_EVENTS) {
        size_t cap = t->capacity ? 2 * t->capacity : 1024;
        trace_event *p = realloc(t->events, cap * sizeof(*p));
        if (p) {
            t->events = p;
            t->capacity = cap;
        }
    }
    if (e.track < CV_LIVE_TRACE_MAX_TRACKS && t->count < t->capacity)
        t->events[t->count++] = e;
    else
        t->dropped++;
    pthread_mutex_unlock(&t->lock);
}

void cv_live_trace_span(cv_live_trace *t, const char *track, uint64_t frame, uint64_t step, double start_ms,
                        double end_ms) {
    add(t, track,
        (trace_event){
            .start_ms = start_ms, .end_ms = end_ms > start_ms ? end_ms : start_ms, .frame = frame, .step = step });
}

void cv_live_trace_instant(cv_live_trace *t, const char *track, uint64_t frame, uint64_t step, double at_ms) {
    add(t, track, (trace_event){ .start_ms = at_ms, .end_ms = at_ms, .frame = frame, .step = step, .instant = true });
}

static int by_start(const void *a, const void *b) {
    const trace_event *x = a, *y = b;
    return x->start_ms < y->start_ms ? -1 : x->start_ms > y->start_ms ? 1 : (int)x->track - (int)y->track;
}

/* The events (sorted, lock held) as JSON into f. Track names are the callers' literals. */
static void print_events(const cv_live_trace *t, FILE *f) {
    double origin = t->count ? t->events[0].start_ms : 0.0;
    fprintf(f, "{\"displayTimeUnit\": \"ms\", \"dropped\": %llu, \"traceEvents\": [\n",
            (unsigned long long)t->dropped);
    fprintf(f, "{\"ph\": \"M\", \"name\": \"process_name\", \"pid\": 1, \"args\": {\"name\": \"live\"}}");
    for (uint32_t i = 0; i < t->track_count; i++) {
        fprintf(f,
                ",\n{\"ph\": \"M\", \"name\": \"thread_name\", \"pid\": 1, \"tid\": %u, \"args\": {\"name\": "
                "\"%s\"}}",
                i + 1, t->tracks[i]);
        fprintf(f,
                ",\n{\"ph\": \"M\", \"name\": \"thread_sort_index\", \"pid\": 1, \"tid\": %u, "
                "\"args\": {\"sort_index\": %u}}",
                i + 1, i + 1);
    }
    for (size_t i = 0; i < t->count; i++) {
        const trace_event *e = &t->events[i];
        const char *name = t->tracks[e->track];
        double ts = (e->start_ms - origin) * 1e3;
        if (e->instant)
            fprintf(f,
                    ",\n{\"ph\": \"i\", \"s\": \"t\", \"cat\": \"%s\", \"name\": \"%s\", \"pid\": 1, \"tid\": %u, "
                    "\"ts\": %.3f",
                    name, name, e->track + 1, ts);
        else
            fprintf(f,
                    ",\n{\"ph\": \"X\", \"cat\": \"%s\", \"name\": \"%s\", \"pid\": 1, \"tid\": %u, \"ts\": %.3f, "
                    "\"dur\": %.3f",
                    name, name, e->track + 1, ts, (e->end_ms - e->start_ms) * 1e3);
        fprintf(f, ", \"args\": {\"frame\": %llu, \"step\": %llu}}", (unsigned long long)e->frame,
                (unsigned long long)e->step);
    }
    fprintf(f, "\n]}\n");
}

cv_result cv_live_trace_write(cv_live_trace *t, const char *path) {
    if (!t || !path)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "live trace: write: NULL %s", t ? "path" : "trace");
    FILE *f = fopen(path, "w");
    if (!f)
        return cv_error(CV_ERROR_IO, "live trace: %s: %s", path, strerror(errno));
    pthread_mutex_lock(&t->lock);
    qsort(t->events, t->count, sizeof(*t->events), by_start);
    print_events(t, f);
    pthread_mutex_unlock(&t->lock);
    bool ok = !ferror(f);
    int saved = errno;
    if (fclose(f) != 0 && ok) {
        ok = false;
        saved = errno;
    }
    return ok ? CV_OK : cv_error(CV_ERROR_IO, "live trace: %s: %s", path, strerror(saved));
}
