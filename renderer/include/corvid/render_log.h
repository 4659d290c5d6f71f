/* A render's frames, kept for people who look at them afterwards: an
 * observer (corvid/render_observer.h) that records every frame's devices,
 * columns, rays, pass times and transfers, and writes them as
 *
 *   - a stats file (JSON): per frame its index, wall time and, per device,
 *     its columns, rays, pass times and transfers; then a summary (the
 *     render's cv_render_stats and per-pass totals);
 *   - a trace (Chrome trace event JSON, which ui.perfetto.dev and
 *     chrome://tracing open): one process per device (named by its label),
 *     a "passes" track with a complete event per pass instance per frame and
 *     a "transfers" track with its outgoing transfers, and a "host" process
 *     with one event per frame.
 *
 *     cv_render_log *log;
 *     cv_render_log_create(&log);
 *     cv_render_observer obs = cv_render_log_observer(log);
 *     cv_render_settings s = { .width = 320, .height = 180, .observer = &obs };
 *     cv_render_stats stats;
 *     if (cv_renderer_render(renderer, &s, &out, &stats, NULL, NULL) == CV_OK) {
 *         cv_render_log_write_stats(log, &stats, "frame.stats.json");
 *         cv_render_log_write_trace(log, "frame.trace.json");
 *     }
 *     cv_render_log_destroy(log);
 *
 * Time base of the trace: the host's CLOCK_MONOTONIC, ts and dur in
 * microseconds (whole nanoseconds) from the first frame's submission. A pass
 * whose device reports when it began on that clock (cv_graph_timing.host_ms:
 * Vulkan devices with calibrated timestamps, the mock) is placed there, with
 * its measured duration (args "clocked": true), so the trace shows real
 * overlap across devices and the idle gaps inside a device's frame. A pass
 * whose device cannot say (a remote node's devices, a Vulkan driver without
 * calibrated timestamps; "clocked": false) is laid end to end after the
 * previous pass of its device, starting no earlier than the frame's
 * submission. A transfer runs on the host, in step order, from when the graph
 * began it (its time includes the wait for its source's work); an unclocked
 * pass after it starts no earlier than its end.
 *
 * A log takes any number of renders (frames are appended). A recording
 * failure (no memory) is kept and returned by the writers. */
#ifndef CORVID_RENDER_LOG_H
#define CORVID_RENDER_LOG_H

#include "corvid/renderer.h"

typedef struct cv_render_log cv_render_log;

cv_result cv_render_log_create(cv_render_log **out);
void cv_render_log_destroy(cv_render_log *log); /* NULL is fine */

/* The observer that records into `log` (which must outlive the render). */
cv_render_observer cv_render_log_observer(cv_render_log *log);

/* Frames recorded so far. */
uint32_t cv_render_log_frame_count(const cv_render_log *log);

/* Writes the stats (with `stats`, the render's cv_render_stats, as the
 * summary) / the trace to `path`, replacing it. Errors (CV_ERROR_IO,
 * CV_ERROR_OUT_OF_MEMORY, or the recording failure) name the path. */
cv_result cv_render_log_write_stats(const cv_render_log *log, const cv_render_stats *stats, const char *path);
cv_result cv_render_log_write_trace(const cv_render_log *log, const char *path);

#endif
