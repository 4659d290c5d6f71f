/* Cluster frames: several corvid-nodes trace column partitions of one frame
 * and send them to the primary's node themselves (the PEER transfer path).
 *  - 3 nodes on loopback (lavapipe) render bit-identically to the local render,
 *    the transfers take the peer path, and the client receives no partition
 *    bytes (the secondaries' sessions send it only small answers; the nodes
 *    count what went between them);
 *  - a node in its own process is SIGKILLed mid-render: the render completes
 *    with the local pixels, the frame it failed in retried on the survivors
 *    (the times are printed, not asserted), and the primary's session goes on;
 *  - the node restarted on its port is added back (cv_renderer_add_device)
 *    and takes columns again, pixels unchanged;
 *  - a node whose network goes silent (a relay that stops forwarding) is
 *    noticed within the keepalive set for the test, and the
 *    render completes on the others with the same pixels;
 *  - a corvid-node draining after SIGTERM still serves its metrics while a
 *    session runs, and exits 0 once it ends. */
#include <arpa/inet.h>
#include <netinet/in.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "check.h"
#include "corvid/clock.h"
#include "corvid/proxy.h"
#include "corvid/renderer.h"
#include "corvid/scene_procedural.h"
#include "corvid/transfer.h"
#include "corvid/vulkan.h"
#include "scratch_node.h"
#include "tcp_relay.h"

#define W 160
#define H 90

static cv_render_settings settings(uint32_t frames) {
    return (cv_render_settings){
        .width = W, .height = H, .frames = frames, .ao_samples = 2, .sun_cone_degrees = 1.0f, .filter_iterations = 2
    };
}

static const char *test_adapter(void) {
    const char *env = getenv("CORVID_TEST_ADAPTER");
    return env && env[0] ? env : "llvmpipe";
}

static bool same_image(const cv_render_output *a, const cv_render_output *b) {
    size_t bytes = (size_t)W * H * 4 * sizeof(float);
    return a->radiance && b->radiance && memcmp(a->radiance, b->radiance, bytes) == 0 &&
           memcmp(a->visibility, b->visibility, bytes) == 0 && memcmp(a->normal, b->normal, bytes) == 0;
}

static cv_result render_local(const cv_scene *scene, const cv_bvh *bvh, uint32_t frames, cv_render_output *out) {
    cv_context *ctx;
    cv_device *dev = NULL;
    cv_renderer *r = NULL;
    cv_render_settings s = settings(frames);
    cv_result res = cv_context_create(NULL, &ctx);
    if (res == CV_OK)
        res = cv_device_create(ctx, cv_vulkan_backend(),
                               &(cv_device_desc){ .adapter = test_adapter(), .validation = true }, &dev);
    if (res == CV_OK)
        res = cv_renderer_create(&dev, 1, scene, bvh, &r);
    if (res == CV_OK)
        res = cv_renderer_render(r, &s, out, NULL, NULL, NULL);
    cv_renderer_destroy(r);
    if (ctx)
        cv_context_destroy(ctx);
    return res;
}

