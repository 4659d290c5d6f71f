/* Per-frame reports from the renderer, for people who look at frames (stats
 * files, timeline traces, live dashboards). An observer set in
 * cv_render_settings.observer is called once per frame, on the thread that
 * called cv_renderer_render, as soon as the frame's pass and transfer timings
 * are known: which device traced which columns, how many rays, and every pass
 * instance and transfer of the frame's render graph with its measured time.
 *
 *     static void on_frame(const cv_render_frame_info *f, void *user) {
 *         for (uint32_t i = 0; i < f->timing_count; i++)
 *             printf("frame %u: %s on %s: %.2f ms\n", f->frame, f->timings[i].name,
 *                    f->device_labels[f->timings[i].device], f->timings[i].ms);
 *     }
 *
 *     cv_render_observer obs = { .frame = on_frame, .user = NULL };
 *     cv_render_settings s = { .width = 320, .height = 180, .frames = 4, .observer = &obs };
 *     cv_renderer_render(renderer, &s, &out, &stats, NULL, NULL);
 *
 * corvid/render_log.h has an observer that keeps every frame and writes them
 * as a JSON stats file and a Chrome/Perfetto trace.
 *
 * Cost: a frame's timings exist only once the frame has finished, so with an
 * observer a single-device render waits for each frame before it submits the
 * next (without one it keeps up to 16 frames in flight to hide a remote
 * device's latency). Multi-device renders wait for every frame anyway. The
 * info and everything it points to are valid only during the call. */
#ifndef CORVID_RENDER_OBSERVER_H
#define CORVID_RENDER_OBSERVER_H

#include "corvid/device.h"
#include "corvid/graph.h"
#include "corvid/partition.h"

/* Most timings one frame reports (pass instances plus transfers); a graph
 * with more steps reports the first ones and says how many were cut. */
#define CV_RENDER_FRAME_TIMINGS 64u

typedef struct cv_render_frame_info {
    uint32_t frame;   /* 0-based within this cv_renderer_render call */
    uint32_t frames;  /* frames of the call */
    uint32_t sample;  /* sample set drawn: settings.first_frame + frame */
    double submit_ms; /* host CLOCK_MONOTONIC, milliseconds, when the frame's work began to be submitted */
    double wall_ms;   /* host time from submit_ms until the frame finished and its timings were read */
    uint32_t device_count;
    const char *device_labels[CV_MAX_DEVICES]; /* cv_device_label of each device, index = timing.device */
    cv_column_range columns[CV_MAX_DEVICES];   /* each device's trace columns this frame */
    uint64_t rays[CV_MAX_DEVICES];             /* rays each device traced this frame */
    /* One per pass instance ("gbuffer", "trace", ...; device = where it ran;
     * ms = its GPU time, 0 where the device measured none) and per transfer
     * ("transfer '<resource>'"; device = its source; bytes moved; host ms), in
     * the order the graph ran them. */
    const cv_graph_timing *timings;
    uint32_t timing_count;
    uint32_t timings_cut; /* timings the frame had beyond CV_RENDER_FRAME_TIMINGS (normally 0) */
} cv_render_frame_info;

typedef struct cv_render_observer {
    void (*frame)(const cv_render_frame_info *info, void *user);
    void *user;
} cv_render_observer;

#endif
