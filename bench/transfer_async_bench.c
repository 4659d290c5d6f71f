/* bench_transfer_async: asynchronous transfers through a ring
 * (cv_transfer_buffer_async, transfer.h) against the synchronous
 * cv_transfer_buffer of the same bytes on the same path, side by side in one
 * run, between two Vulkan devices (by default two virtual GPUs of the
 * default adapter), secondary to primary as the renderer's columns go.
 *
 * For each path a pair can take asynchronously (host-import, shared) and each
 * size, a round moves BATCH transfers one way: synchronously (each returns
 * when the bytes arrived), then asynchronously (queued back to back through a
 * 2-slot ring, then one wait for the last destination ticket). Rounds
 * alternate until both had --min-time; the figures are GB/s of the median
 * round. The async figure is what a frame pays when it does not wait: the
 * copies' own time on the two queues. Bytes are checked after every round.
 *
 *   bench_transfer_async [--adapters LIST] [--sizes 1M,8M,64M] [--min-time S] [--validation] */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bench_util.h"
#include "corvid/corvid.h"
#include "corvid/vulkan.h"
#include "env_vulkan.h"

#define BATCH 8
#define MAX_ROUNDS 4096
#define MAX_SIZES 16

static int cmp_double(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static double median(double *v, uint32_t n) {
    qsort(v, n, sizeof(double), cmp_double);
    return n ? v[n / 2] : 0.0;
}

static bool check_bytes(cv_device *dst, cv_buffer b, const uint8_t *want, uint8_t *got, uint64_t bytes) {
    if (cv_device_read_buffer(dst, b, 0, bytes, got) != CV_OK || memcmp(got, want, bytes) != 0) {
        fprintf(stderr, "bench_transfer_async: the bytes that arrived differ (%s)\n", cv_last_error());
        return false;
    }
    return true;
}

/* One size on one path: prints a row. */
static bool row(cv_context *ctx, cv_device *src, cv_device *dst, cv_transfer_path path, uint64_t bytes,
                double min_time) {
    cv_buffer b;
    cv_buffer_desc d = { .size = bytes };
    snprintf(d.label, sizeof d.label, "moved");
    if (cv_buffer_create(ctx, &d, &b) != CV_OK || cv_device_load(src, cv_any(b)) != CV_OK ||
        cv_device_load(dst, cv_any(b)) != CV_OK) {
        fprintf(stderr, "bench_transfer_async: buffers: %s\n", cv_last_error());
        return false;
    }
    uint8_t *data = malloc(bytes), *got = malloc(bytes);
    for (uint64_t i = 0; data && i < bytes; i++)
        data[i] = (uint8_t)(i * 131 + (i >> 12));
    cv_transfer_ring *ring = NULL;
    bool ok = data && got && cv_device_write_buffer(src, b, 0, bytes, data) == CV_OK &&
              cv_transfer_ring_create(src, dst, (bytes + 255) / 256 * 256, 2, &ring) == CV_OK;
    if (!ok)
        fprintf(stderr, "bench_transfer_async: %s: %s\n", cv_transfer_path_name(path), cv_last_error());
    static double sync_ms[MAX_ROUNDS], async_ms[MAX_ROUNDS];
    uint32_t rounds = 0;
    double spent_sync = 0, spent_async = 0;
    for (int warm = 1; ok && rounds < MAX_ROUNDS &&
                       (warm || rounds < 3 || spent_sync < min_time * 1e3 || spent_async < min_time * 1e3);
         warm = 0) {
        double t0 = bench_now();
        for (int i = 0; i < BATCH && ok; i++)
            ok = cv_transfer_buffer(src, b, 0, dst, b, 0, bytes, NULL) == CV_OK;
        double t1 = bench_now();
        cv_transfer_async a = { 0 };
        for (int i = 0; i < BATCH && ok; i++)
            ok = cv_transfer_buffer_async(ring, b, 0, b, 0, bytes, &a) == CV_OK;
        ok = ok && cv_device_wait(dst, a.dst_ticket, UINT64_MAX) == CV_OK;
        double t2 = bench_now();
        if (!ok)
            fprintf(stderr, "bench_transfer_async: %s\n", cv_last_error());
        ok = ok && check_bytes(dst, b, data, got, bytes);
        if (!warm) {
            sync_ms[rounds] = (t1 - t0) * 1e3 / BATCH;
            async_ms[rounds] = (t2 - t1) * 1e3 / BATCH;
            spent_sync += sync_ms[rounds] * BATCH;
            spent_async += async_ms[rounds] * BATCH;
            rounds++;
        }
    }
    if (ok) {
        double s = median(sync_ms, rounds), a = median(async_ms, rounds);
        char size[32];
        snprintf(size, sizeof size, bytes >= (1u << 20) ? "%llu MiB" : "%llu KiB",
                 (unsigned long long)(bytes >= (1u << 20) ? bytes >> 20 : bytes >> 10));
        printf("%-12s %9s %10.3f %10.2f %10.3f %10.2f %8.2fx %7u\n", cv_transfer_path_name(path), size, s,
               bytes / (s * 1e6), a, bytes / (a * 1e6), s / a, rounds);
    }
    cv_transfer_ring_destroy(ring);
    free(data);
    free(got);
    cv_buffer_destroy(ctx, b);
    return ok;
}

int main(int argc, char **argv) {
    cv_vulkan_gpu_config config = { 0 };
    if (cv_env_vulkan_gpu_args(&argc, argv, &config) != CV_OK || cv_env_vulkan_gpu_config(&config) != CV_OK) {
        fprintf(stderr, "bench_transfer_async: %s\n", cv_last_error());
        return 2;
    }
    uint64_t sizes[MAX_SIZES] = { 1u << 20, 8u << 20, 64u << 20 };
    uint32_t size_count = 3;
    double min_time = 0.3;
    bool validation = false;
    for (int i = 1; i < argc; i++) {
        if (strcmp(argv[i], "--sizes") == 0 && i + 1 < argc) {
            size_count = 0;
            for (char *p = argv[++i]; *p && size_count < MAX_SIZES;) {
                char *end;
                unsigned long long v = strtoull(p, &end, 10);
                if (*end == 'K' || *end == 'k')
                    v <<= 10, end++;
                else if (*end == 'M' || *end == 'm')
                    v <<= 20, end++;
                if (v == 0 || end == p) {
                    fprintf(stderr, "bench_transfer_async: bad --sizes '%s'\n", argv[i]);
                    return 2;
                }
                sizes[size_count++] = v;
                p = *end == ',' ? end + 1 : end;
            }
        } else if (strcmp(argv[i], "--min-time") == 0 && i + 1 < argc) {
            min_time = atof(argv[++i]);
        } else if (strcmp(argv[i], "--validation") == 0) {
            validation = true;
        } else {
            fprintf(stderr,
                    "usage: bench_transfer_async [--adapters LIST] [--sizes 1M,8M,64M] [--min-time S] "
                    "[--validation]\n");
            return 2;
        }
    }
    char adapter[16];
    uint32_t index;
    if (!config.adapters || !config.adapters[0]) {
        if (cv_vulkan_choose_adapter(CV_VULKAN_PURPOSE_RENDER, &index) != CV_OK) {
            fprintf(stderr, "bench_transfer_async: no Vulkan adapter: %s\n", cv_last_error());
            return 1;
        }
        snprintf(adapter, sizeof adapter, "%u", index);
        config.adapters = adapter;
    }
    if (config.total == 0 && config.virtual_per_adapter == 0)
        config.total = 2;
    cv_context *ctx = NULL;
    cv_vulkan_gpu_table table;
    cv_device *vk[CV_MAX_DEVICES] = { 0 };
    if (cv_context_create(NULL, &ctx) != CV_OK || cv_vulkan_gpu_table_build(&config, &table) != CV_OK ||
        table.count < 2 || cv_vulkan_create_devices(ctx, &table, validation, vk) != CV_OK) {
        fprintf(stderr, "bench_transfer_async: two Vulkan devices: %s\n", cv_last_error());
        cv_context_destroy(ctx);
        return 1;
    }
    char machine[256];
    bench_machine(machine, sizeof machine);
    printf("bench_transfer_async: %s -> %s (%s); %s\n", cv_device_label(vk[1]), cv_device_label(vk[0]),
           cv_device_get_info(vk[0])->name, machine);
    printf("%-12s %9s %10s %10s %10s %10s %9s %7s\n", "path", "size", "sync ms", "sync GB/s", "async ms",
           "async GB/s", "speedup", "rounds");
    bool ok = true;
    const cv_transfer_path paths[] = { CV_TRANSFER_HOST_IMPORT, CV_TRANSFER_SHARED };
    for (int p = 0; p < 2; p++) {
        cv_transfer_set_path(paths[p]);
        cv_transfer_path chosen;
        if (cv_transfer_choose_path(vk[1], vk[0], &chosen) != CV_OK) {
            printf("%-12s not run: %s\n", cv_transfer_path_name(paths[p]), cv_last_error());
            continue;
        }
        for (uint32_t s = 0; s < size_count && ok; s++)
            ok = row(ctx, vk[1], vk[0], paths[p], sizes[s], min_time);
    }
    cv_transfer_clear_path();
    for (uint32_t d = 0; d < table.count; d++)
        cv_device_destroy(vk[d]);
    cv_context_destroy(ctx);
    return ok ? 0 : 1;
}
