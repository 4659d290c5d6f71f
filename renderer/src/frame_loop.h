/* Frames of the renderer's frame state run one after another: each frame's
 * passes enabled, the columns split, the graph baked and submitted, the
 * frames in flight bounded, the timings collected for the balancer and the
 * stats. One loop serves a render (cv_renderer_render: frames 0 .. N - 1 in
 * one call) and the steps of a progressive image (cv_renderer_step: one frame
 * a call, the loop kept between calls). */
#ifndef CORVID_RENDER_FRAME_LOOP_H
#define CORVID_RENDER_FRAME_LOOP_H

#include "frame.h"
#include "frame_stats.h"

/* Frames a single-device loop keeps submitted ahead of the one it waits for:
 * enough to cover a round trip of tens of milliseconds to a remote device at
 * GPU frame times of a few milliseconds (an H200 renders 1280x720 in 2.9 ms;
 * 20 ms of latency needs 7 frames in flight). */
#define RENDER_IN_FLIGHT_FRAMES 16u

/* Frames in flight: the primary's last ticket of recent submissions, the
 * frames whose timings are still to collect, and the stats. Zeroed = none. */
typedef struct render_loop {
    cv_render_stats stats;
    render_pending pending;
    uint64_t in_flight[RENDER_IN_FLIGHT_FRAMES]; /* by submission % RENDER_IN_FLIGHT_FRAMES */
    uint64_t submitted;                          /* frames this loop submitted */
    uint64_t ticket;                             /* the primary's last ticket of the last frame run */
    uint32_t generation;                         /* of the graph the pending frames ran on */
} render_loop;

/* Several devices, a new graph: its first frame baked once before the frames
 * (the transfer rings it makes cost time, so the first frames do not pay for
 * them). *ms: the time it took (0: no bake). */
cv_result render_loop_prebake(cv_render_frame *f, double *ms);

/* Runs frame `index` of f->settings (sample set first_frame + index; frame 0
 * starts the accumulation; the last, index + 1 == frames, composites and
 * presents) and submits it. It waits for the frame (and collects its
 * timings, calls the observer) when `wait` is set or an observer wants every
 * frame, else returns with it in flight (at most RENDER_IN_FLIGHT_FRAMES on the
 * primary). A secondary lost on the way is dropped and the frame runs again
 * on the survivors. */
cv_result render_loop_frame(cv_render_frame *f, render_loop *loop, uint32_t index, bool wait);

#endif