/* 3 in-process nodes, one device each: equal pixels, peer transfers, no partition bytes at the client. */
static void three_nodes(const cv_scene *scene, const cv_bvh *bvh, const cv_render_output *local) {
    scratch_node nodes[3];
    for (int i = 0; i < 3; i++)
        CHECK_OK(scratch_node_start(&nodes[i], cv_vulkan_backend(), 1, true));
    cv_context *ctx;
    cv_device *devices[3] = { 0 };
    CHECK_OK(cv_context_create(NULL, &ctx));
    for (int i = 0; i < 3; i++) {
        cv_device_desc desc = { .endpoint = nodes[i].endpoint };
        snprintf(desc.label, sizeof(desc.label), "node%d", i);
        CHECK_OK(cv_device_create(ctx, cv_proxy_backend(), &desc, &devices[i]));
    }
    if (devices[0] && devices[1] && devices[2]) {
        cv_transfer_path path = CV_TRANSFER_AUTO;
        CHECK_OK(cv_transfer_choose_path(devices[1], devices[0], &path));
        CHECK_EQ_INT(path, CV_TRANSFER_PEER);
        CHECK(strcmp(cv_transfer_path_name(CV_TRANSFER_PEER), "peer") == 0);
        cv_renderer *r = NULL;
        cv_render_output out = { 0 };
        cv_render_stats stats;
        cv_render_settings s = settings(3);
        CHECK_OK(cv_renderer_create(devices, 3, scene, bvh, &r));
        CHECK_OK(cv_renderer_render(r, &s, &out, &stats, NULL, NULL));
        CHECK(same_image(local, &out));
        CHECK_EQ_INT(stats.device_count, 3);
        for (int d = 0; d < 3; d++)
            CHECK(stats.devices[d].columns.width > 0);
        cv_renderer_destroy(r);
        cv_render_output_free(&out);
        /* The primary awaited every secondary's columns; the secondaries pushed them and
         * awaited the G-buffer. The secondaries' sessions sent the client only answers and
         * completions (well under one frame's columns: 90 rows x 8 bytes per column). */
        cv_proxy_stats ps[3];
        for (int d = 0; d < 3; d++)
            CHECK_OK(cv_proxy_get_stats(devices[d], &ps[d]));
        CHECK(ps[0].peer_awaits >= 2 * 3);
        CHECK(ps[0].peer_await_bytes > 0);
        CHECK_EQ_INT(ps[0].transfer_failures, 0);
        uint64_t partitions = 0;
        for (int d = 1; d < 3; d++) {
            CHECK(ps[d].peer_pushes >= 3);
            partitions += ps[d].peer_push_bytes;
            CHECK(ps[d].bytes_received < 16 * 1024);
            fprintf(stderr, "secondary %d: pushed %llu partition bytes node to node, the client received %llu\n", d,
                    (unsigned long long)ps[d].peer_push_bytes, (unsigned long long)ps[d].bytes_received);
        }
        /* What the nodes moved between them: every pushed byte left a secondary's node, compressed. */
        uint64_t raw_out = 0, wire_out = 0, wire_in = 0;
        for (int i = 0; i < 3; i++) {
            cv_node_stats ns = cv_node_get_stats(nodes[i].node);
            raw_out += ns.peer_raw_out;
            wire_out += ns.peer_bytes_out;
            wire_in += ns.peer_bytes_in;
            CHECK_EQ_INT(ns.peer_failures, 0);
            CHECK_EQ_INT(ns.transfer_failures, 0);
        }
        CHECK(raw_out >= partitions);
        CHECK(wire_out > 0 && wire_in > 0);
        CHECK(wire_out < raw_out);
        fprintf(stderr, "nodes: %llu raw bytes sent to peers as %llu bytes on the wire\n",
                (unsigned long long)raw_out, (unsigned long long)wire_out);
    }
    cv_context_destroy(ctx);
    for (int i = 0; i < 3; i++) {
        CHECK_EQ_INT(scratch_node_wait_sessions(&nodes[i], 5000), 0);
        scratch_node_stop(&nodes[i]);
    }
}

/* ---- a node killed mid-render, then back --------------------------------------- */

typedef struct kill_plan {
    scratch_process_node *victim;
    uint32_t after_frame;
    double last_ms, frame_ms[16];
    uint32_t frames_seen;
} kill_plan;

static void on_frame(uint32_t frame, uint32_t frames, void *user) {
    (void)frames;
    kill_plan *plan = user;
    double t = cv_now_ms();
    if (frame - 1 < 16)
        plan->frame_ms[frame - 1] = t - plan->last_ms;
    plan->frames_seen = frame;
    if (frame == plan->after_frame)
        scratch_process_node_kill(plan->victim); /* SIGKILL: the next frame's sends meet a dead node */
    plan->last_ms = cv_now_ms();
}

