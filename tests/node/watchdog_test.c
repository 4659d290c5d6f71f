/* The node's submission watchdog (corvid-node --submit-timeout) against a
 * runaway GPU job, in a corvid-node process with two lavapipe devices.
 *
 * Session A submits a legal but enormous dispatch (65535 x 65535 groups of
 * test.fill_u32: hours on lavapipe; the bound on dispatch_indirect makes an
 * indirect runaway impossible, a direct one stays legal). Meanwhile session B,
 * on the other device, clears and copies a buffer and reads it back: it
 * completes. A's wait ends within seconds with the watchdog's error, not a
 * hang; a later session on A's node device works; the node logs the abandoned
 * device; and SIGTERM still drains the node (exit status 0) although the GPU
 * job never finishes. Before the watchdog, A's wait timed out and the node
 * never exited on SIGTERM. Copies and clears only for B and the later session:
 * lavapipe runs every device's compute dispatches in one thread pool, which the
 * runaway holds. */
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <time.h>

#include "check.h"
#include "corvid/clock.h"
#include "corvid/proxy.h"
#include "scratch_node.h"

#define WAIT_NS (30ull * 1000 * 1000 * 1000)

static cv_device *proxy_device(cv_context *ctx, const scratch_process_node *n, const char *adapter,
                               const char *label) {
    cv_device_desc desc = { .endpoint = n->endpoint, .adapter = adapter, .validation = true };
    snprintf(desc.label, sizeof(desc.label), "%s", label);
    cv_device *dev = NULL;
    CHECK_OK(cv_device_create(ctx, cv_proxy_backend(), &desc, &dev));
    return dev;
}

/* Clears a buffer to `value`, copies it to a second one, reads that back. */
static void copy_work(cv_context *ctx, cv_device *dev, uint32_t value) {
    cv_buffer a, b;
    cv_cmdlist list;
    cv_command_list *l;
    CHECK_OK(cv_buffer_create(ctx, &(cv_buffer_desc){ .size = 4096, .label = "a" }, &a));
    CHECK_OK(cv_buffer_create(ctx, &(cv_buffer_desc){ .size = 4096, .label = "b" }, &b));
    CHECK_OK(cv_device_load(dev, cv_any(a)));
    CHECK_OK(cv_device_load(dev, cv_any(b)));
    CHECK_OK(cv_cmdlist_create(ctx, &list));
    CHECK_OK(cv_cmdlist_begin(ctx, list, &l));
    cv_cmd_clear_buffer(l, CV_QUEUE_COPY, &(cv_clear_buffer_args){ .buffer = a, .size = 4096, .value = value });
    cv_cmd_copy_buffer(l, CV_QUEUE_COPY, &(cv_copy_buffer_args){ .src = a, .dst = b, .size = 4096 });
    CHECK_OK(cv_command_list_end(l));
    uint64_t t = 0;
    CHECK_OK(cv_device_submit(dev, list, &t));
    CHECK_OK(cv_device_wait(dev, t, WAIT_NS));
    uint32_t words[1024];
    CHECK_OK(cv_device_read_buffer(dev, b, 0, sizeof(words), words));
    uint32_t wrong = 0;
    for (uint32_t i = 0; i < 1024; i++)
        wrong += words[i] != value;
    CHECK_EQ_INT(wrong, 0);
    CHECK_OK(cv_cmdlist_destroy(ctx, list));
    CHECK_OK(cv_buffer_destroy(ctx, a));
    CHECK_OK(cv_buffer_destroy(ctx, b));
}

/* Submits 65535 x 65535 groups of test.fill_u32 (each group exits at once: count 0). */
static uint64_t submit_runaway(cv_context *ctx, cv_device *dev, cv_buffer out, cv_pipeline fill, cv_cmdlist list) {
    cv_command_list *l;
    CHECK_OK(cv_cmdlist_begin(ctx, list, &l));
    cv_binding b = { .resource = cv_any(out) };
    const uint32_t push[2] = { 1, 0 };
    cv_cmd_dispatch(l, CV_QUEUE_COMPUTE,
                    &(cv_dispatch_args){ .pipeline = fill,
                                         .bindings = &b,
                                         .bindings_count = 1,
                                         .push = push,
                                         .push_size = sizeof(push),
                                         .groups_x = 65535,
                                         .groups_y = 65535,
                                         .groups_z = 1 });
    CHECK_OK(cv_command_list_end(l));
    uint64_t t = 0;
    CHECK_OK(cv_device_submit(dev, list, &t));
    return t;
}

