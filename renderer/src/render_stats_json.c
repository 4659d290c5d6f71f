/* cv_render_log_write_stats: the frames as a JSON stats file (see
 * corvid/render_log.h). Layout:
 *
 *   { "frames": [ { "frame": 0, "sample": 0, "wall_ms": 12.5, "timings_cut": 0,
 *                   "devices": [ { "index": 0, "label": "gpu0", "columns": { "x": 0, "width": 48 },
 *                                  "rays": 12960,
 *                                  "passes": [ { "name": "trace", "ms": 3.1, "start_ms": 0.4 }, ... ],
 *                                  "transfers": [ { "name": "transfer 'visibility'",
 *                                                   "bytes": 4096, "ms": 0.2 }, ... ] } ] } ],
 *     "summary": { "frames": 2, "frames_logged": 2, "device_count": 2, "devices_lost": 0,
 *                  "rays_total": 25920, "reflection_rays": 17280, "alpha_rays": 0, "frame_ms_mean": 12.0,
 *                  "upload_ms": 3.0,
 *                  "transfer_bytes": 8192, "transfer_ms": 0.4,
 *                  "devices": [ { "index", "label", "columns", "rays", "trace_ms", "ms_per_column" } ],
 *                  "passes": [ { "name": "trace", "instances": 4, "ms_total": 12.4 }, ... ] } }
 *
 * "rays" and "rays_total" are shadow and AO rays; "reflection_rays" (not in
 * rays_total) the reflection rays and their shadow rays, "alpha_rays" the
 * ray slots re-traced past alpha-masked cut points (cv_render_stats).
 * "start_ms" (passes and transfers whose device says when they began on the
 * host's clock: cv_graph_timing.host_ms) is ms after the frame's submission.
 * A transfer is listed under its source device. The summary's devices are
 * cv_render_stats's (the last frame's figures). */
#include <string.h>

#include "render_log_internal.h"

static cJSON *columns_json(cv_column_range c) {
    cJSON *o = cJSON_CreateObject();
    cJSON_AddNumberToObject(o, "x", c.x);
    cJSON_AddNumberToObject(o, "width", c.width);
    return o;
}

static cJSON *frame_json(const cv_render_log *log, const render_log_frame *fr) {
    cJSON *o = cJSON_CreateObject();
    cJSON_AddNumberToObject(o, "frame", fr->frame);
    cJSON_AddNumberToObject(o, "sample", fr->sample);
    cJSON_AddNumberToObject(o, "wall_ms", fr->wall_ms);
    cJSON_AddNumberToObject(o, "timings_cut", fr->timings_cut);
    cJSON *devices = cJSON_AddArrayToObject(o, "devices");
    for (uint32_t d = 0; d < fr->device_count; d++) {
        cJSON *dev = cJSON_CreateObject();
        cJSON_AddItemToArray(devices, dev);
        cJSON_AddNumberToObject(dev, "index", d);
        cJSON_AddStringToObject(dev, "label", log->labels[fr->devices[d].label]);
        cJSON_AddItemToObject(dev, "columns", columns_json(fr->devices[d].columns));
        cJSON_AddNumberToObject(dev, "rays", (double)fr->devices[d].rays);
        cJSON *passes = cJSON_AddArrayToObject(dev, "passes");
        cJSON *transfers = cJSON_AddArrayToObject(dev, "transfers");
        for (uint32_t i = 0; i < fr->timing_count; i++) {
            const cv_graph_timing *t = &fr->timings[i];
            if (t->device != d)
                continue;
            cJSON *e = cJSON_CreateObject();
            cJSON_AddStringToObject(e, "name", t->name);
            if (render_log_is_transfer(t))
                cJSON_AddNumberToObject(e, "bytes", (double)t->bytes);
            cJSON_AddNumberToObject(e, "ms", t->ms);
            if (t->host_ms > 0.0) /* clocked: when it began, ms after the frame's submission */
                cJSON_AddNumberToObject(e, "start_ms", t->host_ms - fr->submit_ms);
            cJSON_AddItemToArray(render_log_is_transfer(t) ? transfers : passes, e);
        }
    }
    return o;
}

