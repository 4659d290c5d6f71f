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
 * Time base of the trace: the graph reports each pass instance's duration
 * measured on its device (GPU timestamps where the device has them), not when
 * it started. Each frame starts at the host's clock when it was submitted;
 * on every device its passes are laid end to end in the order the graph ran
 * them. A transfer runs on the host, in step order: its time (the host's)
 * runs from when the graph reached it, including the wait for its source's
 * work, so it starts where the previous transfer of the frame ended (or at
 * the frame's start), and passes after it start no earlier than its end. So
 * the trace shows the order, length and overlap across devices of the work,
 * but not the idle gaps inside a device's frame. ts and dur are microseconds
 * (whole nanoseconds) from the first frame's submission.
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
