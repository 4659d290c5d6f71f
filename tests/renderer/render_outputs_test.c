/* The renderer's outputs for people who look at frames, on lavapipe:
 *  - the depth plane is the camera distance of the G-buffer position (finite,
 *    > 0 on geometry, +inf on sky) and the direct plane is the composite's
 *    direct sun term (0 in shadow, never above the radiance, lit somewhere);
 *    the CPU reference fills both too;
 *  - an observer sees every frame once, in order, also on one device (whose
 *    frames are otherwise pipelined without timings);
 *  - cv_render_log's stats JSON parses back to the render's cv_render_stats
 *    (frames, rays, devices, transfer bytes) and its per-frame figures add up;
 *  - its trace JSON has one complete event per pass instance per frame, named
 *    device processes, non-negative durations and no overlap on a track;
 *    every pass is placed where its device says it began (lavapipe has
 *    calibrated timestamps: "clocked"), inside its frame's host span
 *    (submission to timings read, 0.5 ms of slack for the calibration);
 *  - bad destinations are refused with the path in the message. */
#include <cjson/cJSON.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "check.h"
#include "corvid/render_log.h"
#include "corvid/renderer.h"
#include "corvid/scene_procedural.h"
#include "corvid/vulkan.h"
#include "test_render.h"
#include "test_json.h"

#define W 160
#define H 90
#define FRAMES 3

static void check_depth_and_direct(const cv_render_output *o, const float camera[3], const char *what) {
    CHECK(o->depth != NULL && o->direct != NULL);
    if (!o->depth || !o->direct)
        return;
    uint32_t geometry = 0, lit = 0, bad_depth = 0, bad_direct = 0;
    for (uint32_t i = 0; i < o->width * o->height; i++) {
        const float *p = &o->position[i * 4], *d = &o->direct[i * 4];
        if (p[3] == 0.0f) {
            bad_depth += !isinf(o->depth[i]) || o->depth[i] < 0.0f;
            bad_direct += d[0] != 0.0f || d[1] != 0.0f || d[2] != 0.0f;
            continue;
        }
        geometry++;
        float dx = p[0] - camera[0], dy = p[1] - camera[1], dz = p[2] - camera[2];
        float dist = sqrtf(dx * dx + dy * dy + dz * dz);
        bad_depth += !(o->depth[i] > 0.0f) || fabsf(o->depth[i] - dist) > 1e-5f * dist;
        float shadow = o->visibility[i * 4];
        for (int c = 0; c < 3; c++) {
            /* radiance = albedo * (direct + ambient + local) + emission, every term >= 0 */
            bad_direct += !(d[c] >= 0.0f) || d[c] > o->radiance[i * 4 + c] * 1.0001f + 1e-6f;
            bad_direct += shadow == 0.0f && d[c] != 0.0f;
        }
        lit += d[0] + d[1] + d[2] > 0.0f;
    }
    fprintf(stderr, "%s: %u geometry pixels, %u lit by the sun\n", what, geometry, lit);
    CHECK(geometry > o->width * o->height / 2);
    CHECK(lit > 0); /* the room is lit mostly by the sky: the sun reaches about 2% of it */
    CHECK_EQ_INT(bad_depth, 0);
    CHECK_EQ_INT(bad_direct, 0);
}

/* An observer that checks frames arrive once each, in order. */
typedef struct frame_count {
    uint32_t calls, out_of_order, without_timings;
} frame_count;

static void count_frame(const cv_render_frame_info *info, void *user) {
    frame_count *c = user;
    c->out_of_order += info->frame != c->calls || info->frames != FRAMES || !(info->wall_ms > 0.0);
    c->without_timings += info->timing_count == 0 || info->device_count == 0 || !info->device_labels[0];
    c->calls++;
}

static const char *string(const cJSON *o, const char *key) {
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(o, key);
    return cJSON_IsString(v) ? v->valuestring : "";
}

