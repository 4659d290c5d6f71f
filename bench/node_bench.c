/* bench_node: the renderer and data paths through a corvid-node, each next to
 * a peer measured in the same run. Nodes run in this process on loopback
 * (cv_node_start, as the tests' scratch node does); the client reaches them
 * through the proxy backend.
 *
 *  1. frame     The same render (procedural room, default settings but size and
 *               frames) on one local lavapipe device, against the same on one
 *               lavapipe device of a node. ms per frame is the renderer's own
 *               frame_ms of a warm render (the renderer's second render call and
 *               later); the images must be bit-identical.
 *  2. stream    cv_device_read_buffer of a large buffer of a mock-backed node's
 *               device, against the rpc layer alone: a server handler that sends
 *               the same bytes as 1 MiB messages to a client that receives them.
 *  3. upload    cv_device_write_buffer of fresh random bytes (content-addressed:
 *               hashed, queried, sent in chunks) in a first session, then the
 *               same bytes in a second session (skipped: the node has them);
 *               peers: the same bytes up the rpc layer as 1 MiB messages, and
 *               SHA-256 of them alone (the floor of the cached path).
 *  4. latency   The renderer (small image) through a delaying TCP relay
 *               (tcp_relay.h) adding 0, 5, 20 and 50 ms of round-trip time,
 *               against loopback without the relay; with the proxy's
 *               round_trips per frame and the serial round trips per frame that
 *               the added time implies.
 * Nothing here fails on timing; it exits 1 only when results are wrong (images
 * that differ, bytes read back that differ) or a step fails. */
#include <ftw.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "bench_util.h"
#include "corvid/backend.h"
#include "corvid/corvid.h"
#include "corvid/proxy.h"
#include "corvid/renderer.h"
#include "corvid/rpc.h"
#include "corvid/scene_procedural.h"
#include "corvid/sha256.h"
#include "corvid/vulkan.h"
#include "node.h"
#include "tcp_relay.h"

#define MAX_ROUNDS 16
#define MAX_RTTS 8
#define CHUNK (1u << 20)

typedef struct options {
    uint32_t width, height, frames, rounds;
    uint32_t lat_width, lat_height, lat_frames;
    uint32_t rtts[MAX_RTTS], rtt_count;
    uint64_t read_bytes, upload_bytes;
    uint32_t reads, uploads;
    bool frame, stream, upload, latency;
    const char *adapter;
} options;

static void usage(FILE *f) {
    fprintf(f,
            "usage: bench_node [options]\n"
            "Renders and moves data through a corvid-node started in this process on loopback,\n"
            "next to the same work done locally or through the rpc layer alone.\n"
            "  --size WxH          frame-time image (default 640x360)\n"
            "  --frames N          frames per render (default 4)\n"
            "  --rounds N          measured renders per side after one warm-up (default 2, at most %d)\n"
            "  --latency-size WxH  latency image (default 320x180)\n"
            "  --latency-frames N  frames per latency render (default 4)\n"
            "  --rtts LIST         added round-trip times in ms (default 0,5,20,50)\n"
            "  --read-mib N        buffer read back through the node (default 64, at most 128)\n"
            "  --reads N           measured reads per contender (default 5)\n"
            "  --upload-mib N      buffer uploaded (default 64, at most 128)\n"
            "  --uploads N         upload rounds, each with fresh bytes (default 3)\n"
            "  --only LIST         subset of frame,stream,upload,latency (default: all)\n"
            "  --adapter NAME      Vulkan adapter, local and on the node (default llvmpipe)\n"
            "  --quick             smoke run: 160x90, 2 frames, 16 MiB, rtts 0,20\n"
            "  --help              this text\n",
            MAX_ROUNDS);
}

static bool parse_wh(const char *v, uint32_t *w, uint32_t *h) {
    char tail;
    return sscanf(v, "%ux%u%c", w, h, &tail) == 2 && *w && *h && *w <= 4096 && *h <= 4096;
}

static bool parse_rtts(const char *v, options *o) {
    o->rtt_count = 0;
    for (const char *p = v; *p;) {
        char *end;
        unsigned long ms = strtoul(p, &end, 10);
        if (end == p || ms > 1000 || o->rtt_count == MAX_RTTS)
            return false;
        o->rtts[o->rtt_count++] = (uint32_t)ms;
        if (*end && *end != ',')
            return false;
        p = *end ? end + 1 : end;
    }
    return o->rtt_count > 0;
}

