/* bench_live: the live view's end-to-end figures (issue 25's goals) beside the
 * raw-planes path it replaces, measured in the same run on the same renderer.
 *
 * Corvid: a cv_live (corvid/live.h) over the renderer on local devices
 * (--gpus N virtual GPUs) or on corvid-nodes (--nodes; optionally through an
 * in-process relay that delays and caps the link, tools/relay/tcp_relay.h),
 * frames encoded on the primary's machine (JPEG or H.264) and consumed by a
 * synthetic viewer that acts as corvid-view's page: it holds at most
 * VIEWER_CREDITS frames in flight (the page's rule, apps/view_session.c:
 * two credits at the start, one back per frame displayed; mirrored here, it
 * is not factored out of corvid-view), decodes each with cv_decoder, and every
 * --input-every frames turns the camera (an orbit step through cv_live_update
 * with a new seq). Motion-to-photon: from that cv_live_update call to the end
 * of decoding the first frame whose input_seq >= the seq.
 *
 * Per frame: render = the host time of cv_renderer_step (it submits; the GPU's
 * work is waited for by the read), read = the device read of the display
 * (the wait for the GPU included), encode, transfer = the frame reader's call
 * less read and encode (for a node device: the read's round trip on the link
 * less the node's time; the node's clock is not ours, so frame arrival minus
 * encode end cannot be taken directly), decode.
 *
 * Peer: the same renderer, the same input, each frame cv_renderer_step then
 * cv_renderer_read_output (the float planes back through the same link), as
 * corvid-render's frames come back today. */
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bench_util.h"
#include "corvid/bvh.h"
#include "corvid/clock.h"
#include "corvid/frame_codec.h"
#include "corvid/live.h"
#include "corvid/live_trace.h"
#include "corvid/proxy.h"
#include "corvid/renderer.h"
#include "corvid/scene.h"
#include "corvid/scene_procedural.h"
#include "corvid/vulkan.h"
#include "env_vulkan.h"
#include "live_bench_viewer.h"
#include "tcp_relay.h"

#define MAX_NODES 8

typedef struct options {
    uint32_t width, height;
    double seconds;
    bool jpeg, h264, raw;
    const char *nodes;
    uint32_t relay_delay_ms;
    double relay_rate_mbit;
    uint32_t input_every;
    const char *trace;
    bool validation;
} options;

static void usage(FILE *f) {
    fprintf(f,
            "usage: bench_live [options]\n"
            "The live view end to end (encoded frames, a synthetic viewer that decodes them and turns the\n"
            "camera) beside the raw-planes path it replaces (step + read_output of the float planes).\n"
            "  --width W --height H   image size (default 640x360)\n"
            "  --seconds S            per codec and for the peer (default 5; the first 20%%, at most 1 s, warm up)\n"
            "  --codec jpeg|h264|both (default both)\n"
            "  --no-raw               leave the raw-planes peer out\n"
            "  --gpus N               local virtual GPUs (default 1); --adapters LIST, --virtual-gpus N as "
            "corvid-render\n"
            "  --nodes H:P[,H:P...]   render on corvid-nodes' devices (device 0 of each) instead\n"
            "  --relay-delay-ms MS    an in-process relay to each node adding MS one way (2*MS round trip)\n"
            "  --relay-rate-mbit M    the relay caps each direction at M Mbit/s\n"
            "  --input-every N        an orbit step every N displayed frames (default 5)\n"
            "  --trace FILE           Chrome/Perfetto trace of the live runs (corvid/live_trace.h; + decode)\n"
            "  --validation           the Vulkan validation layer on local devices\n"
            "  --quick                160x90, 1 s per run\n");
}

static bool number(const char *s, double lo, double hi, double *out) {
    char *end;
    double v = strtod(s, &end);
    if (*end || !(v >= lo && v <= hi))
        return false;
    *out = v;
    return true;
}

