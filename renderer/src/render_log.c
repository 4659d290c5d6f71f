/* cv_render_log: recording frames (see corvid/render_log.h). */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "render_log_internal.h"

cv_result cv_render_log_create(cv_render_log **out) {
    if (!out)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_render_log_create: NULL argument");
    *out = calloc(1, sizeof(**out));
    return *out ? CV_OK : cv_error(CV_ERROR_OUT_OF_MEMORY, "render log");
}

void cv_render_log_destroy(cv_render_log *log) {
    if (!log)
        return;
    for (uint32_t f = 0; f < log->frame_count; f++) {
        free(log->frames[f].devices);
        free(log->frames[f].timings);
    }
    free(log->frames);
    free(log->labels);
    free(log);
}

uint32_t cv_render_log_frame_count(const cv_render_log *log) { return log ? log->frame_count : 0; }

bool render_log_is_transfer(const cv_graph_timing *t) { return strncmp(t->name, "transfer ", 9) == 0; }

/* Index of `label` in the log's table, added if new; UINT32_MAX without memory. */
static uint32_t label_id(cv_render_log *log, const char *label) {
    for (uint32_t i = 0; i < log->label_count; i++)
        if (strcmp(log->labels[i], label) == 0)
            return i;
    if (log->label_count == log->label_capacity) {
        uint32_t cap = log->label_capacity ? log->label_capacity * 2 : 8;
        void *p = realloc(log->labels, cap * sizeof(*log->labels));
        if (!p)
            return UINT32_MAX;
        log->labels = p;
        log->label_capacity = cap;
    }
    snprintf(log->labels[log->label_count], CV_LABEL_MAX, "%s", label);
    return log->label_count++;
}

static bool record(cv_render_log *log, const cv_render_frame_info *info) {
    if (log->frame_count == log->frame_capacity) {
        uint32_t cap = log->frame_capacity ? log->frame_capacity * 2 : 16;
        void *p = realloc(log->frames, cap * sizeof(*log->frames));
        if (!p)
            return false;
        log->frames = p;
        log->frame_capacity = cap;
    }
    render_log_frame fr = { .frame = info->frame,
                            .sample = info->sample,
                            .device_count = info->device_count,
                            .timing_count = info->timing_count,
                            .timings_cut = info->timings_cut,
                            .submit_ms = info->submit_ms,
                            .wall_ms = info->wall_ms,
                            .devices = calloc(info->device_count + 1, sizeof(render_log_device)),
                            .timings = malloc((info->timing_count + 1) * sizeof(cv_graph_timing)) };
    bool ok = fr.devices && fr.timings;
    for (uint32_t d = 0; ok && d < info->device_count; d++) {
        fr.devices[d] = (render_log_device){ label_id(log, info->device_labels[d] ? info->device_labels[d] : "?"),
                                             info->columns[d], info->rays[d] };
        ok = fr.devices[d].label != UINT32_MAX;
    }
    if (!ok) {
        free(fr.devices);
        free(fr.timings);
        return false;
    }
    if (info->timing_count)
        memcpy(fr.timings, info->timings, info->timing_count * sizeof(cv_graph_timing));
    log->frames[log->frame_count++] = fr;
    return true;
}

static void on_frame(const cv_render_frame_info *info, void *user) {
    cv_render_log *log = user;
    if (!log->failed && !record(log, info)) {
        log->failed = true;
        log->failed_frame = info->frame;
    }
}

cv_render_observer cv_render_log_observer(cv_render_log *log) {
    return (cv_render_observer){ .frame = on_frame, .user = log };
}

cv_result render_log_write_json(const cv_render_log *log, cJSON *json, const char *path, const char *what,
                                bool indented) {
    if (!log || !path) {
        cJSON_Delete(json);
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "render log: %s: NULL argument", what);
    }
    if (log->failed) {
        cJSON_Delete(json);
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "%s: %s: frame %u could not be recorded (no memory)", what, path,
                        log->failed_frame);
    }
    char *text = !json ? NULL : indented ? cJSON_Print(json) : cJSON_PrintUnformatted(json);
    cJSON_Delete(json);
    if (!text)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "%s: %s: no memory for the JSON", what, path);
    FILE *f = fopen(path, "w");
    cv_result r = CV_OK;
    if (!f) {
        r = cv_error(CV_ERROR_IO, "%s: %s: %s", what, path, strerror(errno));
    } else {
        size_t len = strlen(text);
        bool ok = fwrite(text, 1, len, f) == len && fputc('\n', f) != EOF;
        int saved = errno;
        if (fclose(f) != 0 && ok) {
            ok = false;
            saved = errno;
        }
        if (!ok)
            r = cv_error(CV_ERROR_IO, "%s: %s: %s", what, path, strerror(saved));
    }
    cJSON_free(text);
    return r;
}
