/* A render's statistics (cv_render_stats) from the frame graph's timings and
 * the rays each frame traced; and the frames submitted but not yet
 * collected, whose timings the graph's balancer and the stats read late. */
#ifndef CORVID_RENDER_FRAME_STATS_H
#define CORVID_RENDER_FRAME_STATS_H

#include "frame.h"

/* Timings a frame's execute or collect returns at most. */
#define RENDER_TIMINGS 64u

/* Several devices: frames submitted but not collected yet, and their
 * partitions (by frame index % CV_GRAPH_FRAMES_KEPT). */
typedef struct render_pending {
    uint64_t uncollected[CV_GRAPH_FRAMES_KEPT];
    cv_partition parts[CV_GRAPH_FRAMES_KEPT];
    cv_graph_timing timings[RENDER_TIMINGS];
} render_pending;

/* Adds one finished frame's graph timings to the render's stats: transfer
 * totals, and each device's trace time over the columns it had then (`used`).
 * frame_wall stands in where a device has no GPU timings. */
void render_stats_add_timings(const cv_render_frame *f, cv_render_stats *st, const cv_graph_timing *timings,
                              uint32_t n, const cv_partition *used, double frame_wall);
/* Before frame `index`'s bake, with several devices: collects the frame
 * CV_GRAPH_FRAMES_KEPT - 1 back (all frames still pending, on the last frame)
 * and adds their timings. */
cv_result render_stats_collect(const cv_render_frame *f, render_pending *pending, cv_render_stats *st, uint32_t index,
                               bool last);
/* Adds frame `index`'s rays (over the columns of `part`) to the stats. */
void render_stats_count_rays(const cv_render_frame *f, cv_render_stats *st, const cv_partition *part, uint32_t index);

#endif
