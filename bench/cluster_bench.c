/* bench_cluster: cluster frames on loopback (docs/node.md, "Clusters").
 *
 *  1. Frame time on 1, 2 and 3 corvid-nodes (one lavapipe device each, nodes in
 *     this process), beside the same render on one local device, and the
 *     3-node render with the transfers forced through the client (STAGED) beside
 *     the node-to-node PEER path.
 *  2. Bytes per frame: what each secondary's node sent to the primary's node
 *     (compressed, on the wire) beside the raw partition bytes, and what the
 *     client received from each session.
 *  3. A node killed (SIGKILL, a corvid-node process) mid-render: the frame it
 *     dies in beside the median frame of the same render.
 *
 *     XDG_RUNTIME_DIR=/tmp build/bench/bench_cluster [--size WxH] [--frames N] [--node PATH]
 *
 * --node: the corvid-node program for part 3 (default: ../apps/corvid-node next
 * to this program). Figures go to stdout; nothing here fails on timing. */
#include <libgen.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bench_util.h"
#include "corvid/proxy.h"
#include "corvid/renderer.h"
#include "corvid/scene_procedural.h"
#include "corvid/transfer.h"
#include "corvid/vulkan.h"
#include "scratch_node.h"

static cv_render_settings settings(uint32_t w, uint32_t h, uint32_t frames) {
    return (cv_render_settings){
        .width = w, .height = h, .frames = frames, .ao_samples = 2, .sun_cone_degrees = 1.0f, .filter_iterations = 2
    };
}

typedef struct run_result {
    double frame_ms; /* of the second (warm) render */
    cv_proxy_stats ps[3];
} run_result;

/* Two renders on `devices` (the first warms caches and compiles); figures of the second. */
static cv_result run(cv_device **devices, uint32_t count, const cv_scene *scene, const cv_bvh *bvh,
                     const cv_render_settings *s, run_result *out) {
    cv_renderer *r = NULL;
    cv_render_output img = { 0 };
    cv_render_stats st;
    memset(out, 0, sizeof(*out));
    cv_result res = cv_renderer_create(devices, count, scene, bvh, &r);
    if (res == CV_OK)
        res = cv_renderer_render(r, s, &img, &st, NULL, NULL);
    cv_render_output_free(&img);
    cv_proxy_stats before[3] = { 0 };
    for (uint32_t d = 0; res == CV_OK && d < count && d < 3; d++)
        cv_proxy_get_stats(devices[d], &before[d]);
    if (res == CV_OK)
        res = cv_renderer_render(r, s, &img, &st, NULL, NULL);
    cv_render_output_free(&img);
    if (res == CV_OK) {
        out->frame_ms = st.frame_ms;
        for (uint32_t d = 0; d < count && d < 3; d++) {
            cv_proxy_stats now;
            if (cv_proxy_get_stats(devices[d], &now) != CV_OK)
                continue;
            out->ps[d].bytes_received = now.bytes_received - before[d].bytes_received;
            out->ps[d].peer_push_bytes = now.peer_push_bytes - before[d].peer_push_bytes;
        }
    }
    cv_renderer_destroy(r);
    return res;
}

typedef struct kill_plan {
    scratch_process_node *victim;
    uint32_t after;
    double last, ms[64];
    uint32_t seen;
} kill_plan;

static void on_frame(uint32_t frame, uint32_t frames, void *user) {
    (void)frames;
    kill_plan *k = user;
    double t = bench_now() * 1e3;
    if (frame - 1 < 64)
        k->ms[frame - 1] = t - k->last;
    k->seen = frame;
    if (frame == k->after)
        scratch_process_node_kill(k->victim);
    k->last = bench_now() * 1e3;
}

