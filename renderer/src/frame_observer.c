/* One finished frame as a cv_render_frame_info (see frame_observer.h). */
#include "frame_observer.h"

void render_observe_frame(const render_frame_report *rep) {
    const cv_render_settings *s = rep->settings;
    if (!s->observer || !s->observer->frame)
        return;
    uint32_t kept = rep->timing_count < rep->timing_capacity ? rep->timing_count : rep->timing_capacity;
    if (kept > CV_RENDER_FRAME_TIMINGS)
        kept = CV_RENDER_FRAME_TIMINGS;
    cv_render_frame_info info = { .frame = rep->frame,
                                  .frames = s->frames,
                                  .sample = s->first_frame + rep->frame,
                                  .submit_ms = rep->submit_ms,
                                  .wall_ms = rep->wall_ms,
                                  .device_count = rep->device_count,
                                  .timings = rep->timings,
                                  .timing_count = kept,
                                  .timings_cut = rep->timing_count - kept };
    for (uint32_t d = 0; d < rep->device_count && d < CV_MAX_DEVICES; d++) {
        info.device_labels[d] = cv_device_label(rep->devices[d]);
        info.columns[d] = rep->partition->ranges[d];
        info.rays[d] = (uint64_t)info.columns[d].width * rep->height * cv_render_rays_per_pixel(s);
    }
    s->observer->frame(&info, s->observer->user);
}