static bool parse(int argc, char **argv, options *o) {
    *o = (options){ .width = 640,
                    .height = 360,
                    .frames = 4,
                    .rounds = 2,
                    .lat_width = 320,
                    .lat_height = 180,
                    .lat_frames = 4,
                    .rtts = { 0, 5, 20, 50 },
                    .rtt_count = 4,
                    .read_bytes = 64u << 20,
                    .upload_bytes = 64u << 20,
                    .reads = 5,
                    .uploads = 3,
                    .frame = true,
                    .stream = true,
                    .upload = true,
                    .latency = true,
                    .adapter = "llvmpipe" };
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (strcmp(a, "--help") == 0 || strcmp(a, "-h") == 0) {
            usage(stdout);
            exit(0);
        } else if (strcmp(a, "--quick") == 0) {
            o->width = o->lat_width = 160;
            o->height = o->lat_height = 90;
            o->frames = o->lat_frames = 2;
            o->rounds = 1;
            o->read_bytes = o->upload_bytes = 16u << 20;
            o->reads = 2;
            o->uploads = 1;
            o->rtts[0] = 0;
            o->rtts[1] = 20;
            o->rtt_count = 2;
            continue;
        }
        if (!v) {
            fprintf(stderr, "bench_node: %s needs a value\n", a);
            return false;
        }
        i++;
        bool ok = true;
        unsigned long n = strtoul(v, NULL, 10);
        if (strcmp(a, "--size") == 0) {
            ok = parse_wh(v, &o->width, &o->height);
        } else if (strcmp(a, "--latency-size") == 0) {
            ok = parse_wh(v, &o->lat_width, &o->lat_height);
        } else if (strcmp(a, "--frames") == 0) {
            o->frames = (uint32_t)n;
            ok = n >= 1 && n <= 64;
        } else if (strcmp(a, "--latency-frames") == 0) {
            o->lat_frames = (uint32_t)n;
            ok = n >= 1 && n <= 64;
        } else if (strcmp(a, "--rounds") == 0) {
            o->rounds = (uint32_t)n;
            ok = n >= 1 && n <= MAX_ROUNDS;
        } else if (strcmp(a, "--rtts") == 0) {
            ok = parse_rtts(v, o);
        } else if (strcmp(a, "--read-mib") == 0) {
            o->read_bytes = (uint64_t)n << 20;
            ok = n >= 1 && n <= 128;
        } else if (strcmp(a, "--reads") == 0) {
            o->reads = (uint32_t)n;
            ok = n >= 1 && n <= 100;
        } else if (strcmp(a, "--upload-mib") == 0) {
            o->upload_bytes = (uint64_t)n << 20;
            ok = n >= 1 && n <= 128;
        } else if (strcmp(a, "--uploads") == 0) {
            o->uploads = (uint32_t)n;
            ok = n >= 1 && n <= 20;
        } else if (strcmp(a, "--only") == 0) {
            o->frame = strstr(v, "frame") != NULL;
            o->stream = strstr(v, "stream") != NULL;
            o->upload = strstr(v, "upload") != NULL;
            o->latency = strstr(v, "latency") != NULL;
            ok = o->frame || o->stream || o->upload || o->latency;
        } else if (strcmp(a, "--adapter") == 0) {
            o->adapter = v;
        } else {
            fprintf(stderr, "bench_node: unknown option %s (see --help)\n", a);
            return false;
        }
        if (!ok) {
            fprintf(stderr, "bench_node: bad value '%s' for %s\n", v, a);
            return false;
        }
    }
    return true;
}

/* ---- small helpers -------------------------------------------------------------- */