static int cmp_double(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

static void node_death(const char *binary, const cv_scene *scene, const cv_bvh *bvh, cv_render_settings s) {
    const char *const extra[] = { "--peer-deadline-ms", "2000", "--peer-keepalive-ms", "1000", "--quiet", NULL };
    cv_proxy_configure(&(cv_proxy_options){ .keepalive_ms = 1000 });
    scratch_process_node nodes[3] = { 0 };
    cv_result r = CV_OK;
    for (int i = 0; i < 3 && r == CV_OK; i++)
        r = scratch_process_node_start(&nodes[i], binary, 1, 0, extra);
    cv_context *ctx = NULL;
    cv_device *devices[3] = { 0 };
    if (r == CV_OK)
        r = cv_context_create(NULL, &ctx);
    for (int i = 0; i < 3 && r == CV_OK; i++)
        r = cv_device_create(ctx, cv_proxy_backend(), &(cv_device_desc){ .endpoint = nodes[i].endpoint },
                             &devices[i]);
    cv_renderer *rd = NULL;
    cv_render_output img = { 0 };
    cv_render_stats st;
    kill_plan k = { .victim = &nodes[2], .after = s.frames / 2 };
    if (r == CV_OK)
        r = cv_renderer_create(devices, 3, scene, bvh, &rd);
    if (r == CV_OK) {
        k.last = bench_now() * 1e3;
        r = cv_renderer_render(rd, &s, &img, &st, on_frame, &k);
    }
    if (r == CV_OK && k.seen > k.after + 1) {
        double sorted[64];
        uint32_t n = 0;
        for (uint32_t f = 1; f < k.seen && f < 64; f++) /* frame 0 renders the G-buffer and compiles */
            if (f != k.after)
                sorted[n++] = k.ms[f];
        qsort(sorted, n, sizeof(double), cmp_double);
        printf(
            "node killed after frame %u of %u: that frame %.1f ms, median frame %.1f ms (%.2fx); %u devices "
            "lost\n",
            k.after, s.frames, k.ms[k.after], sorted[n / 2], k.ms[k.after] / sorted[n / 2], st.devices_lost);
    } else {
        printf("node death: not measured: %s\n", r == CV_OK ? "too few frames" : cv_last_error());
    }
    cv_render_output_free(&img);
    cv_renderer_destroy(rd);
    if (ctx)
        cv_context_destroy(ctx);
    for (int i = 0; i < 3; i++)
        scratch_process_node_stop(&nodes[i]);
    cv_proxy_configure(NULL);
}

int main(int argc, char **argv) {
    uint32_t w = 320, h = 180, frames = 8;
    char node_binary[1024];
    char self[1024];
    snprintf(self, sizeof(self), "%s", argv[0]);
    snprintf(node_binary, sizeof(node_binary), "%s/../apps/corvid-node", dirname(self));
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--size") && i + 1 < argc && sscanf(argv[i + 1], "%ux%u", &w, &h) == 2)
            i++;
        else if (!strcmp(argv[i], "--frames") && i + 1 < argc)
            frames = (uint32_t)atoi(argv[++i]);
        else if (!strcmp(argv[i], "--node") && i + 1 < argc)
            snprintf(node_binary, sizeof(node_binary), "%s", argv[++i]);
        else {
            fprintf(stderr, "usage: bench_cluster [--size WxH] [--frames N] [--node PATH]\n");
            return 2;
        }
    }
    if (frames < 4 || frames > 64 || !w || !h) {
        fprintf(stderr, "bench_cluster: --frames 4..64, a size of at least 1x1\n");
        return 2;
    }
    char machine[256];
    bench_machine(machine, sizeof(machine));
    printf("bench_cluster: %ux%u, %u frames, 2 AO rays, room scene; %s\n", w, h, frames, machine);
    cv_scene *scene = NULL;
    cv_bvh *bvh = NULL;
    if (cv_scene_make_room(1, &scene) != CV_OK || cv_bvh_build_flat(scene, NULL, &bvh) != CV_OK) {
        fprintf(stderr, "bench_cluster: %s\n", cv_last_error());
        return 1;
    }
    cv_render_settings s = settings(w, h, frames);

    cv_context *ctx;
    cv_device *local = NULL;
    run_result base = { 0 };
    cv_result r = cv_context_create(NULL, &ctx);
    if (r == CV_OK)
        r = cv_device_create(ctx, cv_vulkan_backend(), &(cv_device_desc){ .adapter = "llvmpipe" }, &local);
    if (r == CV_OK)
        r = run(&local, 1, scene, bvh, &s, &base);
    if (ctx)
        cv_context_destroy(ctx);
    if (r != CV_OK) {
        fprintf(stderr, "bench_cluster: local render: %s\n", cv_last_error());
        return 1;
    }
    printf("local, 1 device: %.1f ms/frame\n", base.frame_ms);

    scratch_node nodes[3];
    for (int i = 0; i < 3; i++)
        if (scratch_node_start(&nodes[i], cv_vulkan_backend(), 1, false) != CV_OK) {
            fprintf(stderr, "bench_cluster: node: %s\n", cv_last_error());
            return 1;
        }
    for (uint32_t n = 1; n <= 3; n++) {
        for (int staged = 0; staged < (n == 3 ? 2 : 1); staged++) {
            cv_device *devices[3] = { 0 };
            run_result res = { 0 };
            cv_node_stats before[3], after[3];
            for (uint32_t i = 0; i < n; i++)
                before[i] = cv_node_get_stats(nodes[i].node);
            r = cv_context_create(NULL, &ctx);
            for (uint32_t i = 0; i < n && r == CV_OK; i++)
                r = cv_device_create(ctx, cv_proxy_backend(), &(cv_device_desc){ .endpoint = nodes[i].endpoint },
                                     &devices[i]);
            if (staged)
                cv_transfer_set_path(CV_TRANSFER_STAGED);
            if (r == CV_OK)
                r = run(devices, n, scene, bvh, &s, &res);
            cv_transfer_clear_path();
            if (ctx)
                cv_context_destroy(ctx);
            if (r != CV_OK) {
                printf("%u node%s: failed: %s\n", n, n > 1 ? "s" : "", cv_last_error());
                continue;
            }
            printf("%u node%s (%s): %.1f ms/frame, %.2fx local\n", n, n > 1 ? "s" : "",
                   n == 1   ? "no transfers"
                   : staged ? "staged through the client"
                            : "peer, node to node",
                   res.frame_ms, res.frame_ms / base.frame_ms);
            /* Two renders ran; per frame of both. */
            for (uint32_t i = 1; i < n; i++) {
                after[i] = cv_node_get_stats(nodes[i].node);
                uint64_t raw = after[i].peer_raw_out - before[i].peer_raw_out;
                uint64_t wire = after[i].peer_bytes_out - before[i].peer_bytes_out;
                printf(
                    "   node %u: to peers %.1f kB/frame on the wire for %.1f kB of partitions (%.2fx); "
                    "the client received %.1f kB/frame from it\n",
                    i, wire / 2e3 / frames, raw / 2e3 / frames, raw ? (double)wire / (double)raw : 0.0,
                    res.ps[i].bytes_received / 1e3 / frames);
            }
        }
    }
    for (int i = 0; i < 3; i++)
        scratch_node_stop(&nodes[i]);
    node_death(node_binary, scene, bvh, s);
    cv_bvh_destroy(bvh);
    cv_scene_destroy(scene);
    return 0;
}
