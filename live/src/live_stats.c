/* cv_live_get_stats: the live's figures, copied under its lock. */
#include <string.h>

#include "corvid/clock.h"
#include "live_internal.h"

/* What the encoder does with a bitrate of 0 (corvid/encode_types.h), for the stats to say it. */
static uint32_t default_bitrate_kbps(const cv_live *l) {
    double fps = l->encode.fps ? l->encode.fps : 60;
    return (uint32_t)((double)l->width * l->height * fps / 8000.0);
}

void cv_live_get_stats(cv_live *l, cv_live_stats *out) {
    if (!out)
        return;
    memset(out, 0, sizeof(*out));
    if (!l)
        return;
    pthread_mutex_lock(&l->lock);
    double now = cv_now_ms(), means[3];
    out->rendered = l->rendered;
    out->presented = l->presented;
    out->spoiled = l->spoiled;
    out->fps = live_window_last_second(&l->presented_window, now, means);
    if (out->fps == 0) /* a view at rest: the figures of its last frame, not zeros */
        live_window_newest(&l->presented_window, means);
    out->render_ms = means[0];
    out->read_ms = means[1];
    out->encode_ms = means[2];
    out->bytes = l->bytes;
    out->link_bytes_per_s = l->rate.link_bytes_per_s;
    out->motion_to_photon_ms = l->motion_to_photon_ms;
    out->motion_to_photon_max_ms = l->motion_to_photon_max_ms;
    out->quality = l->rate.quality;
    out->bitrate_kbps = l->rate.bitrate_kbps ? l->rate.bitrate_kbps : default_bitrate_kbps(l);
    out->accumulated = l->accumulated;
    memcpy(out->passes, l->passes, sizeof(out->passes));
    out->codec = l->codec;
    out->input_seq = l->input_seq;
    out->displayed_seq = l->displayed_seq;
    out->input_age_ms = l->input_age_ms;
    out->input_age_max_ms = l->input_age_max_ms;
    out->width = l->frame_width;
    out->height = l->frame_height;
    out->still = l->still && !l->has_pending;
    out->failed = l->failed;
    memcpy(out->error, l->error, sizeof(out->error));
    pthread_mutex_unlock(&l->lock);
}