/* One option with its value at argv[*i + 1]: 0 = taken, 2 = bad value, 1 = not this one. */
static int value_option(const char *a, const char *v, options *o) {
    double x;
    if (!strcmp(a, "--width") || !strcmp(a, "--height")) {
        if (!number(v, 2, 8192, &x))
            return 2;
        *(a[2] == 'w' ? &o->width : &o->height) = (uint32_t)x;
    } else if (!strcmp(a, "--seconds")) {
        if (!number(v, 0.5, 600, &o->seconds))
            return 2;
    } else if (!strcmp(a, "--codec")) {
        o->jpeg = !strcmp(v, "jpeg") || !strcmp(v, "both");
        o->h264 = !strcmp(v, "h264") || !strcmp(v, "both");
        if (!o->jpeg && !o->h264)
            return 2;
    } else if (!strcmp(a, "--nodes")) {
        o->nodes = v;
    } else if (!strcmp(a, "--relay-delay-ms")) {
        if (!number(v, 0, 10000, &x))
            return 2;
        o->relay_delay_ms = (uint32_t)x;
    } else if (!strcmp(a, "--relay-rate-mbit")) {
        if (!number(v, 0.01, 1e6, &o->relay_rate_mbit))
            return 2;
    } else if (!strcmp(a, "--input-every")) {
        if (!number(v, 1, 1e6, &x))
            return 2;
        o->input_every = (uint32_t)x;
    } else if (!strcmp(a, "--trace")) {
        o->trace = v;
    } else {
        return 1;
    }
    return 0;
}

static int parse_options(int argc, char **argv, options *o) {
    *o = (options){
        .width = 640, .height = 360, .seconds = 5, .jpeg = true, .h264 = true, .raw = true, .input_every = 5
    };
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        int r = i + 1 < argc ? value_option(a, argv[i + 1], o) : 1;
        if (r == 2) {
            fprintf(stderr, "bench_live: %s %s: bad value (see --help)\n", a, argv[i + 1]);
            return 2;
        }
        if (r == 0) {
            i++;
        } else if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            usage(stdout);
            return 0;
        } else if (!strcmp(a, "--no-raw")) {
            o->raw = false;
        } else if (!strcmp(a, "--validation")) {
            o->validation = true;
        } else if (!strcmp(a, "--quick")) {
            o->width = 160, o->height = 90, o->seconds = 1;
        } else {
            fprintf(stderr, "bench_live: unknown option '%s' (see --help)\n", a);
            return 2;
        }
    }
    if (o->width % 2 || o->height % 2) {
        fprintf(stderr, "bench_live: %ux%u: H.264 needs an even width and height\n", o->width, o->height);
        return 2;
    }
    return -1;
}

/* The devices: local (the env_vulkan choice) or device 0 of each node, through a relay of its own when
 * one is asked for. */
typedef struct devices {
    cv_context *ctx;
    cv_device *dev[CV_MAX_DEVICES];
    uint32_t count;
    tcp_relay *relays[MAX_NODES];
    uint32_t relay_count;
} devices;

static cv_result open_node(const options *o, devices *d, const char *endpoint) {
    char relayed[64], host[256];
    unsigned port = 0;
    if (o->relay_delay_ms || o->relay_rate_mbit) {
        const char *colon = strrchr(endpoint, ':');
        if (!colon || sscanf(colon + 1, "%u", &port) != 1 || port > 65535 ||
            (size_t)(colon - endpoint) >= sizeof host)
            return cv_error(CV_ERROR_INVALID_ARGUMENT, "--nodes %s: give host:port", endpoint);
        snprintf(host, sizeof host, "%.*s", (int)(colon - endpoint), endpoint);
        tcp_relay_desc rd = { .target_host = host,
                              .target_port = (uint16_t)port,
                              .delay_us = o->relay_delay_ms * 1000u,
                              .rate_bytes_per_s = (uint64_t)(o->relay_rate_mbit * 1e6 / 8.0) };
        cv_result r = tcp_relay_create(&rd, &d->relays[d->relay_count]);
        if (r != CV_OK)
            return r;
        snprintf(relayed, sizeof relayed, "127.0.0.1:%d", tcp_relay_port(d->relays[d->relay_count++]));
        endpoint = relayed;
    }
    cv_device_desc desc = { .endpoint = endpoint };
    snprintf(desc.label, sizeof desc.label, "node%u", d->count);
    cv_result r = cv_device_create(d->ctx, cv_proxy_backend(), &desc, &d->dev[d->count]);
    if (r == CV_OK)
        d->count++;
    return r;
}

