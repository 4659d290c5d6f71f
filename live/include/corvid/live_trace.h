/* A trace of the live loop for people who look at it afterwards: spans and
 * instants on named tracks, written as Chrome trace event JSON (the "JSON
 * Object Format" ui.perfetto.dev and chrome://tracing open, as
 * corvid/render_log.h's trace).
 *
 * A cv_live given one (cv_live_desc.trace) records, per presented frame, on
 * its own track each:
 *
 *   render    the step that made the frame (cv_renderer_step on the render
 *             thread: host time to submit; args "step"); every step is
 *             recorded, a spoiled one too
 *   read      the device read of its display (args "frame", "step")
 *   encode    its encoding (after the read)
 *   link      the rest of the frame reader's call: for a proxy device the
 *             request and reply on the link (the node's read and encode are
 *             the spans above, laid from the call's start: the node's clock
 *             is not ours); about 0 for a local device
 *   send      the consumer's frame callback (corvid-view: the WebSocket send)
 *   spoiled   an instant per step rendered but never presented (args "step")
 *
 * A consumer may add its own tracks (bench_live: "decode", "display").
 * Times are cv_now_ms (CLOCK_MONOTONIC) host milliseconds; the file's ts and
 * dur are microseconds from the first event. At most CV_LIVE_TRACE_MAX_EVENTS
 * are kept (the rest are counted in the file's "dropped"). Thread-safe.
 *
 *     cv_live_trace *trace;
 *     cv_live_trace_create(&trace);
 *     cv_live_desc d = { ..., .trace = trace };
 *     cv_live_start(&d, &live);
 *     ...
 *     cv_live_trace_span(trace, "decode", frame_index, t0, cv_now_ms());
 *     ...
 *     cv_live_stop(live);
 *     if (cv_live_trace_write(trace, "live.trace.json") != CV_OK) fprintf(stderr, "%s\n", cv_last_error());
 *     cv_live_trace_destroy(trace);
 */
#ifndef CORVID_LIVE_TRACE_H
#define CORVID_LIVE_TRACE_H

#include <stdint.h>

#include "corvid/result.h"

#define CV_LIVE_TRACE_MAX_EVENTS (1u << 20)
/* Tracks (thread names in the file) at most; a span on a further one is dropped. */
#define CV_LIVE_TRACE_MAX_TRACKS 16u

typedef struct cv_live_trace cv_live_trace;

cv_result cv_live_trace_create(cv_live_trace **out);
void cv_live_trace_destroy(cv_live_trace *t); /* NULL is fine */

/* A span from start_ms to end_ms on `track` (a string that outlives the trace: a
 * literal), for frame `frame` (shown in its name and args) of step `step` (0: none). */
void cv_live_trace_span(cv_live_trace *t, const char *track, uint64_t frame, uint64_t step, double start_ms,
                        double end_ms);
/* An instant at at_ms on `track`. */
void cv_live_trace_instant(cv_live_trace *t, const char *track, uint64_t frame, uint64_t step, double at_ms);

/* Writes the events to `path`, replacing it; errors name the path. */
cv_result cv_live_trace_write(cv_live_trace *t, const char *path);

#endif