static void node_killed(const char *node_binary, const cv_scene *scene, const cv_bvh *bvh) {
    const uint32_t frames = 5;
    cv_render_output local = { 0 };
    CHECK_OK(render_local(scene, bvh, frames, &local));
    /* A killed node's connections reset: its loss is seen at once, and the awaits from it are given up
     * (not left to the peer deadline, which stays long enough for a slow frame on a loaded machine). */
    const char *const extra[] = { "--peer-deadline-ms", "10000", "--peer-keepalive-ms", "2000", "--quiet", NULL };
    setenv("CORVID_NODE_KEEPALIVE_MS", "2000", 1);
    scratch_process_node nodes[3] = { 0 };
    for (int i = 0; i < 3; i++)
        CHECK_OK(scratch_process_node_start(&nodes[i], node_binary, 1, 0, extra));
    cv_context *ctx;
    cv_device *devices[3] = { 0 }, *back = NULL;
    CHECK_OK(cv_context_create(NULL, &ctx));
    for (int i = 0; i < 3 && nodes[i].pid; i++) {
        cv_device_desc desc = { .endpoint = nodes[i].endpoint };
        snprintf(desc.label, sizeof(desc.label), "pnode%d", i);
        CHECK_OK(cv_device_create(ctx, cv_proxy_backend(), &desc, &devices[i]));
    }
    if (devices[0] && devices[1] && devices[2]) {
        cv_renderer *r = NULL;
        cv_render_output out = { 0 }, rejoined = { 0 };
        cv_render_stats stats;
        cv_render_settings s = settings(frames);
        CHECK_OK(cv_renderer_create(devices, 3, scene, bvh, &r));
        kill_plan plan = { .victim = &nodes[2], .after_frame = 2, .last_ms = cv_now_ms() };
        CHECK_OK(cv_renderer_render(r, &s, &out, &stats, on_frame, &plan));
        CHECK(same_image(&local, &out));
        CHECK_EQ_INT(stats.devices_lost, 1);
        CHECK(cv_device_is_lost(devices[2]));
        CHECK(!cv_device_is_lost(devices[0]) && !cv_device_is_lost(devices[1]));
        fprintf(stderr, "frame times (ms), node killed after frame %u:", plan.after_frame);
        for (uint32_t f = 0; f < plan.frames_seen && f < 16; f++)
            fprintf(stderr, " %.0f", plan.frame_ms[f]);
        fprintf(stderr, "\n");

        /* The node comes back on its port: a new device for it joins the renderer. */
        CHECK_OK(scratch_process_node_start(&nodes[2], node_binary, 1, nodes[2].port, extra));
        cv_device_desc desc = { .endpoint = nodes[2].endpoint, .label = "pnode2 again" };
        CHECK_OK(cv_device_create(ctx, cv_proxy_backend(), &desc, &back));
        if (back) {
            CHECK_OK(cv_renderer_add_device(r, back));
            CHECK_RESULT(cv_renderer_add_device(r, back), CV_ERROR_ALREADY_EXISTS);
            CHECK_OK(cv_renderer_render(r, &s, &rejoined, &stats, NULL, NULL));
            CHECK(same_image(&local, &rejoined));
            CHECK_EQ_INT(stats.device_count, 3);
            CHECK(stats.devices[2].columns.width > 0);
            cv_proxy_stats ps;
            CHECK_OK(cv_proxy_get_stats(back, &ps));
            CHECK(ps.peer_pushes >= frames);
        }
        cv_renderer_destroy(r);
        cv_render_output_free(&out);
        cv_render_output_free(&rejoined);
    }
    cv_context_destroy(ctx);
    unsetenv("CORVID_NODE_KEEPALIVE_MS");
    for (int i = 0; i < 3; i++)
        scratch_process_node_stop(&nodes[i]);
    cv_render_output_free(&local);
}

/* ---- a node whose network stops ---------------------------------------------------- */

typedef struct stall_plan {
    tcp_relay *relay;
    uint32_t after_frame;
    double stalled_at, resumed_at;
} stall_plan;