static int cmp_double(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static double median(const double *v, uint32_t n) {
    double s[64];
    if (n == 0)
        return 0.0;
    if (n > 64)
        n = 64;
    memcpy(s, v, n * sizeof(double));
    qsort(s, n, sizeof(double), cmp_double);
    return n % 2 ? s[n / 2] : 0.5 * (s[n / 2 - 1] + s[n / 2]);
}

static void fill_random(uint8_t *p, uint64_t bytes, uint64_t seed) {
    uint64_t x = seed * 0x9E3779B97F4A7C15ull + 1;
    for (uint64_t i = 0; i < bytes; i += 8) {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        memcpy(p + i, &x, bytes - i < 8 ? bytes - i : 8);
    }
}

static bool fail(const char *what) {
    fprintf(stderr, "bench_node: %s: %s\n", what, cv_last_error());
    return false;
}

/* ---- a node in this process ------------------------------------------------------- */

typedef struct bench_node {
    cv_node *node;
    char endpoint[64];
    char cache_dir[64];
    cv_node_device_spec device;
    cv_node_config config;
} bench_node;

static int remove_entry(const char *path, const struct stat *st, int flag, struct FTW *ftw) {
    (void)st, (void)flag, (void)ftw;
    return remove(path);
}

static bool node_start(bench_node *n, const cv_backend *backend, const char *adapter) {
    memset(n, 0, sizeof(*n));
    snprintf(n->cache_dir, sizeof(n->cache_dir), "/tmp/corvid-bench-node-XXXXXX");
    if (!mkdtemp(n->cache_dir)) {
        fprintf(stderr, "bench_node: cannot make a cache directory\n");
        return false;
    }
    n->device.backend = backend;
    snprintf(n->device.adapter, sizeof(n->device.adapter), "%s", adapter);
    snprintf(n->device.label, sizeof(n->device.label), "%s0", backend->name);
    n->config = (cv_node_config){ .listen = "127.0.0.1:0",
                                  .name = "bench",
                                  .devices = &n->device,
                                  .device_count = 1,
                                  .cache_dir = n->cache_dir,
                                  .cache_bytes = 1ull << 30 };
    if (cv_node_start(&n->config, &n->node) != CV_OK) {
        nftw(n->cache_dir, remove_entry, 16, FTW_DEPTH | FTW_PHYS);
        return fail("node start");
    }
    snprintf(n->endpoint, sizeof(n->endpoint), "127.0.0.1:%d", cv_node_port(n->node));
    return true;
}

static void node_stop(bench_node *n) {
    if (!n->node)
        return;
    cv_node_stop(n->node, 5000);
    n->node = NULL;
    nftw(n->cache_dir, remove_entry, 16, FTW_DEPTH | FTW_PHYS);
}

/* ---- 1 and 4: the renderer ---------------------------------------------------------- */

typedef struct render_side {
    cv_context *ctx;
    cv_device *dev;
    cv_renderer *renderer;
    double create_ms;
    uint64_t create_round_trips;
} render_side;

static bool side_open(render_side *s, const cv_backend *backend, const cv_device_desc *desc, const cv_scene *scene,
                      const cv_bvh *bvh) {
    memset(s, 0, sizeof(*s));
    double t0 = bench_now();
    if (cv_context_create(NULL, &s->ctx) != CV_OK)
        return fail("context");
    if (cv_device_create(s->ctx, backend, desc, &s->dev) != CV_OK)
        return fail(desc->endpoint ? desc->endpoint : "local device");
    if (cv_renderer_create(&s->dev, 1, scene, bvh, &s->renderer) != CV_OK)
        return fail("renderer");
    s->create_ms = (bench_now() - t0) * 1e3;
    cv_proxy_stats ps;
    if (cv_proxy_get_stats(s->dev, &ps) == CV_OK)
        s->create_round_trips = ps.round_trips;
    return true;
}

static void side_close(render_side *s) {
    cv_renderer_destroy(s->renderer);
    if (s->ctx)
        cv_context_destroy(s->ctx);
    memset(s, 0, sizeof(*s));
}

typedef struct render_run {
    double frame_ms, call_ms;
    uint64_t round_trips;      /* over the whole render call (proxy devices) */
    uint64_t loop_round_trips; /* ... of them in the frame loop (start to the last frame's progress call) */
} render_run;

/* The renderer's progress callback: proxy stats after each frame. */
typedef struct progress_probe {
    cv_device *dev;
    uint64_t last_round_trips;
} progress_probe;

static void on_progress(uint32_t frame, uint32_t frames, void *user) {
    progress_probe *p = user;
    cv_proxy_stats ps;
    if (frame == frames && cv_proxy_get_stats(p->dev, &ps) == CV_OK)
        p->last_round_trips = ps.round_trips;
}

static bool render_once(render_side *s, uint32_t w, uint32_t h, uint32_t frames, cv_render_output *out,
                        render_run *run) {
    cv_render_settings set = { .width = w, .height = h, .frames = frames };
    cv_render_stats st;
    cv_proxy_stats before = { 0 }, after = { 0 };
    bool proxy = cv_proxy_get_stats(s->dev, &before) == CV_OK;
    progress_probe probe = { .dev = s->dev, .last_round_trips = before.round_trips };
    double t0 = bench_now();
    if (cv_renderer_render(s->renderer, &set, out, &st, on_progress, &probe) != CV_OK)
        return fail("render");
    run->call_ms = (bench_now() - t0) * 1e3;
    run->frame_ms = st.frame_ms;
    if (proxy)
        cv_proxy_get_stats(s->dev, &after);
    run->round_trips = after.round_trips - before.round_trips;
    run->loop_round_trips = proxy ? probe.last_round_trips - before.round_trips : 0;
    return true;
}

static bool same_image(const cv_render_output *a, const cv_render_output *b) {
    size_t bytes = (size_t)a->width * a->height * 4 * sizeof(float);
    return a->width == b->width && a->height == b->height && memcmp(a->radiance, b->radiance, bytes) == 0 &&
           memcmp(a->visibility, b->visibility, bytes) == 0;
}

typedef struct frame_result {
    bool done;
    double local_ms, remote_ms, local_call_ms, remote_call_ms;
    double local_lo, local_hi, remote_lo, remote_hi;
    double rt_per_frame, rt_per_call;
    bool identical;
} frame_result;

static void range_of(const double *v, uint32_t n, double *lo, double *hi) {
    *lo = *hi = v[0];
    for (uint32_t i = 1; i < n; i++) {
        *lo = v[i] < *lo ? v[i] : *lo;
        *hi = v[i] > *hi ? v[i] : *hi;
    }
}

static bool bench_frame(const options *o, const bench_node *vk, const cv_scene *scene, const cv_bvh *bvh,
                        frame_result *res) {
    printf(
        "\n1. frame time: %ux%u, %u frames, default settings otherwise; 1 warm-up render, then %u rounds "
        "(local, remote)\n",
        o->width, o->height, o->frames, o->rounds);
    render_side local, remote;
    bool ok = side_open(&local, cv_vulkan_backend(), &(cv_device_desc){ .adapter = o->adapter, .label = "local" },
                        scene, bvh) &&
              side_open(&remote, cv_proxy_backend(), &(cv_device_desc){ .endpoint = vk->endpoint, .label = "remote" },
                        scene, bvh);
    double lf[MAX_ROUNDS], rf[MAX_ROUNDS], lc[MAX_ROUNDS], rc[MAX_ROUNDS];
    uint64_t rts = 0, loop_rts = 0;
    res->identical = true;
    if (ok)
        printf("   create: local %.0f ms, remote %.0f ms (%llu round trips)\n", local.create_ms, remote.create_ms,
               (unsigned long long)remote.create_round_trips);
    for (uint32_t round = 0; ok && round <= o->rounds; round++) {
        cv_render_output a = { 0 }, b = { 0 };
        render_run ra, rb;
        ok = render_once(&local, o->width, o->height, o->frames, &a, &ra) &&
             render_once(&remote, o->width, o->height, o->frames, &b, &rb);
        if (ok && !same_image(&a, &b))
            res->identical = false;
        cv_render_output_free(&a);
        cv_render_output_free(&b);
        if (!ok)
            break;
        printf(
            "   %-9s local %8.1f ms/frame (render call %7.1f ms) | remote %8.1f ms/frame (render call %7.1f "
            "ms, %llu round trips) | %.3fx\n",
            round ? "measured" : "warm-up", ra.frame_ms, ra.call_ms, rb.frame_ms, rb.call_ms,
            (unsigned long long)rb.round_trips, rb.frame_ms / ra.frame_ms);
        if (round == 0)
            continue;
        lf[round - 1] = ra.frame_ms;
        rf[round - 1] = rb.frame_ms;
        lc[round - 1] = ra.call_ms;
        rc[round - 1] = rb.call_ms;
        rts += rb.round_trips;
        loop_rts += rb.loop_round_trips;
    }
    side_close(&remote);
    side_close(&local);
    if (!ok)
        return false;
    res->done = true;
    res->local_ms = median(lf, o->rounds);
    res->remote_ms = median(rf, o->rounds);
    res->local_call_ms = median(lc, o->rounds);
    res->remote_call_ms = median(rc, o->rounds);
    range_of(lf, o->rounds, &res->local_lo, &res->local_hi);
    range_of(rf, o->rounds, &res->remote_lo, &res->remote_hi);
    res->rt_per_call = (double)rts / o->rounds;
    res->rt_per_frame = (double)loop_rts / o->rounds / o->frames;
    if (!res->identical) {
        fprintf(stderr, "bench_node: the remote image differs from the local one\n");
        return false;
    }
    return true;
}

typedef struct latency_row {
    const char *what;
    uint32_t rtt_ms;
    bool relay;
    tcp_relay *relay_obj;
    render_side side;
    double frame_ms, call_ms;
    double frames_ms[MAX_ROUNDS], calls_ms[MAX_ROUNDS];
    uint64_t round_trips, loop_round_trips; /* over the measured renders */
} latency_row;

typedef struct latency_result {
    bool done;
    latency_row rows[MAX_RTTS + 1];
    uint32_t count;
} latency_result;

/* Row 0 is loopback without a relay; row i > 0 goes through its own relay
 * adding rtts[i - 1]. Every row has its own session and renderer, and the rows
 * render in turn, round by round, so background load falls on all of them. */
static bool bench_latency(const options *o, const bench_node *vk, const cv_scene *scene, const cv_bvh *bvh,
                          latency_result *res) {
    printf(
        "\n4. latency: %ux%u, %u frames, through relays adding round-trip time; 1 warm-up render, then %u "
        "rounds, interleaved\n",
        o->lat_width, o->lat_height, o->lat_frames, o->rounds);
    /* The reference image: the local render of the same settings. */
    render_side local;
    cv_render_output reference = { 0 };
    render_run lr;
    bool ok = side_open(&local, cv_vulkan_backend(), &(cv_device_desc){ .adapter = o->adapter }, scene, bvh) &&
              render_once(&local, o->lat_width, o->lat_height, o->lat_frames, &reference, &lr);
    side_close(&local);
    res->count = 0;
    for (uint32_t i = 0; ok && i <= o->rtt_count; i++) {
        latency_row *row = &res->rows[res->count++];
        *row = (latency_row){ .what = i == 0 ? "loopback" : "relay",
                              .relay = i > 0,
                              .rtt_ms = i == 0 ? 0 : o->rtts[i - 1] };
        char endpoint[64];
        snprintf(endpoint, sizeof endpoint, "%s", vk->endpoint);
        if (row->relay) {
            ok = tcp_relay_start(cv_node_port(vk->node), row->rtt_ms * 1000u / 2, &row->relay_obj) == 0;
            if (!ok)
                break;
            snprintf(endpoint, sizeof endpoint, "127.0.0.1:%d", tcp_relay_port(row->relay_obj));
        }
        ok = side_open(&row->side, cv_proxy_backend(), &(cv_device_desc){ .endpoint = endpoint, .label = "remote" },
                       scene, bvh);
        if (ok)
            printf("   %-8s +%3u ms rtt: create %7.1f ms, %llu round trips\n", row->what, row->rtt_ms,
                   row->side.create_ms, (unsigned long long)row->side.create_round_trips);
    }
    for (uint32_t round = 0; ok && round <= o->rounds; round++) {
        for (uint32_t i = 0; ok && i < res->count; i++) {
            latency_row *row = &res->rows[i];
            cv_render_output out = { 0 };
            render_run run;
            ok = render_once(&row->side, o->lat_width, o->lat_height, o->lat_frames, &out, &run);
            if (ok && !same_image(&reference, &out)) {
                fprintf(stderr, "bench_node: the image through %s +%u ms differs from the local one\n", row->what,
                        row->rtt_ms);
                ok = false;
            }
            cv_render_output_free(&out);
            if (ok && round > 0) {
                row->frames_ms[round - 1] = run.frame_ms;
                row->calls_ms[round - 1] = run.call_ms;
                row->round_trips += run.round_trips;
                row->loop_round_trips += run.loop_round_trips;
            }
        }
    }
    for (uint32_t i = 0; i < res->count; i++) {
        latency_row *row = &res->rows[i];
        if (ok) {
            row->frame_ms = median(row->frames_ms, o->rounds);
            row->call_ms = median(row->calls_ms, o->rounds);
            printf(
                "   %-8s +%3u ms rtt: %8.1f ms/frame, %6.2f fps | render call %7.1f ms, %.1f round trips "
                "(%.1f in the frame loop)\n",
                row->what, row->rtt_ms, row->frame_ms, 1e3 / row->frame_ms, row->call_ms,
                (double)row->round_trips / o->rounds, (double)row->loop_round_trips / o->rounds);
        }
        side_close(&row->side);
        if (row->relay_obj) {
            tcp_relay_stats rs = tcp_relay_get_stats(row->relay_obj);
            if (ok)
                printf("            relay: %llu connections, %.2f MB to the node, %.2f MB back\n",
                       (unsigned long long)rs.connections, rs.bytes_to_target / 1e6, rs.bytes_to_client / 1e6);
            tcp_relay_stop(row->relay_obj);
        }
    }
    cv_render_output_free(&reference);
    res->done = ok;
    return ok;
}

/* ---- 2 and 3: data through the node and through the rpc layer alone --------------- */

/* The peer's server: a request is 9 bytes, op ('R' or 'U'), count and size (u32,
 * host order). 'R': sends `count` messages of `size` bytes. 'U': receives
 * `count` messages, then answers with one empty message. */
typedef struct peer_server {
    cv_rpc_server *server;
    const uint8_t *data; /* count * size bytes to send */
} peer_server;

static void peer_stream(cv_rpc_stream *s, const char *method, void *user) {
    (void)method;
    peer_server *p = user;
    uint8_t *m;
    size_t n;
    while (cv_rpc_stream_recv(s, CV_RPC_FOREVER, &m, &n) == CV_OK && m) {
        uint32_t count = 0, size = 0;
        char op = 0;
        if (n == 9) {
            op = (char)m[0];
            memcpy(&count, m + 1, 4);
            memcpy(&size, m + 5, 4);
        }
        free(m);
        bool ok = true;
        if (op == 'R') {
            for (uint32_t i = 0; i < count && ok; i++)
                ok = cv_rpc_stream_send(s, p->data + (size_t)i * size, size) == CV_OK;
        } else if (op == 'U') {
            for (uint32_t i = 0; i < count && ok; i++) {
                ok = cv_rpc_stream_recv(s, 30000, &m, &n) == CV_OK && m;
                free(m);
            }
            ok = ok && cv_rpc_stream_send(s, "", 0) == CV_OK;
        } else {
            ok = false;
        }
        if (!ok)
            break;
    }
}

static bool peer_request(cv_rpc_stream *s, char op, uint32_t count, uint32_t size) {
    uint8_t req[9];
    req[0] = (uint8_t)op;
    memcpy(req + 1, &count, 4);
    memcpy(req + 5, &size, 4);
    return cv_rpc_stream_send(s, req, sizeof req) == CV_OK;
}

/* Receives `count` messages into `out` (size bytes each). */
static bool peer_read(cv_rpc_stream *s, uint32_t count, uint32_t size, uint8_t *out) {
    if (!peer_request(s, 'R', count, size))
        return fail("peer read request");
    for (uint32_t i = 0; i < count; i++) {
        uint8_t *m;
        size_t n;
        if (cv_rpc_stream_recv(s, 30000, &m, &n) != CV_OK || !m || n != size) {
            free(m);
            return fail("peer read");
        }
        memcpy(out + (size_t)i * size, m, size);
        free(m);
    }
    return true;
}

static bool peer_upload(cv_rpc_stream *s, uint32_t count, uint32_t size, const uint8_t *data) {
    if (!peer_request(s, 'U', count, size))
        return fail("peer upload request");
    for (uint32_t i = 0; i < count; i++)
        if (cv_rpc_stream_send(s, data + (size_t)i * size, size) != CV_OK)
            return fail("peer upload");
    uint8_t *m;
    size_t n;
    bool ok = cv_rpc_stream_recv(s, 30000, &m, &n) == CV_OK && m;
    free(m);
    return ok || fail("peer upload answer");
}

typedef struct peer_client {
    peer_server server;
    cv_rpc_client *client;
    cv_rpc_stream *stream;
} peer_client;

static bool peer_open(peer_client *pc, const uint8_t *data) {
    memset(pc, 0, sizeof(*pc));
    pc->server.data = data;
    static const char *const methods[] = { "/bench.Peer/Stream", NULL };
    cv_rpc_server_config cfg = {
        .listen = "127.0.0.1:0", .on_stream = peer_stream, .stream_methods = methods, .user = &pc->server
    };
    if (cv_rpc_server_start(&cfg, &pc->server.server) != CV_OK)
        return fail("peer server");
    char target[64];
    snprintf(target, sizeof target, "127.0.0.1:%d", cv_rpc_server_port(pc->server.server));
    if (cv_rpc_client_create(target, NULL, &pc->client) != CV_OK ||
        cv_rpc_client_open(pc->client, "/bench.Peer/Stream", NULL, 0, &pc->stream) != CV_OK)
        return fail("peer client");
    return true;
}

static void peer_close(peer_client *pc) {
    if (pc->stream) {
        cv_rpc_stream_close_send(pc->stream);
        uint8_t *m;
        size_t n;
        while (cv_rpc_stream_recv(pc->stream, 5000, &m, &n) == CV_OK && m)
            free(m);
        cv_rpc_stream_destroy(pc->stream);
    }
    cv_rpc_client_destroy(pc->client);
    cv_rpc_server_destroy(pc->server.server, 5000);
    memset(pc, 0, sizeof(*pc));
}

typedef struct stream_result {
    bool done;
    double node_mbps, peer_mbps, node_lo, node_hi, peer_lo, peer_hi;
    uint64_t bytes;
} stream_result;

static double mbps(uint64_t bytes, double s) { return bytes / s / 1e6; }

static bool bench_stream(const options *o, const bench_node *mock, stream_result *res) {
    uint64_t bytes = o->read_bytes;
    printf(
        "\n2. result stream: cv_device_read_buffer of %llu MiB from a mock device of a node, vs the same bytes "
        "as %u KiB rpc messages; %u reads each, interleaved\n",
        (unsigned long long)(bytes >> 20), CHUNK >> 10, o->reads);
    uint8_t *data = malloc(bytes), *back = malloc(bytes);
    cv_context *ctx = NULL;
    cv_device *dev = NULL;
    cv_buffer buf;
    peer_client pc = { 0 };
    bool ok = data && back;
    if (ok) {
        fill_random(data, bytes, 7);
        ok = (cv_context_create(NULL, &ctx) == CV_OK || fail("context")) &&
             (cv_device_create(ctx, cv_proxy_backend(), &(cv_device_desc){ .endpoint = mock->endpoint }, &dev) ==
                  CV_OK ||
              fail("proxy device")) &&
             (cv_buffer_create(ctx, &(cv_buffer_desc){ .size = bytes, .label = "readback" }, &buf) == CV_OK ||
              fail("buffer")) &&
             (cv_device_load(dev, cv_any(buf)) == CV_OK || fail("load")) &&
             (cv_device_write_buffer(dev, buf, 0, bytes, data) == CV_OK || fail("write")) && peer_open(&pc, data);
    }
    double node_s[64], peer_s[64];
    uint32_t count = (uint32_t)(bytes / CHUNK);
    for (uint32_t i = 0; ok && i <= o->reads; i++) { /* i == 0: warm-up */
        memset(back, 0, bytes);
        double t0 = bench_now();
        ok = cv_device_read_buffer(dev, buf, 0, bytes, back) == CV_OK || fail("read");
        double t1 = bench_now();
        if (ok && memcmp(back, data, bytes) != 0) {
            fprintf(stderr, "bench_node: the node read back different bytes\n");
            ok = false;
        }
        memset(back, 0, bytes);
        double t2 = bench_now();
        ok = ok && peer_read(pc.stream, count, CHUNK, back);
        double t3 = bench_now();
        if (ok && memcmp(back, data, (size_t)count * CHUNK) != 0) {
            fprintf(stderr, "bench_node: the peer stream delivered different bytes\n");
            ok = false;
        }
        if (ok && i > 0) {
            node_s[i - 1] = t1 - t0;
            peer_s[i - 1] = t3 - t2;
        }
    }
    if (ok) {
        uint32_t n = o->reads < 64 ? o->reads : 64;
        res->bytes = bytes;
        res->node_mbps = mbps(bytes, median(node_s, n));
        res->peer_mbps = mbps((uint64_t)count * CHUNK, median(peer_s, n));
        double lo, hi;
        range_of(node_s, n, &lo, &hi);
        res->node_lo = mbps(bytes, hi);
        res->node_hi = mbps(bytes, lo);
        range_of(peer_s, n, &lo, &hi);
        res->peer_lo = mbps((uint64_t)count * CHUNK, hi);
        res->peer_hi = mbps((uint64_t)count * CHUNK, lo);
        res->done = true;
        printf("   node read %8.0f MB/s (%.0f-%.0f) | rpc stream %8.0f MB/s (%.0f-%.0f) | %.2fx\n", res->node_mbps,
               res->node_lo, res->node_hi, res->peer_mbps, res->peer_lo, res->peer_hi,
               res->node_mbps / res->peer_mbps);
    }
    peer_close(&pc);
    if (ctx)
        cv_context_destroy(ctx);
    free(data);
    free(back);
    return ok;
}

typedef struct upload_result {
    bool done;
    double first_mbps, cached_mbps, peer_mbps, sha_mbps;
    double first_lo, first_hi, cached_lo, cached_hi;
    cv_proxy_stats first, cached;
    uint64_t bytes;
} upload_result;

/* One session: a buffer of `bytes`, written once; seconds of the write and the session's stats. */
static bool upload_session(const bench_node *mock, const uint8_t *data, uint64_t bytes, double *seconds,
                           cv_proxy_stats *stats) {
    cv_context *ctx = NULL;
    cv_device *dev = NULL;
    cv_buffer buf;
    bool ok = (cv_context_create(NULL, &ctx) == CV_OK || fail("context")) &&
              (cv_device_create(ctx, cv_proxy_backend(), &(cv_device_desc){ .endpoint = mock->endpoint }, &dev) ==
                   CV_OK ||
               fail("proxy device")) &&
              (cv_buffer_create(ctx, &(cv_buffer_desc){ .size = bytes, .label = "upload" }, &buf) == CV_OK ||
               fail("buffer")) &&
              (cv_device_load(dev, cv_any(buf)) == CV_OK || fail("load"));
    cv_proxy_stats before = { 0 };
    if (ok)
        cv_proxy_get_stats(dev, &before);
    double t0 = bench_now();
    ok = ok && (cv_device_write_buffer(dev, buf, 0, bytes, data) == CV_OK || fail("write"));
    *seconds = bench_now() - t0;
    if (ok) {
        cv_proxy_get_stats(dev, stats);
        stats->round_trips -= before.round_trips;
        stats->messages_sent -= before.messages_sent;
        stats->bytes_sent -= before.bytes_sent;
        stats->bytes_received -= before.bytes_received;
    }
    if (ctx)
        cv_context_destroy(ctx);
    return ok;
}

static bool bench_upload(const options *o, const bench_node *mock, upload_result *res) {
    uint64_t bytes = o->upload_bytes;
    printf(
        "\n3. upload: cv_device_write_buffer of %llu MiB of fresh random bytes in a first session, then the same "
        "bytes in a second session; %u rounds\n",
        (unsigned long long)(bytes >> 20), o->uploads);
    uint8_t *data = malloc(bytes);
    peer_client pc = { 0 };
    bool ok = data && peer_open(&pc, data);
    double first[20], cached[20], peer[20], sha[20];
    uint32_t count = (uint32_t)(bytes / CHUNK);
    for (uint32_t i = 0; ok && i < o->uploads; i++) {
        fill_random(data, bytes, 1000 + i);
        cv_proxy_stats a, b;
        ok = upload_session(mock, data, bytes, &first[i], &a) && upload_session(mock, data, bytes, &cached[i], &b);
        double t0 = bench_now();
        ok = ok && peer_upload(pc.stream, count, CHUNK, data);
        double t1 = bench_now();
        uint8_t digest[CV_SHA256_SIZE];
        cv_sha256(data, bytes, digest);
        sha[i] = bench_now() - t1;
        peer[i] = t1 - t0;
        if (!ok)
            break;
        printf(
            "   round %u: first %7.0f MB/s (sent %llu, skipped %llu, %llu round trips) | cached %7.0f MB/s "
            "(sent %llu, skipped %llu, %llu round trips) | rpc upload %7.0f MB/s | SHA-256 %6.0f MB/s\n",
            i + 1, mbps(bytes, first[i]), (unsigned long long)a.upload_bytes_sent,
            (unsigned long long)a.upload_bytes_skipped, (unsigned long long)a.round_trips, mbps(bytes, cached[i]),
            (unsigned long long)b.upload_bytes_sent, (unsigned long long)b.upload_bytes_skipped,
            (unsigned long long)b.round_trips, mbps((uint64_t)count * CHUNK, peer[i]), mbps(bytes, sha[i]));
        if (b.upload_bytes_sent != 0 || b.upload_bytes_skipped != bytes || a.upload_bytes_sent != bytes) {
            fprintf(stderr, "bench_node: the cache did not behave (first sent %llu, second sent %llu)\n",
                    (unsigned long long)a.upload_bytes_sent, (unsigned long long)b.upload_bytes_sent);
            ok = false;
        }
        res->first = a;
        res->cached = b;
    }
    if (ok) {
        double lo, hi;
        res->bytes = bytes;
        res->first_mbps = mbps(bytes, median(first, o->uploads));
        res->cached_mbps = mbps(bytes, median(cached, o->uploads));
        res->peer_mbps = mbps((uint64_t)count * CHUNK, median(peer, o->uploads));
        res->sha_mbps = mbps(bytes, median(sha, o->uploads));
        range_of(first, o->uploads, &lo, &hi);
        res->first_lo = mbps(bytes, hi);
        res->first_hi = mbps(bytes, lo);
        range_of(cached, o->uploads, &lo, &hi);
        res->cached_lo = mbps(bytes, hi);
        res->cached_hi = mbps(bytes, lo);
        res->done = true;
    }
    peer_close(&pc);
    free(data);
    return ok;
}

/* ---- main --------------------------------------------------------------------------- */

int main(int argc, char **argv) {
    options o;
    if (!parse(argc, argv, &o))
        return 2;
    char machine[256];
    bench_machine(machine, sizeof machine);
    printf("bench_node: the renderer and data paths through a corvid-node on loopback, vs local / the rpc layer\n");
    printf("machine: %s\n", machine);
    double t_start = bench_now();
    bool ok = true;

    frame_result fr = { 0 };
    latency_result lat = { 0 };
    stream_result sr = { 0 };
    upload_result ur = { 0 };

    if (o.frame || o.latency) {
        cv_scene *scene = NULL;
        cv_bvh *bvh = NULL;
        bench_node vk;
        ok = (cv_scene_make_room(1, &scene) == CV_OK || fail("scene")) &&
             (cv_bvh_build_flat(scene, NULL, &bvh) == CV_OK || fail("bvh")) &&
             node_start(&vk, cv_vulkan_backend(), o.adapter);
        if (ok)
            printf("vulkan node at %s serving adapter '%s'\n", vk.endpoint, o.adapter);
        if (ok && o.frame)
            ok = bench_frame(&o, &vk, scene, bvh, &fr);
        if (ok && o.latency)
            ok = bench_latency(&o, &vk, scene, bvh, &lat);
        if (vk.node)
            node_stop(&vk);
        cv_bvh_destroy(bvh);
        cv_scene_destroy(scene);
    }
    if (ok && (o.stream || o.upload)) {
        bench_node mock;
        ok = node_start(&mock, cv_mock_backend(), "");
        if (ok && o.stream)
            ok = bench_stream(&o, &mock, &sr);
        if (ok && o.upload)
            ok = bench_upload(&o, &mock, &ur);
        node_stop(&mock);
    }

    printf("\n== bench_node summary (%.1f s) ==\n", bench_now() - t_start);
    printf("%-44s | %-26s | %-26s | %s\n", "what", "corvid", "peer", "ratio");
    if (fr.done) {
        char what[64];
        snprintf(what, sizeof what, "frame %ux%u, %u frames, ms/frame", o.width, o.height, o.frames);
        printf("%-44s | remote %7.1f (%.1f-%.1f) | local %8.1f (%.1f-%.1f) | %.3fx (goal <= 1.15x)\n", what,
               fr.remote_ms, fr.remote_lo, fr.remote_hi, fr.local_ms, fr.local_lo, fr.local_hi,
               fr.remote_ms / fr.local_ms);
        printf("%-44s | remote %7.1f            | local %8.1f            | %.3fx\n", "  whole render call, ms",
               fr.remote_call_ms, fr.local_call_ms, fr.remote_call_ms / fr.local_call_ms);
        printf(
            "%-44s | %.1f per render call, %.2f per frame in the frame loop (cv_proxy_stats.round_trips;\n"
            "%-44s |   completion waits are not counted there: see the latency rows)\n",
            "  proxy round trips", fr.rt_per_call, fr.rt_per_frame, "");
    }
    if (sr.done)
        printf("%-44s | node %9.0f MB/s      | rpc %10.0f MB/s      | %.2fx (goal >= 0.9x)\n",
               "result stream, read of a buffer", sr.node_mbps, sr.peer_mbps, sr.node_mbps / sr.peer_mbps);
    if (ur.done) {
        printf("%-44s | first %7.0f MB/s       | rpc upload %5.0f MB/s  | %.2fx\n", "upload, first session",
               ur.first_mbps, ur.peer_mbps, ur.first_mbps / ur.peer_mbps);
        printf("%-44s | cached %6.0f MB/s       | SHA-256 %8.0f MB/s  | %.2fx\n", "upload, cached (second session)",
               ur.cached_mbps, ur.sha_mbps, ur.cached_mbps / ur.sha_mbps);
        printf("%-44s | first: sent %llu skipped %llu; cached: sent %llu skipped %llu\n",
               "  upload_bytes (last round)", (unsigned long long)ur.first.upload_bytes_sent,
               (unsigned long long)ur.first.upload_bytes_skipped, (unsigned long long)ur.cached.upload_bytes_sent,
               (unsigned long long)ur.cached.upload_bytes_skipped);
    }
    if (lat.done && lat.count > 0) {
        const latency_row *base = &lat.rows[0], *relay0 = NULL;
        for (uint32_t i = 1; i < lat.count && !relay0; i++)
            if (lat.rows[i].rtt_ms == 0)
                relay0 = &lat.rows[i];
        for (uint32_t i = 0; i < lat.count; i++) {
            const latency_row *r = &lat.rows[i];
            char what[64], extra[96] = "";
            snprintf(what, sizeof what, "latency %ux%u, %s +%u ms rtt", o.lat_width, o.lat_height, r->what,
                     r->rtt_ms);
            /* Added time per frame over the added round-trip time: the round trips a frame waits for in series. */
            const latency_row *ref = relay0 ? relay0 : base;
            if (r->rtt_ms > 0)
                snprintf(extra, sizeof extra, "; %.2f serial round trips/frame",
                         (r->frame_ms - ref->frame_ms) / r->rtt_ms);
            printf("%-44s | %6.2f fps (%6.1f ms/frame) | loopback %5.2f fps      | %.2fx loopback's frame time%s\n",
                   what, 1e3 / r->frame_ms, r->frame_ms, 1e3 / base->frame_ms, r->frame_ms / base->frame_ms, extra);
        }
        printf("%-44s | goal: within 1.2x of loopback at +20 ms; serial round trips measured against relay +0 ms\n",
               "");
    }
    if (!ok)
        fprintf(stderr, "bench_node: stopped early\n");
    return ok ? 0 : 1;
}
