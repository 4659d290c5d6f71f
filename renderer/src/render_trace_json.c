/* cv_render_log_write_trace: the frames as Chrome trace event JSON (the
 * "JSON Object Format" ui.perfetto.dev and chrome://tracing read):
 *
 *   { "displayTimeUnit": "ms", "traceEvents": [
 *       { "ph": "M", "name": "process_name", "pid": 1, "args": { "name": "gpu0" } },
 *       { "ph": "M", "name": "thread_name", "pid": 1, "tid": 1, "args": { "name": "passes" } },
 *       { "ph": "X", "cat": "pass", "name": "trace", "pid": 1, "tid": 1, "ts": 1520.25, "dur": 3100.5,
 *         "args": { "frame": 0, "device": 0, "measured": true, "columns": "0..48" } }, ... ] }
 *
 * pid 1.. = the devices, by label in order of first appearance (a label keeps
 * its process when devices are lost and the rest renumbered); tid 1 = its
 * passes, tid 2 = transfers it sends; the last pid is the host, with one
 * event per frame (submit to timings read). Placement: corvid/render_log.h. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "render_log_internal.h"

enum { TID_PASSES = 1, TID_TRANSFERS = 2 };

static cJSON *metadata(const char *what, int pid, int tid, const char *key, const char *name, double number) {
    cJSON *e = cJSON_CreateObject();
    cJSON_AddStringToObject(e, "ph", "M");
    cJSON_AddStringToObject(e, "name", what);
    cJSON_AddNumberToObject(e, "pid", pid);
    if (tid)
        cJSON_AddNumberToObject(e, "tid", tid);
    cJSON *args = cJSON_AddObjectToObject(e, "args");
    if (name)
        cJSON_AddStringToObject(args, key, name);
    else
        cJSON_AddNumberToObject(args, key, number);
    return e;
}

/* Host milliseconds as whole nanoseconds from the trace's origin, so that an
 * event ending where the next begins gives exactly equal microseconds. */
static long long ns_from(double ms, double origin_ms) { return llround((ms - origin_ms) * 1e6); }

static cJSON *complete(const char *cat, const char *name, int pid, int tid, long long start_ns, long long end_ns) {
    cJSON *e = cJSON_CreateObject();
    cJSON_AddStringToObject(e, "ph", "X");
    cJSON_AddStringToObject(e, "cat", cat);
    cJSON_AddStringToObject(e, "name", name);
    cJSON_AddNumberToObject(e, "pid", pid);
    cJSON_AddNumberToObject(e, "tid", tid);
    cJSON_AddNumberToObject(e, "ts", (double)start_ns / 1e3);
    cJSON_AddNumberToObject(e, "dur", (double)(end_ns - start_ns) / 1e3);
    return e;
}

/* One frame's events. pass_end / transfer_end (per label, host ms) carry
 * each track's end over from frame to frame so tracks never overlap. */
