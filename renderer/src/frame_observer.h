/* The renderer's side of corvid/render_observer.h: gathers one finished
 * frame's figures into a cv_render_frame_info and calls the observer. */
#ifndef CORVID_RENDER_FRAME_OBSERVER_H
#define CORVID_RENDER_FRAME_OBSERVER_H

#include "corvid/device.h"
#include "corvid/graph.h"
#include "corvid/partition.h"
#include "corvid/render_settings.h"

typedef struct render_frame_report {
    cv_device *const *devices;
    uint32_t device_count;
    const cv_partition *partition; /* this frame's trace columns */
    const cv_render_settings *settings;
    uint32_t frame, height;
    double submit_ms, wall_ms;
    const cv_graph_timing *timings;
    uint32_t timing_count; /* as cv_graph_execute counted them (may exceed the array) */
    uint32_t timing_capacity;
} render_frame_report;

/* Calls settings->observer->frame, if there is one, with the frame's info. */
void render_observe_frame(const render_frame_report *report);

#endif
