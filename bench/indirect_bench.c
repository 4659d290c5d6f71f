/* bench_indirect: the cost of the bound on dispatch_indirect (server/vulkan/
 * vk_indirect.h: one extra one-invocation dispatch and a barrier before each
 * indirect dispatch), measured as N indirect dispatches against the same N
 * direct dispatches of test.fill_u32, in one list each, on a Vulkan device.
 * Prints the GPU time of the list (a marker's timing) and the host time of
 * submit + wait, medians over the repetitions, and the difference per dispatch.
 *
 *   bench_indirect [--adapter A] [--count N] [--groups G] [--reps R] */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bench_util.h"
#include "corvid/context.h"
#include "corvid/device.h"
#include "corvid/vulkan.h"

typedef struct figures {
    double gpu_ms, host_ms;
} figures;

static int compare(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

static double median(double *v, uint32_t n) {
    qsort(v, n, sizeof(*v), compare);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

typedef struct setup {
    cv_context *ctx;
    cv_device *dev;
    cv_buffer out, args;
    cv_pipeline fill;
    cv_cmdlist list;
} setup;

static cv_result record(setup *s, bool indirect, uint32_t count, uint32_t groups) {
    cv_command_list *l;
    cv_result r = cv_cmdlist_begin(s->ctx, s->list, &l);
    if (r != CV_OK)
        return r;
    cv_binding b = { .resource = cv_any(s->out) };
    const uint32_t push[2] = { 1, groups * 64 };
    cv_cmd_begin_marker(l, CV_QUEUE_COMPUTE, &(cv_begin_marker_args){ .label = "dispatches" });
    for (uint32_t i = 0; i < count; i++) {
        if (indirect)
            cv_cmd_dispatch_indirect(l, CV_QUEUE_COMPUTE,
                                     &(cv_dispatch_indirect_args){ .pipeline = s->fill,
                                                                   .bindings = &b,
                                                                   .bindings_count = 1,
                                                                   .push = push,
                                                                   .push_size = sizeof(push),
                                                                   .args = s->args });
        else
            cv_cmd_dispatch(l, CV_QUEUE_COMPUTE,
                            &(cv_dispatch_args){ .pipeline = s->fill,
                                                 .bindings = &b,
                                                 .bindings_count = 1,
                                                 .push = push,
                                                 .push_size = sizeof(push),
                                                 .groups_x = groups,
                                                 .groups_y = 1,
                                                 .groups_z = 1 });
    }
    cv_cmd_end_marker(l, CV_QUEUE_COMPUTE, &(cv_end_marker_args){ 0 });
    return cv_command_list_end(l);
}

static cv_result measure(setup *s, bool indirect, uint32_t count, uint32_t groups, uint32_t reps, figures *out) {
    cv_result r = record(s, indirect, count, groups);
    double *gpu = calloc(reps, sizeof(double)), *host = calloc(reps, sizeof(double));
    for (uint32_t i = 0; r == CV_OK && i <= reps; i++) { /* the first run warms up */
        uint64_t t = 0;
        double start = bench_now();
        r = cv_device_submit(s->dev, s->list, &t);
        if (r == CV_OK)
            r = cv_device_wait(s->dev, t, UINT64_MAX);
        double end = bench_now();
        cv_pass_timing timing;
        uint32_t n = 0;
        if (r == CV_OK)
            r = cv_device_timings(s->dev, t, &timing, 1, &n);
        if (r == CV_OK && i > 0) {
            host[i - 1] = (end - start) * 1e3;
            gpu[i - 1] = n ? timing.duration_ms : 0.0;
        }
    }
    if (r == CV_OK)
        *out = (figures){ median(gpu, reps), median(host, reps) };
    free(gpu);
    free(host);
    return r;
}

static cv_result build(setup *s, const char *adapter, uint32_t groups) {
    cv_result r = cv_context_create(NULL, &s->ctx);
    cv_device_desc desc = { .adapter = adapter, .label = "bench" };
    if (r == CV_OK)
        r = cv_device_create(s->ctx, cv_vulkan_backend(), &desc, &s->dev);
    if (r == CV_OK)
        r = cv_buffer_create(s->ctx, &(cv_buffer_desc){ .size = (uint64_t)groups * 256, .label = "out" }, &s->out);
    if (r == CV_OK)
        r = cv_buffer_create(s->ctx,
                             &(cv_buffer_desc){ .size = 16, .usage = CV_BUFFER_USAGE_INDIRECT, .label = "args" },
                             &s->args);
    if (r == CV_OK)
        r = cv_pipeline_create(s->ctx, "test.fill_u32", &s->fill);
    if (r == CV_OK)
        r = cv_cmdlist_create(s->ctx, &s->list);
    if (r == CV_OK)
        r = cv_device_load(s->dev, cv_any(s->out));
    if (r == CV_OK)
        r = cv_device_load(s->dev, cv_any(s->args));
    if (r == CV_OK)
        r = cv_device_load(s->dev, cv_any(s->fill));
    const uint32_t counts[4] = { groups, 1, 1, 0 };
    if (r == CV_OK)
        r = cv_device_write_buffer(s->dev, s->args, 0, sizeof(counts), counts);
    return r;
}

int main(int argc, char **argv) {
    const char *adapter = NULL;
    uint32_t count = 256, groups = 1, reps = 20;
    for (int i = 1; i + 1 < argc; i += 2) {
        if (!strcmp(argv[i], "--adapter"))
            adapter = argv[i + 1];
        else if (!strcmp(argv[i], "--count"))
            count = (uint32_t)strtoul(argv[i + 1], NULL, 10);
        else if (!strcmp(argv[i], "--groups"))
            groups = (uint32_t)strtoul(argv[i + 1], NULL, 10);
        else if (!strcmp(argv[i], "--reps"))
            reps = (uint32_t)strtoul(argv[i + 1], NULL, 10);
        else {
            fprintf(stderr, "usage: bench_indirect [--adapter A] [--count N] [--groups G] [--reps R]\n");
            return 2;
        }
    }
    if (!count || !groups || !reps || groups > 65535) {
        fprintf(stderr, "bench_indirect: --count, --groups (at most 65535) and --reps must be positive\n");
        return 2;
    }
    setup s = { 0 };
    figures direct = { 0 }, indirect = { 0 };
    cv_result r = build(&s, adapter, groups);
    if (r == CV_OK)
        r = measure(&s, false, count, groups, reps, &direct);
    if (r == CV_OK)
        r = measure(&s, true, count, groups, reps, &indirect);
    if (r == CV_OK) {
        char machine[256];
        bench_machine(machine, sizeof(machine));
        printf("bench_indirect: %s, device '%s'; %u dispatches of %u group(s) of 64 per list, median of %u\n",
               machine, cv_device_get_info(s.dev)->name, count, groups, reps);
        printf("  %-10s %12s %12s\n", "", "GPU ms", "host ms");
        printf("  %-10s %12.3f %12.3f\n", "direct", direct.gpu_ms, direct.host_ms);
        printf("  %-10s %12.3f %12.3f\n", "indirect", indirect.gpu_ms, indirect.host_ms);
        printf("  bound: %+.2f us GPU, %+.2f us host per indirect dispatch\n",
               (indirect.gpu_ms - direct.gpu_ms) * 1e3 / count, (indirect.host_ms - direct.host_ms) * 1e3 / count);
    } else {
        fprintf(stderr, "bench_indirect: %s\n", cv_last_error());
    }
    if (s.dev)
        cv_device_destroy(s.dev);
    if (s.ctx)
        cv_context_destroy(s.ctx);
    return r == CV_OK ? 0 : 1;
}
