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
 * The pass 'present' follows the composite: the radiance tone-mapped into a
 * ring of display images (passes/present.c).
 *
 * This file creates and destroys a renderer and runs its renders and steps;
 * the frame loop both share is frame_loop.h's, the shared frame state
 * frame.h's, the graph frame_graph.h's, readback readback.h's, devices joining
 * and leaving device_join.h's, the stats frame_stats.h's, which step goes on
 * from which step_history.h's. */
#include "corvid/renderer.h"

#include <stdlib.h>
#include <string.h>

#include "corvid/clock.h"

#include "camera.h"
#include "device_join.h"
#include "frame.h"
#include "frame_graph.h"
#include "frame_loop.h"
#include "readback.h"
#include "step_history.h"

_Static_assert(RENDER_DISPLAY_SLOTS == CV_RENDER_DISPLAY_SLOTS, "frame.h's display ring is renderer.h's");

struct cv_renderer {
    cv_render_frame frame;
    double upload_ms;
    bool rendering; /* inside cv_renderer_render (a progress callback may add devices, not passes) */
    bool has_frame; /* the textures hold a finished render's or step's frame (cv_renderer_read_output) */
    /* The progressive image of cv_renderer_step: its frame loop (kept from
     * step to step, made by the first), its settings (first_frame: its first
     * step's) and the frames in it; 0 = none (none yet, or a render or a
     * failed step since). */
    render_loop *steps;
    cv_render_settings history;
    uint32_t accumulated;
};

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
    free(r->steps);
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

/* Resolves and checks the settings (nothing changes on a refusal). */
static cv_result check_settings(const cv_render_frame *f, const cv_render_settings *in, cv_render_settings *out) {
    *out = cv_render_settings_resolve(in, f->scene);
    cv_result res = cv_render_settings_check(out);
    return res == CV_OK ? cv_render_camera_check(out, f->scene) : res;
}

cv_result cv_renderer_check_settings(const cv_renderer *r, const cv_render_settings *settings) {
    if (!r || !settings)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_renderer_check_settings: NULL argument");
    cv_render_settings resolved;
    return check_settings(&r->frame, settings, &resolved);
}

/* Readies the targets and the graph for checked settings `s` and bakes a
 * new graph's first frame (render_loop_prebake: *setup_ms). */
static cv_result apply_settings(cv_renderer *r, const cv_render_settings *s, double *setup_ms) {
    cv_render_frame *f = &r->frame;
    r->has_frame = false;
    render_sun_direction(s, f->data.sun_direction, f->sun_direction);
    f->settings = *s;
    cv_result res = render_frame_ensure_targets(f, s->width, s->height,
                                                s->reflections == 1 ? s->reflection_samples : 1);
    if (res == CV_OK)
        res = render_graph_build(f, render_band_capacity(f, s));
    if (res == CV_OK)
        res = render_loop_prebake(f, setup_ms);
    return res;
}

static cv_result render_frames(cv_renderer *r, render_loop *loop, void (*progress)(uint32_t, uint32_t, void *),
                               void *user) {
    cv_render_frame *f = &r->frame;
    uint32_t frames = f->settings.frames;
    cv_result res = CV_OK;
    for (uint32_t index = 0; index < frames && res == CV_OK; index++) {
        /* Only the last frame waits: the frames before stay in flight. */
        res = render_loop_frame(f, loop, index, index + 1 == frames);
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
    cv_render_settings s;
    cv_result res = check_settings(f, settings, &s);
    if (res != CV_OK)
        return res;
    r->accumulated = 0; /* the steps' image is gone with this render's frames */
    res = apply_settings(r, &s, &setup_ms);
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
    r->has_frame = res == CV_OK;
    if (res == CV_OK)
        res = render_read_output(f, f->settings.frames, out);
    if (res == CV_OK && stats)
        *stats = loop->stats;
    free(loop);
    return res;
}

cv_result cv_renderer_step(cv_renderer *r, const cv_render_settings *settings, cv_render_step *out) {
    if (!r || !settings || !out)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_renderer_step: NULL argument");
    if (r->rendering)
        return cv_error(CV_ERROR_BAD_STATE, "renderer: step: not during a render");
    cv_render_frame *f = &r->frame;
    double start = cv_now_ms(), setup_ms;
    cv_render_settings s;
    cv_result res = check_settings(f, settings, &s);
    if (res != CV_OK)
        return res;
    if (!r->steps && !(r->steps = calloc(1, sizeof(*r->steps))))
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "renderer: step");
    /* Step k of a history is frame k of a render of k + 1 frames from the history's first frame. */
    uint32_t index = r->accumulated && render_step_goes_on(&r->history, &s) ? r->accumulated : 0;
    if (index)
        s.first_frame = r->history.first_frame;
    s.frames = index + 1;
    r->accumulated = 0; /* until the frame is submitted: a failed step leaves no history */
    res = apply_settings(r, &s, &setup_ms);
    /* Several devices wait for the frame, as a render's last frame does; one pipelines. */
    if (res == CV_OK)
        res = render_loop_frame(f, r->steps, index, f->count > 1);
    if (res != CV_OK)
        return res;
    r->history = s;
    r->accumulated = index + 1;
    r->has_frame = true;
    *out = (cv_render_step){ .display = f->textures[TEX_DISPLAY + f->display_slot],
                             .radiance = f->textures[TEX_RADIANCE],
                             .width = f->width,
                             .height = f->height,
                             .accumulated = r->accumulated,
                             .ticket = r->steps->ticket,
                             .frame_ms = cv_now_ms() - start };
    return CV_OK;
}

cv_result cv_renderer_read_output(cv_renderer *r, cv_render_output *out) {
    if (!r || !out)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_renderer_read_output: NULL argument");
    if (r->rendering)
        return cv_error(CV_ERROR_BAD_STATE, "renderer: read output: not during a render");
    if (!r->has_frame)
        return cv_error(CV_ERROR_BAD_STATE, "renderer: read output: no frame rendered since the last change");
    return render_read_output(&r->frame, r->frame.settings.frames, out);
}
