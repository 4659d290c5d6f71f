/* The live's render thread: the newest settings, one cv_renderer_step after
 * another, each finished step published for the encoder (live_internal.h says
 * how far ahead of the encoder's read it may run). */
#include <string.h>

#include "corvid/clock.h"
#include "corvid/log.h"
#include "live_internal.h"
#include "live_passes.h"

/* How often a step is measured for stats.passes: a measured frame is not
 * pipelined (the renderer waits for its timings, corvid/render_observer.h),
 * which over a link of 20 ms round trip would cap the frame rate near 50. */
#define LIVE_PASSES_PERIOD_MS 250.0

/* The render thread's own: the settings it renders (with the caller's
 * observer) and those of its last good step (a refused update goes back to
 * them). */
typedef struct live_render {
    cv_render_settings settings, good;
    uint64_t seq, good_seq;
    double input_ms, good_input_ms;
    bool unproven;          /* settings not yet rendered by a step */
    uint32_t width, height; /* of the last good step; 0: none yet */
    double measured_ms;     /* when a step was last measured; 0: never */
} live_render;

/* The renderer's report of a frame: its passes into the stats, then the
 * user's observer. */
static void observe(const cv_render_frame_info *info, void *user) {
    cv_live *l = user;
    char passes[sizeof(l->passes)];
    live_passes_format(info, passes, sizeof(passes));
    pthread_mutex_lock(&l->lock);
    memcpy(l->passes, passes, sizeof(passes));
    pthread_mutex_unlock(&l->lock);
    if (l->user_observer && l->user_observer->frame)
        l->user_observer->frame(info, l->user_observer->user);
}

/* The settings of the next step: the live's observer in them when the
 * caller gave one (it sees every frame) or a measurement is due. */
static cv_render_settings measured(cv_live *l, live_render *rs) {
    cv_render_settings s = rs->settings;
    double now = cv_now_ms();
    l->user_observer = rs->settings.observer;
    s.observer = NULL;
    if (l->user_observer || !rs->measured_ms || now - rs->measured_ms >= LIVE_PASSES_PERIOD_MS) {
        s.observer = &l->observer;
        rs->measured_ms = now;
    }
    return s;
}

/* Takes the newest update (lock held): input never waits behind frames. */
static void take_input(cv_live *l, live_render *rs) {
    if (!l->has_pending)
        return;
    rs->settings = l->pending;
    rs->seq = l->pending_seq;
    rs->input_ms = l->pending_ms;
    rs->unproven = true;
    l->has_pending = false;
    l->still = false;
}

static bool resizes(const live_render *rs) {
    return rs->width && (rs->settings.width != rs->width || rs->settings.height != rs->height);
}

/* Whether the next step may start now (lock held). */
static bool may_step(const cv_live *l, const live_render *rs) {
    if (l->hold || l->still)
        return false;
    if (l->reading && resizes(rs))
        return false;
    return !l->reading || l->steps + 1 <= l->reading + CV_RENDER_DISPLAY_SLOTS - 1;
}

/* A finished step becomes the newest frame (lock held); the one it replaces
 * is spoiled if the encoder never took it. */
static void publish(cv_live *l, live_render *rs, const cv_render_step *step) {
    if (l->published.step && !l->published.taken) {
        l->spoiled++;
        cv_live_trace_instant(l->desc.trace, "spoiled", 0, l->published.step, cv_now_ms());
    }
    l->steps++;
    l->rendered++;
    l->last_ticket = step->ticket;
    l->published = (live_published){
        .step = l->steps, .info = *step, .input_seq = rs->seq, .input_ms = rs->input_ms, .taken = false
    };
    live_window_add(&l->rendered_window, cv_now_ms(), NULL);
    rs->good = rs->settings;
    rs->good_seq = rs->seq;
    rs->good_input_ms = rs->input_ms;
    rs->unproven = false;
    rs->width = step->width;
    rs->height = step->height;
    if (step->accumulated >= l->max_accumulate && !l->has_pending)
        l->still = true;
    pthread_cond_broadcast(&l->encode_cond);
    pthread_cond_broadcast(&l->snapshot_cond);
}

/* A step that failed (lock held): settings the renderer refused (cv_live_update
 * checked them as cv_renderer_check_settings does, so only what a step alone
 * finds) go back to the last good ones and rendering goes on; anything else
 * ends the live. */
static bool recover(cv_live *l, live_render *rs, cv_result res, const char *why) {
    bool refused = res == CV_ERROR_INVALID_ARGUMENT || res == CV_ERROR_OUT_OF_RANGE;
    if (refused && rs->unproven && rs->width) {
        cv_log(CV_LOG_WARNING, "live", "update %llu refused by the renderer: %s", (unsigned long long)rs->seq, why);
        rs->settings = rs->good;
        rs->seq = rs->good_seq;
        rs->input_ms = rs->good_input_ms;
        rs->unproven = false;
        return true;
    }
    live_fail_locked(l, "live: step %llu: %s", (unsigned long long)(l->steps + 1), why);
    return false;
}

void *live_render_main(void *arg) {
    cv_live *l = arg;
    live_render rs = { .settings = l->desc.settings, .input_ms = cv_now_ms(), .unproven = true };
    l->observer = (cv_render_observer){ .frame = observe, .user = l };
    pthread_mutex_lock(&l->lock);
    while (!l->stopping && !l->failed) {
        take_input(l, &rs);
        if (!may_step(l, &rs)) {
            pthread_cond_wait(&l->render_cond, &l->lock);
            continue;
        }
        l->stepping = true;
        l->resizing = resizes(&rs);
        pthread_mutex_unlock(&l->lock);
        cv_render_step step;
        cv_render_settings settings = measured(l, &rs);
        double start_ms = cv_now_ms();
        cv_result res = cv_renderer_step(l->desc.renderer, &settings, &step);
        double end_ms = cv_now_ms();
        char why[sizeof(l->error)] = "";
        if (res != CV_OK)
            snprintf(why, sizeof(why), "%s", cv_last_error());
        pthread_mutex_lock(&l->lock);
        l->stepping = l->resizing = false;
        pthread_cond_broadcast(&l->encode_cond);
        pthread_cond_broadcast(&l->snapshot_cond);
        if (res == CV_OK) {
            publish(l, &rs, &step);
            cv_live_trace_span(l->desc.trace, "render", 0, l->steps, start_ms, end_ms);
        } else if (!recover(l, &rs, res, why))
            break;
    }
    pthread_mutex_unlock(&l->lock);
    return NULL;
}