static cv_result open_devices(const options *o, const cv_vulkan_gpu_config *gpu, devices *d) {
    cv_result r = cv_context_create(NULL, &d->ctx);
    if (r != CV_OK || !o->nodes) {
        cv_vulkan_gpu_table table;
        if (r == CV_OK)
            r = cv_vulkan_gpu_table_build(gpu, &table);
        if (r == CV_OK && table.count > CV_MAX_DEVICES)
            r = cv_error(CV_ERROR_LIMIT_EXCEEDED, "%u devices; the renderer takes %u", table.count, CV_MAX_DEVICES);
        if (r == CV_OK)
            r = cv_vulkan_create_devices(d->ctx, &table, o->validation, d->dev);
        d->count = r == CV_OK ? table.count : 0;
        return r;
    }
    char list[1024];
    snprintf(list, sizeof list, "%s", o->nodes);
    char *save = NULL;
    for (char *e = strtok_r(list, ",", &save); e && r == CV_OK; e = strtok_r(NULL, ",", &save))
        r = d->count < MAX_NODES ? open_node(o, d, e)
                                 : cv_error(CV_ERROR_LIMIT_EXCEEDED, "--nodes: at most %d", MAX_NODES);
    return r;
}

static void close_devices(devices *d) {
    for (uint32_t i = 0; i < d->count; i++)
        cv_device_destroy(d->dev[i]);
    for (uint32_t i = 0; i < d->relay_count; i++)
        tcp_relay_stop(d->relays[i]);
    cv_context_destroy(d->ctx);
}

/* The peer: step + read_output per frame, the same orbit input; its row. */
static cv_result raw_run(const options *o, cv_renderer *r, const cv_scene *scene, viewer_figures *fig) {
    viewer_camera cam;
    cv_render_settings s = { .width = o->width, .height = o->height };
    viewer_camera_init(&cam, &s, scene);
    double start = cv_now_ms(), warm = viewer_warmup_ms(o->seconds);
    viewer_figures_init(fig, "raw planes");
    fig->start_ms = start + warm;
    for (uint32_t frame = 0;; frame++) {
        double input_ms = 0;
        if (frame % o->input_every == 0) {
            viewer_camera_step(&cam, &s);
            input_ms = cv_now_ms();
        }
        cv_render_step step;
        cv_render_output out = { 0 };
        double t0 = cv_now_ms();
        cv_result res = cv_renderer_step(r, &s, &step);
        double t1 = cv_now_ms();
        if (res == CV_OK)
            res = cv_renderer_read_output(r, &out);
        double t2 = cv_now_ms();
        size_t bytes = viewer_output_bytes(&out);
        cv_render_output_free(&out);
        if (res != CV_OK)
            return res;
        if (t0 - start >= warm)
            viewer_figures_add(
                fig, &(viewer_frame){
                         .arrive_ms = t2, .shown_ms = t2, .bytes = bytes, .render_ms = t1 - t0, .read_ms = t2 - t1 });
        if (input_ms && t0 - start >= warm)
            viewer_figures_m2p(fig, t2 - input_ms);
        fig->end_ms = t2;
        if (t2 - start >= o->seconds * 1e3 && fig->frames >= 1)
            return CV_OK;
    }
}

static void print_header(const options *o, const devices *d) {
    char machine[256];
    bench_machine(machine, sizeof machine);
    printf("bench_live on %s\n", machine);
    printf("%ux%u, %.1f s a run, an orbit step every %u displayed frames, %u device(s): ", o->width, o->height,
           o->seconds, o->input_every, d->count);
    for (uint32_t i = 0; i < d->count; i++)
        printf("%s%s (%s)", i ? ", " : "", cv_device_label(d->dev[i]), cv_device_get_info(d->dev[i])->name);
    printf("\n");
    if (d->relay_count)
        printf("through in-process relays: %u ms one way (%u ms round trip), %s%.0f Mbit/s\n", o->relay_delay_ms,
               2 * o->relay_delay_ms, o->relay_rate_mbit ? "" : "uncapped ", o->relay_rate_mbit);
    printf(
        "render = host time of cv_renderer_step (submission); read = device read (waits for the GPU);\n"
        "transfer = the reader's call less read and encode (a node: the round trip on the link less the node's\n"
        "time); m2p = cv_live_update to the end of decoding the first frame that reflects it.\n");
    viewer_figures_print_header();
}

