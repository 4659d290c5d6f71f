/* Figures over the last second (live_window.h). */
#include "live_window.h"

void live_window_add(live_window *w, double now_ms, const double v[3]) {
    w->t_ms[w->next] = now_ms;
    for (int i = 0; i < 3; i++)
        w->v[w->next][i] = v ? v[i] : 0;
    w->next = (w->next + 1) % CV_LIVE_WINDOW_EVENTS;
    if (w->count < CV_LIVE_WINDOW_EVENTS)
        w->count++;
}

uint32_t live_window_last_second(const live_window *w, double now_ms, double mean[3]) {
    double sum[3] = { 0, 0, 0 };
    uint32_t n = 0;
    /* Newest first: events are added in time order, so the first one too old ends it. */
    for (uint32_t k = 0; k < w->count; k++) {
        uint32_t i = (w->next + CV_LIVE_WINDOW_EVENTS - 1 - k) % CV_LIVE_WINDOW_EVENTS;
        if (w->t_ms[i] <= now_ms - CV_LIVE_WINDOW_MS)
            break;
        for (int j = 0; j < 3; j++)
            sum[j] += w->v[i][j];
        n++;
    }
    for (int j = 0; mean && j < 3; j++)
        mean[j] = n ? sum[j] / n : 0;
    return n;
}

bool live_window_newest(const live_window *w, double v[3]) {
    if (!w->count)
        return false;
    uint32_t i = (w->next + CV_LIVE_WINDOW_EVENTS - 1) % CV_LIVE_WINDOW_EVENTS;
    for (int j = 0; j < 3; j++)
        v[j] = w->v[i][j];
    return true;
}
