/* One hybrid frame across N devices (see renderer.h), declared as a render
 * graph (corvid/graph.h) from the table of pass modules (passes/pass_table.h,
 * one file each in passes/): 'gbuffer' (primary, first frame; every frame for
 * a moving camera), 'trace' (every device, over its column window; in a scene
 * with alpha-masked materials the alpha-mask rule's re-traces run inside it
 * and inside 'reflect', renderer.h), with reflections 'reflect' (every device,
 * its window), 'reflect_reproject' (primary, moving camera only) and
 * 'reflect_filter' (primary), 'reproject' (primary, moving camera only),
 * 'accumulate' (primary), 'reflect_denoise', 'filter' and 'composite'
 * (primary, last frame), then a program's own passes (cv_renderer_add_pass).
 * The graph multicasts the G-buffer (a moving camera's: each device's window
 * of it), copies the secondaries' visibility and reflection windows back,
 * places barriers and balances the columns from the trace times; no pass sees
 * the device count.
 *
 * This file creates and destroys a renderer and runs a render's frame loop;
 * the shared frame state is frame.h's, the graph frame_graph.h's, readback
 * readback.h's, devices joining and leaving device_join.h's, the stats
 * frame_stats.h's. */
#include "corvid/renderer.h"

#include <stdlib.h>
#include <string.h>

#include "corvid/clock.h"

#include "camera.h"
#include "device_join.h"
#include "frame.h"
#include "frame_graph.h"
#include "frame_observer.h"
#include "frame_stats.h"
#include "readback.h"

struct cv_renderer {
    cv_render_frame frame;
    double upload_ms;
    bool rendering; /* inside cv_renderer_render (a progress callback may add devices, not passes) */
};

/* Frames a single-device render keeps submitted ahead of the one it waits for:
 * enough to cover a round trip of tens of milliseconds to a remote device at
 * GPU frame times of a few milliseconds (an H200 renders 1280x720 in 2.9 ms;
 * 20 ms of latency needs 7 frames in flight). */
#define IN_FLIGHT_FRAMES 16u

cv_result cv_renderer_create(cv_device *const *devices, uint32_t device_count, const cv_scene *scene,
                             const cv_bvh *bvh, cv_renderer **out) {
    if (!devices || !scene || !bvh || !out || device_count == 0 || device_count > CV_MAX_DEVICES)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "renderer: need 1..%u devices, a scene and its BVH",
                        CV_MAX_DEVICES);
    for (uint32_t d = 1; d < device_count; d++)
        if (cv_device_context(devices[d]) != cv_device_context(devices[0]))
            return cv_error(CV_ERROR_INVALID_ARGUMENT, "renderer: device %u belongs to another context", d);
    cv_renderer *r = calloc(1, sizeof(*r));
    if (!r)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "renderer");
    cv_render_frame *f = &r->frame;
    f->ctx = cv_device_context(devices[0]);
    f->count = device_count;
    f->scene = scene;
    f->bvh = bvh;
    memcpy(f->devices, devices, device_count * sizeof(*devices));
    double t0 = cv_now_ms();
    cv_result res = render_frame_upload_scene(f);
    r->upload_ms = cv_now_ms() - t0;
    if (res != CV_OK) {
        cv_renderer_destroy(r);
        return res;
    }
    *out = r;
    return CV_OK;
}

void cv_renderer_destroy(cv_renderer *r) {
    if (!r)
        return;
    for (uint32_t d = 0; d < r->frame.count; d++)
        cv_device_wait_idle(r->frame.devices[d]);
    render_frame_release(&r->frame);
    free(r);
}

cv_result cv_renderer_add_device(cv_renderer *r, cv_device *dev) {
    if (!r || !dev)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_renderer_add_device: NULL argument");
    return render_devices_add(&r->frame, dev);
}

cv_result cv_renderer_add_pass(cv_renderer *r, const cv_render_pass_module *module, void *user) {
    if (!r)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_renderer_add_pass: NULL renderer");
    if (r->rendering)
        return cv_error(CV_ERROR_BAD_STATE, "renderer: add pass: not during a render");
    return render_graph_add_pass(&r->frame, module, user);
}

cv_result cv_renderer_dump_graph(cv_renderer *r, FILE *text, FILE *dot) {
    if (!r || (!text && !dot))
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_renderer_dump_graph: NULL argument");
    if (!r->frame.graph)
        return cv_error(CV_ERROR_BAD_STATE, "cv_renderer_dump_graph: nothing rendered yet");
    return render_graph_dump(&r->frame, text, dot);
}

/* Checks and resolves the settings, then readies the targets and the graph
 * for them. */
static cv_result prepare(cv_renderer *r, const cv_render_settings *settings) {
    cv_render_frame *f = &r->frame;
    cv_render_settings s = cv_render_settings_resolve(settings, f->scene);
    cv_result res = cv_render_settings_check(&s);
    if (res == CV_OK)
        res = cv_render_camera_check(&s, f->scene);
    if (res != CV_OK)
        return res;
    render_sun_direction(&s, f->data.sun_direction, f->sun_direction);
    f->settings = s;
    res = render_frame_ensure_targets(f, s.width, s.height, s.reflections == 1 ? s.reflection_samples : 1);
    if (res == CV_OK)
        res = render_graph_build(f, render_band_capacity(f, &s));
    return res;
}

