/* A run of frames on the renderer's frame state (frame_loop.h): the render's
 * and the steps' one frame loop. */
#include "frame_loop.h"

#include <string.h>

#include "corvid/clock.h"

#include "device_join.h"
#include "frame_graph.h"
#include "frame_observer.h"

/* The bake makes the transfer rings of the pairs it copies between (graph.h,
 * cv_graph_stats.rings), and making one costs time in proportion to its
 * memory (host-import pins and imports it: ~85 ms a ring on the H200). */
cv_result render_loop_prebake(cv_render_frame *f, double *ms) {
    double start = cv_now_ms();
    *ms = 0.0;
    if (f->count < 2 || f->graph_prebaked)
        return CV_OK;
    f->info.frame = 0;
    f->info.first = true;
    f->info.last = f->settings.frames == 1;
    cv_graph_bake_desc bake = render_graph_bake_desc(f, NULL);
    cv_result res = render_graph_enable_passes(f);
    if (res == CV_OK)
        res = cv_graph_bake(f->graph, &bake);
    f->graph_prebaked = res == CV_OK;
    *ms = cv_now_ms() - start;
    return res;
}

/* After a submit that left the frame in flight: bounds the frames in flight
 * on the primary, and with several devices keeps the frame for a later
 * collect. */
static cv_result keep_in_flight(cv_render_frame *f, render_loop *loop, uint32_t index, const cv_partition *part) {
    if (f->count > 1) {
        loop->pending.uncollected[index % CV_GRAPH_FRAMES_KEPT] = cv_graph_frame_id(f->graph);
        loop->pending.parts[index % CV_GRAPH_FRAMES_KEPT] = *part;
    }
    uint64_t oldest = loop->in_flight[(loop->submitted + 1) % RENDER_IN_FLIGHT_FRAMES];
    if (loop->submitted + 1 >= RENDER_IN_FLIGHT_FRAMES && oldest)
        return cv_device_wait(f->devices[0], oldest, UINT64_MAX);
    return CV_OK;
}

/* Submits frame `index` (render_loop_frame), or fails with the devices as
 * they were. Frames are pipelined on any number of devices: up to
 * RENDER_IN_FLIGHT_FRAMES submitted ahead, so a remote device's latency hides
 * behind the work of the frames before, and transfers between local devices
 * are queued on the GPUs (graph.h). With several devices the "last frame"
 * whose trace times the balancer splits from is the one
 * CV_GRAPH_FRAMES_KEPT - 1 back (render_stats_collect: lagged feedback; that
 * frame has usually finished, so collecting it rarely waits), which bounds
 * the frames in flight to CV_GRAPH_FRAMES_KEPT. The last frame collects every
 * frame still pending. */
static cv_result run_frame(cv_render_frame *f, render_loop *loop, uint32_t index, bool wait) {
    const cv_render_settings *s = &f->settings;
    bool last = index + 1 == s->frames;
    f->info.frame = index;
    f->info.first = index == 0;
    f->info.last = last;
    f->display_slot = (uint32_t)(f->presented % RENDER_DISPLAY_SLOTS);
    f->camera = cv_render_camera(s, f->scene, s->first_frame + index);
    f->previous_camera = cv_render_camera(s, f->scene, s->first_frame + index - (s->first_frame + index > 0));
    cv_result res = render_graph_enable_passes(f);
    /* The graph's balancer splits the columns from the last frame's trace times. */
    if (res == CV_OK)
        res = render_stats_collect(f, &loop->pending, &loop->stats, index, last);
    cv_graph_bake_desc bake = render_graph_bake_desc(f, NULL);
    if (res == CV_OK)
        res = cv_graph_bake(f->graph, &bake);
    cv_partition part;
    if (res == CV_OK)
        res = cv_graph_get_partition(f->graph, &part);
    /* An observer wants every frame's timings: the frame ends here (no pipelining). */
    bool wait_now = wait || (s->observer && s->observer->frame);
    uint32_t n = 0;
    double submitted = cv_now_ms();
    uint64_t tickets[CV_MAX_DEVICES];
    if (res == CV_OK)
        res = cv_graph_submit(f->graph, tickets);
    if (res == CV_OK) {
        loop->ticket = tickets[0];
        loop->in_flight[loop->submitted % RENDER_IN_FLIGHT_FRAMES] = tickets[0];
        /* Collecting the frame just submitted is cv_graph_execute. */
        res = wait_now
                  ? cv_graph_collect(f->graph, cv_graph_frame_id(f->graph), loop->pending.timings, RENDER_TIMINGS, &n)
                  : keep_in_flight(f, loop, index, &part);
        loop->submitted++;
    }
    if (res != CV_OK)
        return res;
    f->presented += last;
    double frame_wall = cv_now_ms() - submitted;
    if (wait_now) {
        render_stats_add_timings(f, &loop->stats, loop->pending.timings, n, &part, frame_wall);
        render_observe_frame(&(render_frame_report){ f->devices, f->count, &part, s, index, f->height, submitted,
                                                     frame_wall, loop->pending.timings, n, RENDER_TIMINGS });
    }
    render_stats_count_rays(f, &loop->stats, &part, index);
    return CV_OK;
}

/* After a failed frame: drops the secondaries that are gone and builds the
 * graph for the survivors. True when the frame should run again. */
static bool survive_lost_devices(cv_render_frame *f, render_loop *loop, cv_result *res) {
    uint32_t dropped = render_devices_drop_lost(f);
    if (!dropped)
        return false;
    loop->stats.devices_lost += dropped;
    loop->stats.device_count = f->count;
    memset(loop->stats.devices, 0, sizeof(loop->stats.devices));
    memset(loop->pending.uncollected, 0, sizeof(loop->pending.uncollected)); /* the old graph's frames are gone */
    *res = render_graph_build(f, render_band_capacity(f, &f->settings));
    return *res == CV_OK;
}

cv_result render_loop_frame(cv_render_frame *f, render_loop *loop, uint32_t index, bool wait) {
    cv_result res;
    do {
        if (f->graph_generation != loop->generation) { /* a device added (from a progress callback) or lost */
            loop->generation = f->graph_generation;
            memset(loop->pending.uncollected, 0, sizeof(loop->pending.uncollected)); /* went with the old graph */
            loop->stats.device_count = f->count;
        }
        res = run_frame(f, loop, index, wait);
    } while (res != CV_OK && survive_lost_devices(f, loop, &res)); /* this frame again, on the survivors */
    return res;
}