/* SIGTERM; the node must exit by itself (status 0) within 30 s, else it is killed. */
static void stop_node(scratch_process_node *n) {
    kill((pid_t)n->pid, SIGTERM);
    int status = -1;
    pid_t got = 0;
    for (int waited = 0; waited < 30000 && got == 0; waited += 50) {
        got = waitpid((pid_t)n->pid, &status, WNOHANG);
        if (got == 0)
            nanosleep(&(struct timespec){ 0, 50 * 1000 * 1000 }, NULL);
    }
    CHECK(got == (pid_t)n->pid);
    if (got == (pid_t)n->pid) {
        CHECK(WIFEXITED(status) && WEXITSTATUS(status) == 0);
        n->pid = 0;
    } else {
        fprintf(stderr, "node_watchdog: the node did not exit within 30 s of SIGTERM: killed\n");
        scratch_process_node_kill(n);
    }
    scratch_process_node_stop(n); /* removes its directory */
}

static bool log_has(const scratch_process_node *n, const char *text) {
    char path[300], line[1024];
    snprintf(path, sizeof(path), "%s/log", n->dir);
    FILE *f = fopen(path, "r");
    bool found = false;
    while (f && !found && fgets(line, sizeof(line), f))
        found = strstr(line, text) != NULL;
    if (f)
        fclose(f);
    return found;
}

int main(int argc, char **argv) {
    if (argc < 2) {
        fprintf(stderr, "usage: node_watchdog PATH-TO-corvid-node\n");
        return 2;
    }
    const char *const extra[] = { "--submit-timeout", "1", "--drain-timeout", "2", "--validation", NULL };
    /* Under ASan the node's leak check is off: the node deliberately abandons a device whose lavapipe
       queue thread still runs the runaway dispatch, and what that thread allocates is the driver's,
       reachable from nothing of Corvid's (the node keeps the abandoned contexts themselves reachable). */
    const char *asan = getenv("ASAN_OPTIONS");
    if (asan) {
        char options[512];
        snprintf(options, sizeof(options), "%s:detect_leaks=0", asan);
        setenv("ASAN_OPTIONS", options, 1);
    }
    scratch_process_node node = { 0 };
    CHECK_OK(scratch_process_node_start(&node, argv[1], 2, 0, extra));
    if (!node.pid)
        return check_report("node_watchdog");

    cv_context *ctx;
    CHECK_OK(cv_context_create(NULL, &ctx));
    cv_device *a = proxy_device(ctx, &node, "0", "runaway");
    cv_device *b = proxy_device(ctx, &node, "1", "neighbour");
    cv_buffer out;
    cv_pipeline fill;
    cv_cmdlist list;
    CHECK_OK(cv_buffer_create(ctx, &(cv_buffer_desc){ .size = 256, .label = "out" }, &out));
    CHECK_OK(cv_pipeline_create(ctx, "test.fill_u32", &fill));
    CHECK_OK(cv_cmdlist_create(ctx, &list));
    CHECK_OK(cv_device_load(a, cv_any(out)));
    CHECK_OK(cv_device_load(a, cv_any(fill)));

    double start = cv_now_ms() / 1e3;
    uint64_t t = submit_runaway(ctx, a, out, fill, list);
    copy_work(ctx, b, 0x5eed); /* the other session completes meanwhile */
    cv_result r = cv_device_wait(a, t, WAIT_NS);
    double waited = cv_now_ms() / 1e3 - start;
    /* The Completed with the watchdog's error, or the stream's end with it, whichever the client saw first. */
    CHECK(r == CV_ERROR_DEVICE_LOST || r == CV_ERROR_CONNECTION);
    CHECK(strstr(cv_last_error(), "did not complete in 1.000 s (corvid-node --submit-timeout)") != NULL);
    printf("node_watchdog: the runaway session ended after %.1f s: %s\n", waited, cv_last_error());
    bool lost = false; /* the stream's end follows the Completed */
    for (int i = 0; i < 100 && !(lost = cv_device_is_lost(a)); i++)
        nanosleep(&(struct timespec){ 0, 50 * 1000 * 1000 }, NULL);
    CHECK(lost);

    cv_device *c = proxy_device(ctx, &node, "0", "later"); /* a later session on the same node device */
    copy_work(ctx, c, 0xbeef);
    copy_work(ctx, b, 0xcafe);
    CHECK(log_has(&node, "its device abandoned"));
    CHECK(!log_has(&node, "corvid vulkan: "));          /* the validation layer (--validation) stayed quiet */
    CHECK(!log_has(&node, "WARNING: ThreadSanitizer")); /* the node process, in the TSan build */

    cv_device_destroy(a);
    cv_device_destroy(b);
    cv_device_destroy(c);
    cv_context_destroy(ctx);
    stop_node(&node);
    CHECK_NOTHING_LIVE();
    return check_report("node_watchdog");
}