/* One step waited for: pipelines, the scene's upload and the first frame's resources before any run. */
static cv_result warm_up(const options *o, cv_device *primary, cv_renderer *r) {
    cv_render_step step;
    cv_result res = cv_renderer_step(r, &(cv_render_settings){ .width = o->width, .height = o->height }, &step);
    return res == CV_OK ? cv_device_wait(primary, step.ticket, UINT64_MAX) : res;
}

static int run(const options *o, devices *d, const cv_scene *scene, cv_renderer *r, cv_live_trace *trace) {
    print_header(o, d);
    if (warm_up(o, d->dev[0], r) != CV_OK) {
        fprintf(stderr, "bench_live: warm-up step: %s\n", cv_last_error());
        return 1;
    }
    cv_codec codecs[2];
    uint32_t n = 0;
    if (o->h264)
        codecs[n++] = CV_CODEC_H264;
    if (o->jpeg)
        codecs[n++] = CV_CODEC_JPEG;
    viewer_desc vd = { .renderer = r,
                       .primary = d->dev[0],
                       .scene = scene,
                       .width = o->width,
                       .height = o->height,
                       .seconds = o->seconds,
                       .input_every = o->input_every,
                       .trace = trace };
    for (uint32_t i = 0; i < n; i++) {
        vd.codec = codecs[i];
        viewer_figures fig;
        if (viewer_run(&vd, &fig) != CV_OK) {
            fprintf(stderr, "bench_live: %s: %s\n", cv_codec_name(codecs[i]), cv_last_error());
            return 1;
        }
        viewer_figures_print(&fig);
    }
    if (o->raw) {
        viewer_figures fig;
        if (raw_run(o, r, scene, &fig) != CV_OK) {
            fprintf(stderr, "bench_live: raw planes: %s\n", cv_last_error());
            return 1;
        }
        viewer_figures_print(&fig);
    }
    return 0;
}

int main(int argc, char **argv) {
    cv_vulkan_gpu_config gpu = { .total = 1 };
    if (cv_env_vulkan_gpu_args(&argc, argv, &gpu) != CV_OK || cv_env_vulkan_gpu_config(&gpu) != CV_OK) {
        fprintf(stderr, "bench_live: %s\n", cv_last_error());
        return 2;
    }
    if (gpu.total && !gpu.virtual_per_adapter)
        gpu.virtual_per_adapter = 1;
    options o;
    int rc = parse_options(argc, argv, &o);
    if (rc >= 0)
        return rc;
    cv_scene *scene = NULL;
    cv_bvh *bvh = NULL;
    cv_renderer *r = NULL;
    cv_live_trace *trace = NULL;
    devices d = { 0 };
    cv_result res = cv_scene_make_room(1, &scene);
    if (res == CV_OK)
        res = cv_bvh_build_flat(scene, NULL, &bvh);
    if (res == CV_OK)
        res = open_devices(&o, &gpu, &d);
    if (res == CV_OK)
        res = cv_renderer_create(d.dev, d.count, scene, bvh, &r);
    if (res == CV_OK && o.trace)
        res = cv_live_trace_create(&trace);
    rc = res == CV_OK ? run(&o, &d, scene, r, trace) : 1;
    if (res != CV_OK)
        fprintf(stderr, "bench_live: set-up: %s\n", cv_last_error());
    if (rc == 0 && trace && cv_live_trace_write(trace, o.trace) != CV_OK) {
        fprintf(stderr, "bench_live: %s\n", cv_last_error());
        rc = 1;
    }
    cv_live_trace_destroy(trace);
    cv_renderer_destroy(r);
    close_devices(&d);
    cv_bvh_destroy(bvh);
    cv_scene_destroy(scene);
    if (o.validation && cv_vulkan_validation_message_count() != 0) {
        fprintf(stderr, "bench_live: %u validation messages\n", cv_vulkan_validation_message_count());
        return 1;
    }
    return rc;
}