static void check_stats(const char *path, const cv_render_stats *st, uint32_t gpus) {
    cJSON *root = cv_test_json_parse_file(path);
    CHECK(root != NULL);
    const cJSON *frames = cJSON_GetObjectItem(root, "frames"), *summary = cJSON_GetObjectItem(root, "summary");
    CHECK_EQ_INT(cJSON_GetArraySize(frames), st->frames);
    CHECK_EQ_INT(cv_test_json_number(summary, "frames"), st->frames);
    CHECK_EQ_INT(cv_test_json_number(summary, "device_count"), st->device_count);
    CHECK_EQ_INT(cv_test_json_number(summary, "rays_total"), st->rays_total);
    /* Reflections on (the default, full rate): a reflection and a shadow ray per pixel per frame. */
    CHECK_EQ_INT(cv_test_json_number(summary, "reflection_rays"), st->reflection_rays);
    CHECK_EQ_INT(st->reflection_rays, (uint64_t)2 * W * H * st->frames);
    CHECK_EQ_INT(cv_test_json_number(summary, "alpha_rays"), 0); /* the room has no alpha-masked material */
    CHECK_EQ_INT(st->alpha_rays, 0);
    CHECK_EQ_INT(cv_test_json_number(summary, "transfer_bytes"), st->transfer_bytes);
    CHECK(fabs(cv_test_json_number(summary, "frame_ms_mean") - st->frame_ms) < 1e-9 * st->frame_ms + 1e-12);
    CHECK_EQ_INT(cJSON_GetArraySize(cJSON_GetObjectItem(summary, "devices")), gpus);
    uint64_t rays = 0, bytes = 0;
    uint32_t index = 0, traces = 0;
    const cJSON *frame;
    cJSON_ArrayForEach(frame, frames) {
        CHECK_EQ_INT(cv_test_json_number(frame, "frame"), index++);
        CHECK(cv_test_json_number(frame, "wall_ms") > 0.0);
        const cJSON *devices = cJSON_GetObjectItem(frame, "devices"), *dev;
        CHECK_EQ_INT(cJSON_GetArraySize(devices), gpus);
        uint32_t columns = 0;
        cJSON_ArrayForEach(dev, devices) {
            char label[16];
            snprintf(label, sizeof label, "gpu%d", (int)cv_test_json_number(dev, "index"));
            CHECK(strcmp(string(dev, "label"), label) == 0);
            const cJSON *cols = cJSON_GetObjectItem(dev, "columns");
            columns += (uint32_t)cv_test_json_number(cols, "width");
            rays += (uint64_t)cv_test_json_number(dev, "rays");
            CHECK_EQ_INT(cv_test_json_number(dev, "rays"), cv_test_json_number(cols, "width") * H * (1 + 2));
            const cJSON *e;
            cJSON_ArrayForEach(e, cJSON_GetObjectItem(dev, "passes")) {
                traces += strcmp(string(e, "name"), "trace") == 0;
                CHECK(cv_test_json_number(e, "ms") >= 0.0);
            }
            cJSON_ArrayForEach(e, cJSON_GetObjectItem(dev, "transfers")) {
                bytes += (uint64_t)cv_test_json_number(e, "bytes");
                CHECK(strncmp(string(e, "name"), "transfer '", 10) == 0);
            }
        }
        CHECK_EQ_INT(columns, W);
    }
    CHECK_EQ_INT(rays, st->rays_total);
    CHECK_EQ_INT(bytes, st->transfer_bytes);
    CHECK_EQ_INT(traces, FRAMES * gpus);
    cJSON_Delete(root);
}

typedef struct span {
    int pid, tid;
    double ts, dur;
} span;

static int by_track(const void *a, const void *b) {
    const span *x = a, *y = b;
    if (x->pid != y->pid)
        return x->pid - y->pid;
    if (x->tid != y->tid)
        return x->tid - y->tid;
    return x->ts < y->ts ? -1 : x->ts > y->ts;
}

/* Expected pass instances: gbuffer (frame 0), trace on every device and
 * accumulate every frame, filter and composite on the last. */
