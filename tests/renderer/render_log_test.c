/* cv_render_log on frames made up here (no GPU), so every figure is known:
 *  - the trace places events exactly as corvid/render_log.h says: a frame
 *    starts at its submit time, a device's passes end to end, a transfer from
 *    where the host's submission had got to, passes after a transfer no
 *    earlier than its end, a device's track carried over from frame to frame;
 *  - a timing that says when it began on the host's clock (host_ms: clocked
 *    devices, and every transfer) is placed there instead, overlapping
 *    across devices as it really ran, and marked "clocked";
 *  - a device keeps its process when devices are renumbered (a lost device);
 *  - the stats file holds each frame's figures and the per-pass totals;
 *  - a label with quotes and backslashes stays valid JSON. */
#include <cjson/cJSON.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "check.h"
#include "corvid/render_log.h"
#include "test_json.h"

static cv_graph_timing timing(const char *name, uint32_t device, double ms, uint64_t bytes) {
    cv_graph_timing t = { .device = device, .ms = ms, .bytes = bytes };
    snprintf(t.name, sizeof t.name, "%s", name);
    return t;
}

/* The complete event named `name` of `frame` on process `pid` (NULL if none). */
static const cJSON *event(const cJSON *events, const char *name, int frame, int pid) {
    const cJSON *e;
    cJSON_ArrayForEach(e, events) {
        const cJSON *n = cJSON_GetObjectItem(e, "name");
        if (cJSON_IsString(n) && !strcmp(n->valuestring, name) && cv_test_json_number(e, "pid") == pid &&
            cv_test_json_number(cJSON_GetObjectItem(e, "args"), "frame") == frame)
            return e;
    }
    return NULL;
}

/* ts and dur in microseconds, to the nanosecond. */
static void check_span(const cJSON *events, const char *name, int frame, int pid, int tid, double ts, double dur) {
    const cJSON *e = event(events, name, frame, pid);
    CHECK(e != NULL);
    if (!e)
        return;
    CHECK(!strcmp(cJSON_GetObjectItem(e, "ph")->valuestring, "X"));
    CHECK_EQ_INT(cv_test_json_number(e, "tid"), tid);
    if (fabs(cv_test_json_number(e, "ts") - ts) > 1e-3 || fabs(cv_test_json_number(e, "dur") - dur) > 1e-3) {
        check_failures++;
        fprintf(stderr, "%s frame %d pid %d: ts %.3f dur %.3f, expected %.3f %.3f\n", name, frame, pid,
                cv_test_json_number(e, "ts"), cv_test_json_number(e, "dur"), ts, dur);
    }
}

/* One frame whose timings carry host_ms: each is placed where it began. */
static void check_clocked(const char *trace) {
    cv_render_log *log = NULL;
    CHECK_OK(cv_render_log_create(&log));
    if (!log)
        return;
    cv_render_observer obs = cv_render_log_observer(log);
    cv_graph_timing f[] = { timing("trace", 0, 1.0, 0), timing("trace", 1, 2.0, 0),
                            timing("transfer 'visibility'", 1, 0.5, 40), timing("accumulate", 0, 0.25, 0) };
    f[0].host_ms = 501.5; /* device 0 began 1.5 ms after the submission */
    f[1].host_ms = 501.0; /* device 1 earlier, and still running when device 0 began */
    f[2].host_ms = 503.25;
    f[3].host_ms = 504.0;
    cv_render_frame_info info = { .frame = 0,
                                  .frames = 1,
                                  .submit_ms = 500.0,
                                  .wall_ms = 5.0,
                                  .device_count = 2,
                                  .device_labels = { "a", "b" },
                                  .columns = { { 0, 64 }, { 64, 32 } },
                                  .timings = f,
                                  .timing_count = 4 };
    obs.frame(&info, obs.user);
    CHECK_OK(cv_render_log_write_trace(log, trace));
    cJSON *root = cv_test_json_parse_file(trace);
    const cJSON *events = root ? cJSON_GetObjectItem(root, "traceEvents") : NULL;
    check_span(events, "trace", 0, 1, 1, 1500.0, 1000.0);
    check_span(events, "trace", 0, 2, 1, 1000.0, 2000.0);
    check_span(events, "transfer 'visibility'", 0, 2, 2, 3250.0, 500.0);
    check_span(events, "accumulate", 0, 1, 1, 4000.0, 250.0);
    const cJSON *e = event(events, "trace", 0, 1);
    CHECK(e && cJSON_IsTrue(cJSON_GetObjectItem(cJSON_GetObjectItem(e, "args"), "clocked")));
    cJSON_Delete(root);
    cv_render_log_destroy(log);
    remove(trace);
}