static void stall_after(uint32_t frame, uint32_t frames, void *user) {
    (void)frames;
    stall_plan *plan = user;
    if (frame == plan->after_frame) {
        tcp_relay_set_stall(plan->relay, true);
        plan->stalled_at = cv_now_ms();
    } else if (frame == plan->after_frame + 1) {
        plan->resumed_at = cv_now_ms(); /* the frame after the stall completed, on the survivors */
    }
}

static void node_stalled(const cv_scene *scene, const cv_bvh *bvh) {
    const uint32_t frames = 4;
    cv_render_output local = { 0 };
    CHECK_OK(render_local(scene, bvh, frames, &local));
    setenv("CORVID_NODE_KEEPALIVE_MS", "1500", 1); /* a silent node is noticed within about 3 s */
    cv_node_config quick = { .peer_deadline_ms = 10000, .peer_keepalive_ms = 1500 };
    scratch_node nodes[2];
    CHECK_OK(scratch_node_start_secured(&nodes[0], cv_vulkan_backend(), 1, &quick));
    CHECK_OK(scratch_node_start_secured(&nodes[1], cv_vulkan_backend(), 1, &quick));
    tcp_relay *relay = NULL;
    CHECK_EQ_INT(tcp_relay_start(cv_node_port(nodes[1].node), 0, &relay), 0);
    char through[64];
    snprintf(through, sizeof(through), "127.0.0.1:%d", relay ? tcp_relay_port(relay) : 0);
    cv_context *ctx;
    cv_device *devices[2] = { 0 };
    CHECK_OK(cv_context_create(NULL, &ctx));
    CHECK_OK(
        cv_device_create(ctx, cv_proxy_backend(), &(cv_device_desc){ .endpoint = nodes[0].endpoint }, &devices[0]));
    CHECK_OK(cv_device_create(ctx, cv_proxy_backend(), &(cv_device_desc){ .endpoint = through }, &devices[1]));
    if (relay && devices[0] && devices[1]) {
        cv_renderer *r = NULL;
        cv_render_output out = { 0 };
        cv_render_stats stats;
        cv_render_settings s = settings(frames);
        CHECK_OK(cv_renderer_create(devices, 2, scene, bvh, &r));
        stall_plan plan = { .relay = relay, .after_frame = 1 };
        CHECK_OK(cv_renderer_render(r, &s, &out, &stats, stall_after, &plan));
        CHECK(same_image(&local, &out));
        CHECK_EQ_INT(stats.devices_lost, 1);
        CHECK(cv_device_is_lost(devices[1]) && !cv_device_is_lost(devices[0]));
        /* Keepalive 1.5 s + 1.5 s: the frame after the stall ends before the default keepalive (10 s + 5 s)
         * would even notice, and well before the request timeout (120 s); generous for a loaded machine. */
        double took = plan.resumed_at - plan.stalled_at;
        fprintf(stderr, "stalled node noticed and its frame done again on the survivor in %.0f ms\n", took);
        CHECK(took > 0 && took < 14000);
        cv_renderer_destroy(r);
        cv_render_output_free(&out);
    }
    cv_context_destroy(ctx);
    tcp_relay_stop(relay);
    unsetenv("CORVID_NODE_KEEPALIVE_MS");
    for (int i = 0; i < 2; i++) {
        CHECK_EQ_INT(scratch_node_wait_sessions(&nodes[i], 5000), 0);
        scratch_node_stop(&nodes[i]);
    }
    cv_render_output_free(&local);
}

/* ---- metrics during a drain ------------------------------------------------------------ */

static int free_port(void) {
    int fd = socket(AF_INET, SOCK_STREAM, 0);
    struct sockaddr_in a = { .sin_family = AF_INET, .sin_addr.s_addr = htonl(INADDR_LOOPBACK) };
    socklen_t len = sizeof(a);
    int port = 0;
    if (fd >= 0 && bind(fd, (struct sockaddr *)&a, sizeof(a)) == 0 &&
        getsockname(fd, (struct sockaddr *)&a, &len) == 0)
        port = ntohs(a.sin_port);
    if (fd >= 0)
        close(fd);
    return port;
}