static void check_trace(const char *path, uint32_t gpus) {
    cJSON *root = cv_test_json_parse_file(path);
    CHECK(root != NULL);
    const cJSON *events = cJSON_GetObjectItem(root, "traceEvents"), *e;
    span spans[512];
    uint32_t count = 0, passes = 0, per_frame[FRAMES] = { 0 }, traces[FRAMES] = { 0 }, transfers = 0;
    uint32_t named = 0, negative = 0, clocked = 0, outside = 0;
    double frame_start[FRAMES], frame_end[FRAMES];
    cJSON_ArrayForEach(e, events) {
        unsigned f;
        if (!strcmp(string(e, "ph"), "X") && !strcmp(string(e, "cat"), "frame") &&
            sscanf(string(e, "name"), "frame %u", &f) == 1 && f < FRAMES) {
            frame_start[f] = cv_test_json_number(e, "ts");
            frame_end[f] = frame_start[f] + cv_test_json_number(e, "dur");
        }
    }
    cJSON_ArrayForEach(e, events) {
        const char *ph = string(e, "ph");
        if (!strcmp(ph, "M") && !strcmp(string(e, "name"), "process_name")) {
            const char *name = string(cJSON_GetObjectItem(e, "args"), "name");
            named += !strcmp(name, "gpu0") || !strcmp(name, "gpu1") || !strcmp(name, "host");
        }
        if (strcmp(ph, "X") != 0)
            continue;
        double dur = cv_test_json_number(e, "dur");
        negative += !(dur >= 0.0) || !(cv_test_json_number(e, "ts") >= 0.0);
        if (count < 512)
            spans[count++] = (span){ (int)cv_test_json_number(e, "pid"), (int)cv_test_json_number(e, "tid"),
                                     cv_test_json_number(e, "ts"), dur };
        int frame = (int)cv_test_json_number(cJSON_GetObjectItem(e, "args"), "frame");
        if (!strcmp(string(e, "cat"), "pass")) {
            passes++;
            const cJSON *clock = cJSON_GetObjectItem(cJSON_GetObjectItem(e, "args"), "clocked");
            clocked += cJSON_IsTrue(clock);
            if (frame >= 0 && frame < FRAMES) {
                double ts = cv_test_json_number(e, "ts");
                outside += ts < frame_start[frame] - 500.0 || ts + dur > frame_end[frame] + 500.0;
                per_frame[frame]++;
                traces[frame] += !strcmp(string(e, "name"), "trace");
            }
        } else if (!strcmp(string(e, "cat"), "transfer")) {
            transfers++;
            /* The gathers are zero-copy on lavapipe's virtual GPUs (graph.h): GPU-side waits, no byte. */
            const char *what = string(e, "name");
            bool gather = strstr(what, "'visibility'") || strstr(what, "'reflection samples'");
            double moved = cv_test_json_number(cJSON_GetObjectItem(e, "args"), "bytes");
            CHECK(gather ? moved == 0.0 : moved > 0.0);
        }
    }
    CHECK_EQ_INT(named, gpus + 1);
    CHECK_EQ_INT(negative, 0);
    /* per frame: trace and reflect on every device, accumulate and reflect_filter on the primary;
     * gbuffer on the first frame, reflect_denoise, filter, composite and present on the last */
    CHECK_EQ_INT(passes, 1 + FRAMES * (2 * gpus + 2) + 4);
    CHECK_EQ_INT(clocked, passes);
    CHECK_EQ_INT(outside, 0);
    for (uint32_t f = 0; f < FRAMES; f++) {
        CHECK_EQ_INT(traces[f], gpus);
        CHECK_EQ_INT(per_frame[f], 2 * gpus + 2 + (f == 0) + 4 * (f == FRAMES - 1));
    }
    if (gpus > 1)
        CHECK(transfers >= FRAMES); /* at least the visibility copy-back every frame */
    else
        CHECK_EQ_INT(transfers, 0);
    /* Events of one track never overlap (microseconds; whole nanoseconds in the file). */
    qsort(spans, count, sizeof(span), by_track);
    uint32_t overlaps = 0;
    for (uint32_t i = 1; i < count; i++)
        if (spans[i].pid == spans[i - 1].pid && spans[i].tid == spans[i - 1].tid)
            overlaps += spans[i - 1].ts + spans[i - 1].dur > spans[i].ts + 1e-6;
    CHECK_EQ_INT(overlaps, 0);
    cJSON_Delete(root);
}