int main(void) {
    char dir[] = "/tmp/corvid_render_log_XXXXXX", stats[128], trace[128];
    CHECK(mkdtemp(dir) != NULL);
    snprintf(stats, sizeof stats, "%s/stats.json", dir);
    snprintf(trace, sizeof trace, "%s/trace.json", dir);
    cv_render_log *log = NULL;
    CHECK_OK(cv_render_log_create(&log));
    cv_render_observer obs = cv_render_log_observer(log);

    /* Frame 0 on "a" and "b\"q\\": G-buffer 2 ms, its transfer 3 ms (host,
     * waiting for it), traces 4 and 5 ms, the copy-back 6 ms, accumulate 0.5 ms. */
    cv_graph_timing f0[] = { timing("gbuffer", 0, 2.0, 0),
                             timing("transfer 'gbuffer position'", 0, 3.0, 100),
                             timing("trace", 0, 4.0, 0),
                             timing("trace", 1, 5.0, 0),
                             timing("transfer 'visibility'", 1, 6.0, 40),
                             timing("accumulate", 0, 0.5, 0) };
    cv_render_frame_info info = { .frame = 0,
                                  .frames = 2,
                                  .sample = 7,
                                  .submit_ms = 1000.0,
                                  .wall_ms = 12.0,
                                  .device_count = 2,
                                  .device_labels = { "a", "b\"q\\" },
                                  .columns = { { 0, 64 }, { 64, 32 } },
                                  .rays = { 64 * 10 * 3, 32 * 10 * 3 },
                                  .timings = f0,
                                  .timing_count = 6 };
    obs.frame(&info, obs.user);
    /* Frame 1, submitted 1 ms after frame 0's end; "b" was lost: "a" alone
     * (trace 1 ms, accumulate 1 ms, composite 2 ms; one timing cut). */
    cv_graph_timing f1[] = { timing("trace", 0, 1.0, 0), timing("accumulate", 0, 1.0, 0),
                             timing("composite", 0, 2.0, 0) };
    info = (cv_render_frame_info){ .frame = 1,
                                   .frames = 2,
                                   .sample = 8,
                                   .submit_ms = 1013.0,
                                   .wall_ms = 4.5,
                                   .device_count = 1,
                                   .device_labels = { "a" },
                                   .columns = { { 0, 96 } },
                                   .rays = { 96 * 10 * 3 },
                                   .timings = f1,
                                   .timing_count = 3,
                                   .timings_cut = 1 };
    obs.frame(&info, obs.user);
    /* Frame 2: "b\"q\\" alone, now device 0: still its own process. */
    cv_graph_timing f2[] = { timing("trace", 0, 1.0, 0) };
    info = (cv_render_frame_info){ .frame = 2,
                                   .frames = 3,
                                   .submit_ms = 1020.0,
                                   .wall_ms = 1.5,
                                   .device_count = 1,
                                   .device_labels = { "b\"q\\" },
                                   .columns = { { 0, 96 } },
                                   .rays = { 96 * 10 * 3 },
                                   .timings = f2,
                                   .timing_count = 1 };
    obs.frame(&info, obs.user);
    CHECK_EQ_INT(cv_render_log_frame_count(log), 3);

    CHECK_OK(cv_render_log_write_trace(log, trace));
    cJSON *root = cv_test_json_parse_file(trace);
    CHECK(root != NULL);
    const cJSON *events = cJSON_GetObjectItem(root, "traceEvents");
    /* pid 1 = "a", 2 = "b\"q\\", 3 = host; times from frame 0's submission. */
    check_span(events, "gbuffer", 0, 1, 1, 0.0, 2000.0);
    check_span(events, "transfer 'gbuffer position'", 0, 1, 2, 0.0, 3000.0);
    check_span(events, "trace", 0, 1, 1, 3000.0, 4000.0); /* after the transfer, not at 2 ms */
    check_span(events, "trace", 0, 2, 1, 3000.0, 5000.0);
    check_span(events, "transfer 'visibility'", 0, 2, 2, 3000.0, 6000.0);
    check_span(events, "accumulate", 0, 1, 1, 9000.0, 500.0);
    /* Frame 1 at 13 ms: "a"'s track ended at 9.5 ms, so it starts at the submission. */
    check_span(events, "trace", 1, 1, 1, 13000.0, 1000.0);
    check_span(events, "accumulate", 1, 1, 1, 14000.0, 1000.0);
    check_span(events, "composite", 1, 1, 1, 15000.0, 2000.0);
    check_span(events, "trace", 2, 2, 1, 20000.0, 1000.0);
    CHECK(event(events, "trace", 2, 1) == NULL);
    const cJSON *frame0 = NULL, *e;
    uint32_t names = 0;
    cJSON_ArrayForEach(e, events) {
        const char *name = cJSON_GetObjectItem(e, "name")->valuestring;
        if (!strcmp(name, "frame 0"))
            frame0 = e;
        if (!strcmp(name, "process_name")) {
            const char *label = cJSON_GetObjectItem(cJSON_GetObjectItem(e, "args"), "name")->valuestring;
            int pid = (int)cv_test_json_number(e, "pid");
            names += (pid == 1 && !strcmp(label, "a")) + (pid == 2 && !strcmp(label, "b\"q\\")) +
                     (pid == 3 && !strcmp(label, "host"));
        }
    }
    CHECK_EQ_INT(names, 3);
    CHECK(frame0 && cv_test_json_number(frame0, "pid") == 3 && cv_test_json_number(frame0, "ts") == 0.0 &&
          cv_test_json_number(frame0, "dur") == 12000.0);
    CHECK(frame0 && cv_test_json_number(cJSON_GetObjectItem(frame0, "args"), "sample") == 7);
    cJSON_Delete(root);

    cv_render_stats st = {
        .device_count = 1,
        .frames = 2,
        .devices = { { .columns = { 0, 96 }, .rays = 2880, .trace_ms = 1.0, .ms_per_column = 1.0 / 96 } },
        .rays_total = 2880 * 2,
        .reflection_rays = 1234,
        .devices_lost = 1,
        .transfer_bytes = 140,
        .transfer_ms = 9.0,
        .frame_ms = 8.25
    };
    CHECK_OK(cv_render_log_write_stats(log, &st, stats));
    root = cv_test_json_parse_file(stats);
    CHECK(root != NULL);
    const cJSON *frames = cJSON_GetObjectItem(root, "frames"), *summary = cJSON_GetObjectItem(root, "summary");
    CHECK_EQ_INT(cJSON_GetArraySize(frames), 3);
    const cJSON *fr0 = cJSON_GetArrayItem(frames, 0), *fr1 = cJSON_GetArrayItem(frames, 1);
    CHECK_EQ_INT(cv_test_json_number(fr0, "sample"), 7);
    CHECK(cv_test_json_number(fr0, "wall_ms") == 12.0);
    CHECK_EQ_INT(cv_test_json_number(fr1, "timings_cut"), 1);
    const cJSON *b = cJSON_GetArrayItem(cJSON_GetObjectItem(fr0, "devices"), 1);
    CHECK(b && !strcmp(cJSON_GetObjectItem(b, "label")->valuestring, "b\"q\\"));
    CHECK_EQ_INT(cv_test_json_number(cJSON_GetObjectItem(b, "columns"), "x"), 64);
    CHECK_EQ_INT(cv_test_json_number(b, "rays"), 960);
    const cJSON *vis = cJSON_GetArrayItem(cJSON_GetObjectItem(b, "transfers"), 0);
    CHECK(vis && cv_test_json_number(vis, "bytes") == 40 && cv_test_json_number(vis, "ms") == 6.0);
    CHECK_EQ_INT(cJSON_GetArraySize(cJSON_GetObjectItem(b, "passes")), 1);
    CHECK_EQ_INT(cv_test_json_number(summary, "rays_total"), 5760);
    CHECK_EQ_INT(cv_test_json_number(summary, "reflection_rays"), 1234);
    CHECK_EQ_INT(cv_test_json_number(summary, "devices_lost"), 1);
    CHECK_EQ_INT(cv_test_json_number(summary, "transfer_bytes"), 140);
    CHECK(cv_test_json_number(summary, "frame_ms_mean") == 8.25);
    const cJSON *p;
    uint32_t totals = 0;
    cJSON_ArrayForEach(p, cJSON_GetObjectItem(summary, "passes")) {
        const char *name = cJSON_GetObjectItem(p, "name")->valuestring;
        double n = cv_test_json_number(p, "instances"), ms = cv_test_json_number(p, "ms_total");
        totals += (!strcmp(name, "trace") && n == 4 && ms == 11.0) +
                  (!strcmp(name, "accumulate") && n == 2 && ms == 1.5) +
                  (!strcmp(name, "gbuffer") && n == 1 && ms == 2.0) +
                  (!strcmp(name, "composite") && n == 1 && ms == 2.0);
    }
    CHECK_EQ_INT(totals, 4);
    CHECK_EQ_INT(cJSON_GetArraySize(cJSON_GetObjectItem(summary, "passes")), 4); /* transfers are not passes */
    cJSON_Delete(root);

    /* A destination that cannot be written: the path in the message, no file. */
    char bad[160];
    snprintf(bad, sizeof bad, "%s/stats.json/x", dir);
    CHECK_RESULT(cv_render_log_write_stats(log, &st, bad), CV_ERROR_IO);
    CHECK(strstr(cv_last_error(), bad) != NULL);
    CHECK_RESULT(cv_render_log_create(NULL), CV_ERROR_INVALID_ARGUMENT);
    cv_render_log_destroy(log);
    cv_render_log_destroy(NULL);
    remove(stats);
    check_clocked(trace);
    remove(trace);
    CHECK(rmdir(dir) == 0);
    CHECK_NOTHING_LIVE();
    return check_report("render_log");
}