/* Per pass name: instances and total ms over every logged frame. */
static cJSON *pass_totals_json(const cv_render_log *log) {
    cJSON *passes = cJSON_CreateArray();
    for (uint32_t f = 0; f < log->frame_count; f++)
        for (uint32_t i = 0; i < log->frames[f].timing_count; i++) {
            const cv_graph_timing *t = &log->frames[f].timings[i];
            if (render_log_is_transfer(t))
                continue;
            cJSON *entry = NULL, *e;
            cJSON_ArrayForEach(e, passes) {
                const cJSON *name = cJSON_GetObjectItem(e, "name");
                if (cJSON_IsString(name) && strcmp(name->valuestring, t->name) == 0)
                    entry = e;
            }
            if (!entry) {
                entry = cJSON_CreateObject();
                cJSON_AddStringToObject(entry, "name", t->name);
                cJSON_AddNumberToObject(entry, "instances", 0);
                cJSON_AddNumberToObject(entry, "ms_total", 0);
                cJSON_AddItemToArray(passes, entry);
            }
            cJSON *n = cJSON_GetObjectItem(entry, "instances"), *ms = cJSON_GetObjectItem(entry, "ms_total");
            if (n && ms) {
                cJSON_SetNumberValue(n, n->valuedouble + 1);
                cJSON_SetNumberValue(ms, ms->valuedouble + t->ms);
            }
        }
    return passes;
}

static cJSON *summary_json(const cv_render_log *log, const cv_render_stats *s) {
    cJSON *o = cJSON_CreateObject();
    cJSON_AddNumberToObject(o, "frames", s->frames);
    cJSON_AddNumberToObject(o, "frames_logged", log->frame_count);
    cJSON_AddNumberToObject(o, "device_count", s->device_count);
    cJSON_AddNumberToObject(o, "devices_lost", s->devices_lost);
    cJSON_AddNumberToObject(o, "rays_total", (double)s->rays_total);
    cJSON_AddNumberToObject(o, "reflection_rays", (double)s->reflection_rays);
    cJSON_AddNumberToObject(o, "alpha_rays", (double)s->alpha_rays);
    cJSON_AddNumberToObject(o, "frame_ms_mean", s->frame_ms);
    cJSON_AddNumberToObject(o, "upload_ms", s->upload_ms);
    cJSON_AddNumberToObject(o, "transfer_bytes", (double)s->transfer_bytes);
    cJSON_AddNumberToObject(o, "transfer_ms", s->transfer_ms);
    /* Labels from the last frame, whose devices cv_render_stats describes. */
    const render_log_frame *last = log->frame_count ? &log->frames[log->frame_count - 1] : NULL;
    cJSON *devices = cJSON_AddArrayToObject(o, "devices");
    for (uint32_t d = 0; d < s->device_count && d < CV_MAX_DEVICES; d++) {
        const cv_render_device_stats *ds = &s->devices[d];
        cJSON *dev = cJSON_CreateObject();
        cJSON_AddItemToArray(devices, dev);
        cJSON_AddNumberToObject(dev, "index", d);
        if (last && d < last->device_count)
            cJSON_AddStringToObject(dev, "label", log->labels[last->devices[d].label]);
        cJSON_AddItemToObject(dev, "columns", columns_json(ds->columns));
        cJSON_AddNumberToObject(dev, "rays", (double)ds->rays);
        cJSON_AddNumberToObject(dev, "trace_ms", ds->trace_ms);
        cJSON_AddNumberToObject(dev, "ms_per_column", ds->ms_per_column);
    }
    cJSON_AddItemToObject(o, "passes", pass_totals_json(log));
    return o;
}

cv_result cv_render_log_write_stats(const cv_render_log *log, const cv_render_stats *stats, const char *path) {
    if (!log || !stats || !path)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_render_log_write_stats: NULL argument");
    cJSON *root = cJSON_CreateObject();
    cJSON *frames = root ? cJSON_AddArrayToObject(root, "frames") : NULL;
    for (uint32_t f = 0; frames && f < log->frame_count; f++)
        cJSON_AddItemToArray(frames, frame_json(log, &log->frames[f]));
    if (root)
        cJSON_AddItemToObject(root, "summary", summary_json(log, stats));
    return render_log_write_json(log, root, path, "stats", true);
}
