/* The frames a cv_render_log keeps (render_log.c records them; the stats and
 * trace writers read them). */
#ifndef CORVID_RENDER_LOG_INTERNAL_H
#define CORVID_RENDER_LOG_INTERNAL_H

#include <cjson/cJSON.h>

#include "corvid/render_log.h"

typedef struct render_log_device {
    uint32_t label; /* index into cv_render_log.labels */
    cv_column_range columns;
    uint64_t rays;
} render_log_device;

typedef struct render_log_frame {
    uint32_t frame, sample, device_count, timing_count, timings_cut;
    double submit_ms, wall_ms;
    render_log_device *devices;
    cv_graph_timing *timings;
} render_log_frame;

struct cv_render_log {
    render_log_frame *frames;
    uint32_t frame_count, frame_capacity;
    char (*labels)[CV_LABEL_MAX]; /* distinct device labels, in order of first appearance */
    uint32_t label_count, label_capacity;
    bool failed; /* a frame could not be recorded (no memory) */
    uint32_t failed_frame;
};

/* Whether a timing is a transfer ("transfer '<resource>'") rather than a pass. */
bool render_log_is_transfer(const cv_graph_timing *t);

/* Writes `json` (consumed; NULL = it could not be built) to `path`, indented
 * or on one line; `what` names the file in errors. */
cv_result render_log_write_json(const cv_render_log *log, cJSON *json, const char *path, const char *what,
                                bool indented);

#endif
