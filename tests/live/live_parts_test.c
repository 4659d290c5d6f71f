/* The live's pure parts: the bandwidth rule (live_rate.h), the last-second
 * window of its stats (live_window.h) and the per-pass text (live_passes.h). */
#include <string.h>

#include "check.h"
#include "live_passes.h"
#include "live_rate.h"
#include "live_window.h"

static void rate_start(void) {
    live_rate r;
    live_rate_init(&r, 0, 0);
    CHECK_EQ_INT(r.quality, 85);
    live_rate_init(&r, 10, 0);
    CHECK_EQ_INT(r.quality, CV_LIVE_QUALITY_MIN);
    live_rate_init(&r, 100, 0);
    CHECK_EQ_INT(r.quality, CV_LIVE_QUALITY_MAX);
    /* No link reported: nothing adapts. */
    live_rate_init(&r, 80, 0);
    live_rate_jpeg_frame(&r, 10u << 20, 60);
    CHECK_EQ_INT(r.quality, 80);
    CHECK_EQ_INT(r.bitrate_kbps, 0);
}

/* 1 MB/s at 20 fps: a budget of 40000 bytes a frame. */
static void rate_jpeg(void) {
    live_rate r;
    live_rate_init(&r, 80, 0);
    live_rate_link(&r, 1e6);
    live_rate_jpeg_frame(&r, 40000, 20); /* exactly the budget: stays */
    CHECK_EQ_INT(r.quality, 80);
    live_rate_jpeg_frame(&r, 30000, 20); /* 75%: stays (no swing around the point of fit) */
    CHECK_EQ_INT(r.quality, 80);
    live_rate_jpeg_frame(&r, 41000, 20); /* 2.5% over: the smallest step down, 2 */
    CHECK_EQ_INT(r.quality, 78);
    live_rate_jpeg_frame(&r, 60000, 20); /* 50% over: 10 down */
    CHECK_EQ_INT(r.quality, 68);
    live_rate_jpeg_frame(&r, 400000, 20); /* ten times: at most 20 down */
    CHECK_EQ_INT(r.quality, 48);
    live_rate_jpeg_frame(&r, 400000, 20);
    CHECK_EQ_INT(r.quality, CV_LIVE_QUALITY_MIN);
    live_rate_jpeg_frame(&r, 20000, 20); /* under 60%: one up a frame */
    CHECK_EQ_INT(r.quality, CV_LIVE_QUALITY_MIN + 1);
    for (int i = 0; i < 100; i++)
        live_rate_jpeg_frame(&r, 1000, 20);
    CHECK_EQ_INT(r.quality, CV_LIVE_QUALITY_MAX);
    /* A still view (no frames rendered): the budget is figured at 10 fps, 80000 bytes. */
    live_rate_jpeg_frame(&r, 79000, 0);
    CHECK_EQ_INT(r.quality, CV_LIVE_QUALITY_MAX);
    live_rate_jpeg_frame(&r, 81000, 0);
    CHECK_EQ_INT(r.quality, CV_LIVE_QUALITY_MAX - 2);
}

static void rate_h264(void) {
    live_rate r;
    live_rate_init(&r, 0, 0);
    live_rate_link(&r, 12.5e6); /* 100 Mbit/s: 80 Mbit/s */
    CHECK_EQ_INT(r.bitrate_kbps, 80000);
    live_rate_link(&r, 1000); /* a trickle: the floor */
    CHECK_EQ_INT(r.bitrate_kbps, CV_LIVE_MIN_BITRATE_KBPS);
    live_rate_link(&r, -5); /* nonsense is ignored */
    CHECK_EQ_INT(r.bitrate_kbps, CV_LIVE_MIN_BITRATE_KBPS);
    CHECK(r.link_bytes_per_s == 1000);
    live_rate_init(&r, 0, 5000); /* a starting bitrate is the cap */
    live_rate_link(&r, 12.5e6);
    CHECK_EQ_INT(r.bitrate_kbps, 5000);
    live_rate_link(&r, 250e3); /* 2 Mbit/s: 1600 kbit/s */
    CHECK_EQ_INT(r.bitrate_kbps, 1600);
}

static void window(void) {
    static live_window w; /* 16 kB: off the stack */
    double mean[3];
    CHECK_EQ_INT(live_window_last_second(&w, 5000, mean), 0);
    CHECK(mean[0] == 0 && mean[1] == 0 && mean[2] == 0);
    CHECK(!live_window_newest(&w, mean));
    live_window_add(&w, 3000, (double[3]){ 100, 100, 100 }); /* more than a second before 5000 */
    live_window_add(&w, 4500, (double[3]){ 1, 2, 3 });
    live_window_add(&w, 4900, (double[3]){ 3, 4, 5 });
    CHECK_EQ_INT(live_window_last_second(&w, 5000, mean), 2);
    CHECK(mean[0] == 2 && mean[1] == 3 && mean[2] == 4);
    CHECK_EQ_INT(live_window_last_second(&w, 5600, mean), 1);
    CHECK(mean[0] == 3);
    CHECK_EQ_INT(live_window_last_second(&w, 9000, mean), 0); /* at rest: none in the second */
    CHECK(live_window_newest(&w, mean) && mean[0] == 3 && mean[1] == 4 && mean[2] == 5);
    /* More events than it keeps: the rate reads as the most it keeps. */
    for (uint32_t i = 0; i < 2 * CV_LIVE_WINDOW_EVENTS; i++)
        live_window_add(&w, 6000 + i * 0.1, NULL);
    CHECK_EQ_INT(live_window_last_second(&w, 6000 + 2 * CV_LIVE_WINDOW_EVENTS * 0.1, NULL), CV_LIVE_WINDOW_EVENTS);
}

static void passes(void) {
    cv_graph_timing t[3] = { { .name = "gbuffer", .device = 0, .ms = 1.2 },
                             { .name = "trace", .device = 1, .ms = 3.4 },
                             { .name = "transfer 'visibility'", .device = 1, .ms = 0.25 } };
    cv_render_frame_info info = { .timings = t, .timing_count = 3 };
    char out[2048];
    live_passes_format(&info, out, sizeof(out));
    CHECK(strcmp(out, "gbuffer dev0 1.20 ms\ntrace dev1 3.40 ms\ntransfer 'visibility' dev1 0.25 ms\n") == 0);
    /* Too small for the second line: it and the third are left out whole, and said. */
    char small[40];
    live_passes_format(&info, small, sizeof(small));
    CHECK(strcmp(small, "gbuffer dev0 1.20 ms\n+2 more\n") == 0);
    char tiny[24];
    live_passes_format(&info, tiny, sizeof(tiny));
    CHECK(strcmp(tiny, "gbuffer dev0 1.20 ms\n") == 0);
    info.timings_cut = 5;
    live_passes_format(&info, out, sizeof(out));
    CHECK(strstr(out, "\n+5 more\n") != NULL);
}

int main(void) {
    rate_start();
    rate_jpeg();
    rate_h264();
    window();
    passes();
    return check_report("live_parts");
}