static void frame_events(const cv_render_log *log, const render_log_frame *fr, double origin, double *pass_end,
                         double *transfer_end, cJSON *events) {
    double cursor[CV_MAX_DEVICES], host = fr->submit_ms; /* host: where the graph's submission has got to */
    for (uint32_t d = 0; d < fr->device_count && d < CV_MAX_DEVICES; d++) {
        double prev = pass_end[fr->devices[d].label];
        cursor[d] = fr->submit_ms > prev ? fr->submit_ms : prev;
    }
    char frame_name[32];
    snprintf(frame_name, sizeof frame_name, "frame %u", fr->frame);
    cJSON *frame_event = complete("frame", frame_name, (int)log->label_count + 1, 1, ns_from(fr->submit_ms, origin),
                                  ns_from(fr->submit_ms + fr->wall_ms, origin));
    cJSON *frame_args = cJSON_AddObjectToObject(frame_event, "args");
    cJSON_AddNumberToObject(frame_args, "sample", fr->sample);
    cJSON_AddNumberToObject(frame_args, "devices", fr->device_count);
    cJSON_AddItemToArray(events, frame_event);
    for (uint32_t i = 0; i < fr->timing_count; i++) {
        const cv_graph_timing *t = &fr->timings[i];
        if (t->device >= fr->device_count)
            continue;
        uint32_t label = fr->devices[t->device].label;
        double ms = t->ms > 0.0 && isfinite(t->ms) ? t->ms : 0.0;
        bool transfer = render_log_is_transfer(t);
        double start = transfer ? host : cursor[t->device];
        if (transfer && transfer_end[label] > start)
            start = transfer_end[label];
        if (!transfer && host > start)
            start = host;
        bool clocked = t->host_ms > 0.0 && isfinite(t->host_ms); /* where it really began */
        if (clocked)
            start = t->host_ms;
        double end = start + ms;
        cJSON *e = complete(transfer ? "transfer" : "pass", t->name, (int)label + 1,
                            transfer ? TID_TRANSFERS : TID_PASSES, ns_from(start, origin), ns_from(end, origin));
        cJSON *args = cJSON_AddObjectToObject(e, "args");
        cJSON_AddNumberToObject(args, "frame", fr->frame);
        cJSON_AddNumberToObject(args, "device", t->device);
        if (transfer) {
            cJSON_AddNumberToObject(args, "bytes", (double)t->bytes);
            transfer_end[label] = end;
            host = end; /* synchronous on the host: what the graph submits next comes after it */
        } else {
            cJSON_AddBoolToObject(args, "measured", t->ms > 0.0);
            cJSON_AddBoolToObject(args, "clocked", clocked);
            if (fr->devices[t->device].columns.width && !strcmp(t->name, "trace")) {
                char cols[32];
                cv_column_range c = fr->devices[t->device].columns;
                snprintf(cols, sizeof cols, "%u..%u", c.x, c.x + c.width);
                cJSON_AddStringToObject(args, "columns", cols);
            }
            cursor[t->device] = end;
            pass_end[label] = end;
        }
        cJSON_AddItemToArray(events, e);
    }
}

cv_result cv_render_log_write_trace(const cv_render_log *log, const char *path) {
    if (!log || !path)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_render_log_write_trace: NULL argument");
    double *ends = calloc(2 * (size_t)log->label_count + 1, sizeof(double));
    cJSON *root = ends ? cJSON_CreateObject() : NULL;
    cJSON *events = root ? cJSON_AddArrayToObject(root, "traceEvents") : NULL;
    if (root)
        cJSON_AddStringToObject(root, "displayTimeUnit", "ms");
    int host = (int)log->label_count + 1;
    for (uint32_t l = 0; events && l < log->label_count; l++) {
        cJSON_AddItemToArray(events, metadata("process_name", (int)l + 1, 0, "name", log->labels[l], 0));
        cJSON_AddItemToArray(events, metadata("process_sort_index", (int)l + 1, 0, "sort_index", NULL, l + 1));
        cJSON_AddItemToArray(events, metadata("thread_name", (int)l + 1, TID_PASSES, "name", "passes", 0));
        cJSON_AddItemToArray(events, metadata("thread_name", (int)l + 1, TID_TRANSFERS, "name", "transfers out", 0));
    }
    if (events) {
        cJSON_AddItemToArray(events, metadata("process_name", host, 0, "name", "host", 0));
        cJSON_AddItemToArray(events, metadata("process_sort_index", host, 0, "sort_index", NULL, 0));
        cJSON_AddItemToArray(events, metadata("thread_name", host, 1, "name", "frames", 0));
    }
    /* The earliest submission is time 0 (frames are in order, but a log may hold several renders). */
    double origin = log->frame_count ? log->frames[0].submit_ms : 0.0;
    for (uint32_t f = 0; f < log->frame_count; f++)
        origin = log->frames[f].submit_ms < origin ? log->frames[f].submit_ms : origin;
    for (uint32_t l = 0; ends && l < 2 * log->label_count; l++)
        ends[l] = origin;
    for (uint32_t f = 0; events && f < log->frame_count; f++)
        frame_events(log, &log->frames[f], origin, ends, ends + log->label_count, events);
    free(ends);
    return render_log_write_json(log, root, path, "trace", false);
}