static void test_logs(const cv_scene *scene, const cv_bvh *bvh, uint32_t gpus, const char *dir) {
    cv_render_log *log = NULL;
    CHECK_OK(cv_render_log_create(&log));
    cv_render_observer obs = cv_render_log_observer(log);
    cv_render_settings s = { .width = W, .height = H, .frames = FRAMES, .ao_samples = 2, .observer = &obs };
    cv_render_output out = { 0 };
    cv_render_stats st = { 0 };
    CHECK_OK(cv_test_render(gpus, scene, bvh, &s, &out, &st));
    CHECK_EQ_INT(cv_render_log_frame_count(log), FRAMES);
    char stats_path[512], trace_path[512];
    snprintf(stats_path, sizeof stats_path, "%s/stats%u.json", dir, gpus);
    snprintf(trace_path, sizeof trace_path, "%s/trace%u.json", dir, gpus);
    CHECK_OK(cv_render_log_write_stats(log, &st, stats_path));
    CHECK_OK(cv_render_log_write_trace(log, trace_path));
    check_stats(stats_path, &st, gpus);
    check_trace(trace_path, gpus);
    if (gpus == 2) { /* the planes, once */
        cv_camera cam = *cv_scene_camera(scene, 0);
        check_depth_and_direct(&out, cam.position, "GPU render");
    }
    /* Bad destinations name the path; NULL arguments are refused. */
    char bad[600];
    snprintf(bad, sizeof bad, "%s/missing/stats.json", dir);
    CHECK_RESULT(cv_render_log_write_stats(log, &st, bad), CV_ERROR_IO);
    CHECK(strstr(cv_last_error(), bad) != NULL);
    CHECK_RESULT(cv_render_log_write_trace(log, bad), CV_ERROR_IO);
    CHECK(access(bad, F_OK) != 0);
    CHECK_RESULT(cv_render_log_write_stats(log, NULL, stats_path), CV_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(cv_render_log_write_trace(NULL, trace_path), CV_ERROR_INVALID_ARGUMENT);
    remove(stats_path);
    remove(trace_path);
    cv_render_output_free(&out);
    CHECK(out.depth == NULL && out.direct == NULL);
    cv_render_log_destroy(log);
}

int main(void) {
    cv_scene *scene = NULL;
    cv_bvh *bvh = NULL;
    CHECK_OK(cv_scene_make_room(1, &scene));
    CHECK_OK(cv_bvh_build_flat(scene, NULL, &bvh));
    char dir[] = "/tmp/corvid_render_outputs_XXXXXX";
    CHECK(mkdtemp(dir) != NULL);

    test_logs(scene, bvh, 2, dir);
    test_logs(scene, bvh, 1, dir);

    /* One device: every frame reaches the observer (frames wait for their timings). */
    frame_count counted = { 0 };
    cv_render_observer obs = { count_frame, &counted };
    cv_render_settings s = { .width = W, .height = H, .frames = FRAMES, .ao_samples = 1, .observer = &obs };
    cv_render_output out = { 0 };
    CHECK_OK(cv_test_render(1, scene, bvh, &s, &out, NULL));
    CHECK_EQ_INT(counted.calls, FRAMES);
    CHECK_EQ_INT(counted.out_of_order, 0);
    CHECK_EQ_INT(counted.without_timings, 0);
    cv_render_output_free(&out);

    /* The CPU reference fills depth and direct the same way. */
    cv_render_output ref = { 0 };
    CHECK_OK(cv_render_reference(scene, bvh, &(cv_render_settings){ .width = 64, .height = 36, .ao_samples = 1 }, 1,
                                 2, &ref));
    cv_camera cam = *cv_scene_camera(scene, 0);
    check_depth_and_direct(&ref, cam.position, "CPU reference");
    cv_render_output_free(&ref);

    CHECK(rmdir(dir) == 0);
    cv_bvh_destroy(bvh);
    cv_scene_destroy(scene);
    CHECK_NOTHING_LIVE();
    return check_report("render_outputs");
}