/* Several devices, a new graph: its first frame baked once before the clock
 * starts. The bake makes the transfer rings of the pairs it copies between
 * (graph.h, cv_graph_stats.rings), and making one costs time in proportion
 * to its memory (host-import pins and imports it: ~85 ms a ring on the H200),
 * so the first frames do not pay for them. Returns the time it took (0: no
 * bake). */
static cv_result prebake(cv_render_frame *f, double *ms) {
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

/* A render's frames in flight: the primary's last ticket of recent frames,
 * the frames whose timings are still to collect, and the stats. */
typedef struct render_loop {
    cv_render_stats stats;
    render_pending pending;
    uint64_t accumulated[IN_FLIGHT_FRAMES];
    uint32_t generation; /* of the graph the pending frames ran on */
} render_loop;

/* Submits frame `index` (executes it when it is the last or an observer
 * wants it), or fails with the devices as they were. Frames are pipelined
 * on any number of devices: up to IN_FLIGHT_FRAMES submitted ahead, so a
 * remote device's latency hides behind the work of the frames before, and
 * transfers between local devices are queued on the GPUs (graph.h). With
 * several devices the "last frame" whose trace times the balancer splits
 * from is the one CV_GRAPH_FRAMES_KEPT - 1 back (render_stats_collect:
 * lagged feedback; that frame has usually finished, so collecting it rarely
 * waits), which bounds the frames in flight to CV_GRAPH_FRAMES_KEPT. The last
 * frame collects every frame still pending, then executes. */
static cv_result run_frame(cv_render_frame *f, render_loop *loop, uint32_t index) {
    const cv_render_settings *s = &f->settings;
    bool last = index + 1 == s->frames;
    f->info.frame = index;
    f->info.first = index == 0;
    f->info.last = last;
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
    /* An observer wants every frame's timings: the frame ends here (no
     * pipelining); otherwise only the last frame waits. */
    bool wait_now = last || (s->observer && s->observer->frame);
    uint32_t n = 0;
    double submitted = cv_now_ms();
    if (res == CV_OK && wait_now) {
        res = cv_graph_execute(f->graph, loop->pending.timings, RENDER_TIMINGS, &n);
    } else if (res == CV_OK) {
        uint64_t tickets[CV_MAX_DEVICES], *accumulated = loop->accumulated;
        res = cv_graph_submit(f->graph, tickets);
        accumulated[index % IN_FLIGHT_FRAMES] = tickets[0];
        if (res == CV_OK && f->count > 1) {
            loop->pending.uncollected[index % CV_GRAPH_FRAMES_KEPT] = cv_graph_frame_id(f->graph);
            loop->pending.parts[index % CV_GRAPH_FRAMES_KEPT] = part;
        }
        if (res == CV_OK && index + 1 >= IN_FLIGHT_FRAMES && accumulated[(index + 1) % IN_FLIGHT_FRAMES])
            res = cv_device_wait(f->devices[0], accumulated[(index + 1) % IN_FLIGHT_FRAMES], UINT64_MAX);
    }
    if (res != CV_OK)
        return res;
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

static cv_result render_frames(cv_renderer *r, render_loop *loop, void (*progress)(uint32_t, uint32_t, void *),
                               void *user) {
    cv_render_frame *f = &r->frame;
    uint32_t frames = f->settings.frames;
    cv_result res = CV_OK;
    loop->generation = f->graph_generation;
    for (uint32_t index = 0; index < frames && res == CV_OK; index++) {
        if (f->graph_generation != loop->generation) { /* a device added from the progress callback, or lost */
            loop->generation = f->graph_generation;
            memset(loop->pending.uncollected, 0, sizeof(loop->pending.uncollected)); /* went with the old graph */
            loop->stats.device_count = f->count;
        }
        res = run_frame(f, loop, index);
        if (res != CV_OK && survive_lost_devices(f, loop, &res)) {
            index--; /* this frame again, on the survivors (index wraps to the loop's ++ at 0) */
            continue;
        }
        if (res == CV_OK && progress)
            progress(index + 1, frames, user);
    }
    return res;
}

cv_result cv_renderer_render(cv_renderer *r, const cv_render_settings *settings, cv_render_output *out,
                             cv_render_stats *stats, void (*progress)(uint32_t, uint32_t, void *), void *user) {
    if (!r || !out)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_renderer_render: NULL argument");
    if (r->rendering)
        return cv_error(CV_ERROR_BAD_STATE, "renderer: render: already rendering");
    cv_render_frame *f = &r->frame;
    double setup_ms = 0.0;
    cv_result res = prepare(r, settings);
    if (res == CV_OK)
        res = prebake(f, &setup_ms);
    if (res != CV_OK)
        return res;
    render_loop *loop = calloc(1, sizeof(*loop));
    if (!loop)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "renderer: render");
    loop->stats = (cv_render_stats){
        .device_count = f->count, .frames = f->settings.frames, .upload_ms = r->upload_ms, .setup_ms = setup_ms
    };
    double frames_start = cv_now_ms();
    r->rendering = true;
    res = render_frames(r, loop, progress, user);
    r->rendering = false;
    loop->stats.frame_ms = (cv_now_ms() - frames_start) / f->settings.frames;
    if (res == CV_OK)
        res = render_read_output(f, f->settings.frames, out);
    if (res == CV_OK && stats)
        *stats = loop->stats;
    free(loop);
    return res;
}
