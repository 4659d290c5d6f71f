/* The live loop's calls (corvid/live.h): start and stop of its two threads,
 * and what the consumer hands in (input, credit, codec, link and display
 * reports) or asks for (stats). live_render.c and live_encode.c hold the
 * threads, live_snapshot.c the snapshot. */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "corvid/clock.h"
#include "live_internal.h"

/* How long cv_live_stop waits for the last step's work on the primary. */
#define LIVE_STOP_WAIT_NS 10000000000ull

void live_fail_locked(cv_live *l, const char *fmt, ...) {
    if (!l->failed) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(l->error, sizeof(l->error), fmt, ap);
        va_end(ap);
        l->failed = true;
    }
    pthread_cond_broadcast(&l->render_cond);
    pthread_cond_broadcast(&l->encode_cond);
    pthread_cond_broadcast(&l->snapshot_cond);
}

/* The checks a codec and size pass before anything changes. */
static cv_result check_codec(cv_codec codec, uint32_t width, uint32_t height) {
    if (codec != CV_CODEC_JPEG && codec != CV_CODEC_H264)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "live: codec %s is not a live codec (jpeg or h264)",
                        cv_codec_name(codec));
    if (codec == CV_CODEC_H264 && (width % 2 || height % 2))
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "live: h264 needs an even width and height, not %ux%u", width,
                        height);
    return CV_OK;
}

/* The settings with their defaults' size: 0 means the table's default. */
static void settings_size(const cv_render_settings *s, uint32_t *width, uint32_t *height) {
    *width = s->width ? s->width : (uint32_t)cv_render_setting_rows[CV_RENDER_SETTING_width].def;
    *height = s->height ? s->height : (uint32_t)cv_render_setting_rows[CV_RENDER_SETTING_height].def;
}

static cv_result check_desc(const cv_live_desc *d) {
    if (!d || !d->renderer || !d->primary || !d->frame)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "live: start: NULL %s",
                        !d             ? "desc"
                        : !d->renderer ? "renderer"
                        : !d->primary  ? "primary"
                                       : "frame callback");
    cv_result res = cv_renderer_check_settings(d->renderer, &d->settings);
    if (res != CV_OK)
        return cv_error(res, "live: start: %s", cv_last_error());
    uint32_t w, h;
    settings_size(&d->settings, &w, &h);
    return check_codec(d->codec, w, h);
}

static void destroy(cv_live *l) {
    pthread_mutex_destroy(&l->lock);
    pthread_cond_destroy(&l->render_cond);
    pthread_cond_destroy(&l->encode_cond);
    pthread_cond_destroy(&l->snapshot_cond);
    free(l);
}

cv_result cv_live_start(const cv_live_desc *desc, cv_live **out) {
    if (!out)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "live: start: NULL out");
    cv_result res = check_desc(desc);
    if (res != CV_OK)
        return res;
    cv_live *l = calloc(1, sizeof(*l));
    if (!l)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "live: start: no memory for the live");
    l->desc = *desc;
    l->max_accumulate = desc->max_accumulate ? desc->max_accumulate : 256;
    l->codec = desc->codec;
    l->encode = desc->encode;
    l->keyframe_request = true;
    live_rate_init(&l->rate, desc->encode.quality, desc->encode.bitrate_kbps);
    settings_size(&desc->settings, &l->width, &l->height);
    pthread_mutex_init(&l->lock, NULL);
    cv_cond_init(&l->render_cond);
    cv_cond_init(&l->encode_cond);
    cv_cond_init(&l->snapshot_cond);
    l->render_started = pthread_create(&l->render_thread, NULL, live_render_main, l) == 0;
    l->encode_started = l->render_started && pthread_create(&l->encode_thread, NULL, live_encode_main, l) == 0;
    if (!l->encode_started) {
        cv_live_stop(l);
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "live: start: cannot start its threads");
    }
    *out = l;
    return CV_OK;
}

