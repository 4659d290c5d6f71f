/* Figures over the last second for the live's stats: events with a time and
 * up to three values each (render, read and encode ms of a presented frame);
 * how many fell in the last second and their means. Plain data: the live
 * keeps it under its lock. */
#ifndef CORVID_LIVE_WINDOW_H
#define CORVID_LIVE_WINDOW_H

#include <stdbool.h>
#include <stdint.h>

/* Events kept: a rate above this many per second reads as this many. */
#define CV_LIVE_WINDOW_EVENTS 512u
#define CV_LIVE_WINDOW_MS 1000.0

typedef struct live_window {
    double t_ms[CV_LIVE_WINDOW_EVENTS];
    double v[CV_LIVE_WINDOW_EVENTS][3];
    uint32_t next, count;
} live_window;

void live_window_add(live_window *w, double now_ms, const double v[3]);
/* Events in (now_ms - CV_LIVE_WINDOW_MS, now_ms]; means of their values
 * into mean (0 when none). */
uint32_t live_window_last_second(const live_window *w, double now_ms, double mean[3]);
/* The newest event's values into v; false (v untouched) when there is none. */
bool live_window_newest(const live_window *w, double v[3]);

#endif
