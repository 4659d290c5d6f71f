/* Bandwidth adaptation of the live's encoder (live_rate.h). */
#include "live_rate.h"

#include <math.h>

void live_rate_init(live_rate *r, uint32_t quality, uint32_t bitrate_kbps) {
    if (quality == 0)
        quality = 85;
    if (quality < CV_LIVE_QUALITY_MIN)
        quality = CV_LIVE_QUALITY_MIN;
    if (quality > CV_LIVE_QUALITY_MAX)
        quality = CV_LIVE_QUALITY_MAX;
    *r = (live_rate){ .quality = quality, .bitrate_kbps = bitrate_kbps, .bitrate_cap_kbps = bitrate_kbps };
}

void live_rate_link(live_rate *r, double bytes_per_s) {
    if (!(bytes_per_s > 0) || !isfinite(bytes_per_s))
        return;
    r->link_bytes_per_s = bytes_per_s;
    double kbps = bytes_per_s * CV_LIVE_LINK_SHARE * 8.0 / 1000.0;
    if (r->bitrate_cap_kbps && kbps > r->bitrate_cap_kbps)
        kbps = r->bitrate_cap_kbps;
    if (kbps < CV_LIVE_MIN_BITRATE_KBPS)
        kbps = CV_LIVE_MIN_BITRATE_KBPS;
    if (kbps > UINT32_MAX)
        kbps = UINT32_MAX;
    r->bitrate_kbps = (uint32_t)kbps;
}

/* Down in proportion to the excess (a frame twice the budget: 20 steps), so a
 * camera that starts moving over a slow link gets there within a few frames;
 * up one step per frame below 60% of the budget, so the quality does not
 * swing around the point where a frame just fits. */
void live_rate_jpeg_frame(live_rate *r, size_t bytes, double fps) {
    if (r->link_bytes_per_s <= 0 || bytes == 0)
        return;
    if (!(fps >= CV_LIVE_RATE_MIN_FPS))
        fps = CV_LIVE_RATE_MIN_FPS;
    double budget = r->link_bytes_per_s * CV_LIVE_LINK_SHARE / fps;
    double ratio = (double)bytes / budget;
    if (ratio > 1.0) {
        double step = ceil((ratio - 1.0) * 20.0);
        step = step < 2 ? 2 : step > 20 ? 20 : step;
        r->quality = r->quality > CV_LIVE_QUALITY_MIN + (uint32_t)step ? r->quality - (uint32_t)step
                                                                       : CV_LIVE_QUALITY_MIN;
    } else if (ratio < 0.6 && r->quality < CV_LIVE_QUALITY_MAX) {
        r->quality++;
    }
}