/* GET /metrics from 127.0.0.1:port into out (NUL-terminated); false if nothing came. */
static bool scrape(int port, char *out, size_t cap) {
    int fd = socket(AF_INET, SOCK_STREAM, 0);
    struct sockaddr_in a = { .sin_family = AF_INET,
                             .sin_port = htons((uint16_t)port),
                             .sin_addr.s_addr = htonl(INADDR_LOOPBACK) };
    size_t got = 0;
    if (fd >= 0 && connect(fd, (struct sockaddr *)&a, sizeof(a)) == 0) {
        static const char req[] = "GET /metrics HTTP/1.0\r\n\r\n";
        if (write(fd, req, sizeof(req) - 1) == (ssize_t)(sizeof(req) - 1))
            for (ssize_t n; got + 1 < cap && (n = read(fd, out + got, cap - 1 - got)) > 0;)
                got += (size_t)n;
    }
    if (fd >= 0)
        close(fd);
    out[got] = '\0';
    return got > 0;
}

static void drain_metrics(const char *node_binary) {
    char port[16];
    snprintf(port, sizeof(port), "%d", free_port());
    const char *const extra[] = { "--metrics-port", port, "--drain-timeout", "20", "--quiet", NULL };
    scratch_process_node n = { 0 };
    CHECK_OK(scratch_process_node_start(&n, node_binary, 1, 0, extra));
    cv_context *ctx;
    cv_device *dev = NULL;
    CHECK_OK(cv_context_create(NULL, &ctx));
    CHECK_OK(cv_device_create(ctx, cv_proxy_backend(), &(cv_device_desc){ .endpoint = n.endpoint }, &dev));
    char *text = malloc(1 << 16);
    if (dev && n.pid && text) {
        kill(n.pid, SIGTERM); /* drains: the session goes on, new ones are refused */
        bool draining = false;
        for (int i = 0; i < 400 && !draining; i++) {
            nanosleep(&(struct timespec){ 0, 50 * 1000 * 1000 }, NULL);
            draining = scrape(atoi(port), text, 1 << 16) && strstr(text, "\ncorvid_node_draining 1");
        }
        CHECK(draining);
        CHECK(strstr(text, "\ncorvid_node_sessions_active 1") != NULL);
        cv_context_destroy(ctx); /* the session ends: the node stops */
        ctx = NULL;
        int status = -1;
        for (int i = 0; i < 1200 && waitpid(n.pid, &status, WNOHANG) == 0; i++)
            nanosleep(&(struct timespec){ 0, 50 * 1000 * 1000 }, NULL);
        CHECK(WIFEXITED(status) && WEXITSTATUS(status) == 0);
        n.pid = 0;
    }
    free(text);
    if (ctx)
        cv_context_destroy(ctx);
    scratch_process_node_stop(&n);
}

int main(int argc, char **argv) {
    if (argc < 2) {
        fprintf(stderr, "usage: node_cluster CORVID_NODE_BINARY\n");
        return 2;
    }
    cv_scene *scene = NULL;
    cv_bvh *bvh = NULL;
    CHECK_OK(cv_scene_make_room(1, &scene));
    CHECK_OK(cv_bvh_build_flat(scene, NULL, &bvh));
    if (!scene || !bvh)
        return check_report("node_cluster");
    cv_render_output local = { 0 };
    CHECK_OK(render_local(scene, bvh, 3, &local));
    three_nodes(scene, bvh, &local);
    node_killed(argv[1], scene, bvh);
    node_stalled(scene, bvh);
    drain_metrics(argv[1]);
    CHECK_EQ_INT(cv_vulkan_validation_message_count(), 0);
    CHECK_NOTHING_LIVE();
    cv_render_output_free(&local);
    cv_bvh_destroy(bvh);
    cv_scene_destroy(scene);
    return check_report("node_cluster");
}