void cv_live_stop(cv_live *l) {
    if (!l)
        return;
    pthread_mutex_lock(&l->lock);
    l->stopping = true;
    pthread_cond_broadcast(&l->render_cond);
    pthread_cond_broadcast(&l->encode_cond);
    pthread_cond_broadcast(&l->snapshot_cond);
    pthread_mutex_unlock(&l->lock);
    if (l->render_started)
        pthread_join(l->render_thread, NULL);
    if (l->encode_started)
        pthread_join(l->encode_thread, NULL);
    /* The renderer is the caller's again: nothing of the live's still runs on the primary. A lost
     * device fails the wait at once (the live already failed). */
    if (l->last_ticket)
        (void)cv_device_wait(l->desc.primary, l->last_ticket, LIVE_STOP_WAIT_NS);
    destroy(l);
}

cv_result cv_live_update(cv_live *l, const cv_render_settings *s, uint64_t seq) {
    if (!l || !s)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "live: update %llu: NULL %s", (unsigned long long)seq,
                        l ? "settings" : "live");
    cv_result res = cv_renderer_check_settings(l->desc.renderer, s);
    if (res != CV_OK)
        return cv_error(res, "live: update %llu: %s", (unsigned long long)seq, cv_last_error());
    uint32_t w, h;
    settings_size(s, &w, &h);
    pthread_mutex_lock(&l->lock);
    res = l->failed ? cv_error(CV_ERROR_BAD_STATE, "the live has stopped after an error: %s", l->error)
                    : check_codec(l->codec, w, h);
    if (res == CV_OK) {
        l->pending = *s;
        l->pending_seq = seq;
        l->pending_ms = cv_now_ms();
        l->has_pending = true;
        l->width = w;
        l->height = h;
        pthread_cond_broadcast(&l->render_cond);
    }
    pthread_mutex_unlock(&l->lock);
    return res == CV_OK ? CV_OK : cv_error(res, "live: update %llu: %s", (unsigned long long)seq, cv_last_error());
}

void cv_live_credit(cv_live *l, uint32_t n) {
    if (!l)
        return;
    pthread_mutex_lock(&l->lock);
    l->credit = n > UINT32_MAX - l->credit ? UINT32_MAX : l->credit + n;
    pthread_cond_broadcast(&l->encode_cond);
    pthread_mutex_unlock(&l->lock);
}

cv_result cv_live_set_codec(cv_live *l, cv_codec codec, const cv_encode_params *encode) {
    if (!l)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "live: set codec: NULL live");
    cv_encode_params p = encode ? *encode : (cv_encode_params){ 0 };
    pthread_mutex_lock(&l->lock);
    cv_result res = check_codec(codec, l->width, l->height);
    /* A keyframe request alone (the same codec, no quality or bitrate) keeps what the adaptation chose. */
    bool restart_rate = codec != l->codec || p.quality || p.bitrate_kbps;
    if (res == CV_OK) {
        double link = l->rate.link_bytes_per_s;
        l->codec = codec;
        l->encode = p;
        l->keyframe_request = l->keyframe_request || p.keyframe;
        if (restart_rate) {
            live_rate_init(&l->rate, p.quality, p.bitrate_kbps);
            live_rate_link(&l->rate, link);
        }
    }
    pthread_mutex_unlock(&l->lock);
    return res;
}

void cv_live_report_link(cv_live *l, double bytes_per_s) {
    if (!l)
        return;
    pthread_mutex_lock(&l->lock);
    live_rate_link(&l->rate, bytes_per_s);
    pthread_mutex_unlock(&l->lock);
}

void cv_live_report_display(cv_live *l, uint64_t input_seq, double motion_to_photon_ms) {
    if (!l || !(motion_to_photon_ms >= 0))
        return;
    pthread_mutex_lock(&l->lock);
    l->displayed_seq = input_seq;
    l->motion_to_photon_ms = motion_to_photon_ms;
    if (motion_to_photon_ms > l->motion_to_photon_max_ms)
        l->motion_to_photon_max_ms = motion_to_photon_ms;
    pthread_mutex_unlock(&l->lock);
}
