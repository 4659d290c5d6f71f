/* A render's figures (cv_render_stats): each frame's graph timings
 * collected, with several devices lagged behind the frames in flight, and
 * the rays each frame traced. */
#include "frame_stats.h"

#include <string.h>

#include "corvid/clock.h"

void render_stats_add_timings(const cv_render_frame *f, cv_render_stats *st, const cv_graph_timing *timings,
                              uint32_t n, const cv_partition *used, double frame_wall) {
    const cv_render_settings *s = &f->settings;
    for (uint32_t i = 0; i < n && i < RENDER_TIMINGS; i++) {
        const cv_graph_timing *t = &timings[i];
        if (strncmp(t->name, "transfer ", 9) == 0) {
            st->transfer_bytes += t->bytes;
            st->transfer_ms += t->ms;
        } else if (strcmp(t->name, "trace") == 0 && t->device < f->count && t->device < used->device_count) {
            cv_column_range cols = used->ranges[t->device];
            double ms = t->ms > 0.0 ? t->ms : frame_wall; /* no GPU timing: the frame's wall time */
            st->devices[t->device] = (cv_render_device_stats){ .columns = cols,
                                                               .rays = (uint64_t)cols.width * f->height *
                                                                       cv_render_rays_per_pixel(s),
                                                               .trace_ms = ms,
                                                               .ms_per_column = ms / cols.width };
        }
    }
}

cv_result render_stats_collect(const cv_render_frame *f, render_pending *pending, cv_render_stats *st, uint32_t index,
                               bool last) {
    const uint32_t lag = CV_GRAPH_FRAMES_KEPT - 1;
    double start = cv_now_ms();
    cv_result res = CV_OK;
    for (uint32_t k = index >= lag ? index - lag : 0; k < index && res == CV_OK && f->count > 1; k++) {
        uint32_t slot = k % CV_GRAPH_FRAMES_KEPT, n = 0;
        if (!pending->uncollected[slot] || (!last && k != index - lag))
            continue;
        res = cv_graph_collect(f->graph, pending->uncollected[slot], pending->timings, RENDER_TIMINGS, &n);
        pending->uncollected[slot] = 0;
        if (res == CV_OK)
            render_stats_add_timings(f, st, pending->timings, n, &pending->parts[slot], cv_now_ms() - start);
    }
    return res;
}

void render_stats_count_rays(const cv_render_frame *f, cv_render_stats *st, const cv_partition *part,
                             uint32_t index) {
    const cv_render_settings *s = &f->settings;
    for (uint32_t d = 0; d < f->count; d++)
        st->rays_total += (uint64_t)part->ranges[d].width * f->height * cv_render_rays_per_pixel(s);
    if (f->info.reflections)
        st->reflection_rays += 2 * render_reflect_traced_pixels(f, s, s->first_frame + index) * s->reflection_samples;
    if (f->alpha_mask) /* the rounds run over every ray slot of every band */
        st->alpha_rays += (uint64_t)f->width * f->height *
                          (cv_render_rays_per_pixel(s) * render_alpha_retraces(true) +
                           (f->info.reflections
                                ? (render_alpha_retraces(false) + render_alpha_retraces(true)) * s->reflection_samples
                                : 0));
}
