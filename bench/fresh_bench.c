/* bench_fresh: what zeroing new resources costs, beside the frame it serves.
 *
 * A buffer or texture's memory may hold an earlier owner's data (on a node,
 * another session's), so the Vulkan backend hands out every new resource
 * zeroed: a host memset where the memory is mapped, else a GPU fill or clear
 * batched before the next submission (vk_immediate.h). The renderer creates
 * its resources once, when its graph is first baked, so the cost falls on the
 * first frame of a render, not on every frame.
 *
 * For each size, on the devices given (--gpus/--adapters, as corvid-render),
 * this renders the procedural room through the renderer API: one render of
 * --frames frames, then reads each device's zeroing figures
 * (cv_vulkan_memory_stats: bytes, and host time of the submissions that
 * carried the fills, an upper bound) and prints them beside the render's
 * mean frame time: the peer. The share of one frame is the figure issue 23's
 * goal names; the share of the render is what a user pays. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bench_util.h"
#include "corvid/bvh.h"
#include "corvid/renderer.h"
#include "corvid/scene.h"
#include "corvid/scene_procedural.h"
#include "corvid/vulkan.h"
#include "env_vulkan.h"

#define MAX_SIZES 8

typedef struct options {
    uint32_t widths[MAX_SIZES], heights[MAX_SIZES], size_count;
    uint32_t frames;
    bool validation;
} options;

static void usage(FILE *f) {
    fprintf(f,
            "usage: bench_fresh [options]\n"
            "Renders the room and prints the time spent zeroing new resources beside the frame time.\n"
            "  --sizes LIST       image sizes, e.g. 640x360,1920x1080 (default 640x360)\n"
            "  --frames N         frames per render (default 4)\n"
            "  --adapters LIST    Vulkan adapters (names or indices; default: the default adapter)\n"
            "  --gpus N           devices (default 1); --virtual-gpus N per adapter\n"
            "  --validation       enable the Vulkan validation layer\n"
            "  --quick            160x90, 2 frames\n");
}

static bool parse_sizes(const char *list, options *o) {
    o->size_count = 0;
    for (const char *p = list; *p && o->size_count < MAX_SIZES;) {
        unsigned w, h;
        int used = 0;
        if (sscanf(p, "%ux%u%n", &w, &h, &used) != 2 || !w || !h || w > 16384 || h > 16384)
            return false;
        o->widths[o->size_count] = w;
        o->heights[o->size_count++] = h;
        p += used;
        if (*p == ',')
            p++;
        else if (*p)
            return false;
    }
    return o->size_count > 0;
}

static int parse_options(int argc, char **argv, options *o) {
    *o = (options){ .widths = { 640 }, .heights = { 360 }, .size_count = 1, .frames = 4 };
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            usage(stdout);
            return 0;
        } else if (!strcmp(a, "--sizes") && i + 1 < argc) {
            if (!parse_sizes(argv[++i], o)) {
                fprintf(stderr, "bench_fresh: --sizes %s: give WxH[,WxH...], each side 1..16384\n", argv[i]);
                return 2;
            }
        } else if (!strcmp(a, "--frames") && i + 1 < argc) {
            char *end;
            unsigned long n = strtoul(argv[++i], &end, 10);
            if (*end || n < 1 || n > 1024) {
                fprintf(stderr, "bench_fresh: --frames %s: 1..1024\n", argv[i]);
                return 2;
            }
            o->frames = (uint32_t)n;
        } else if (!strcmp(a, "--validation")) {
            o->validation = true;
        } else if (!strcmp(a, "--quick")) {
            o->widths[0] = 160, o->heights[0] = 90, o->size_count = 1, o->frames = 2;
        } else {
            fprintf(stderr, "bench_fresh: unknown option '%s' (see --help)\n", a);
            return 2;
        }
    }
    return -1;
}

/* One render at w x h on the devices; prints its row. False on failure. */
static bool measure(cv_device **devices, uint32_t count, const cv_scene *scene, const cv_bvh *bvh, uint32_t w,
                    uint32_t h, uint32_t frames) {
    cv_renderer *r = NULL;
    cv_result res = cv_renderer_create(devices, count, scene, bvh, &r);
    cv_render_settings settings = { .width = w, .height = h, .frames = frames };
    cv_render_output out = { 0 };
    cv_render_stats stats = { 0 };
    double start = bench_now();
    if (res == CV_OK)
        res = cv_renderer_render(r, &settings, &out, &stats, NULL, NULL);
    double wall_ms = (bench_now() - start) * 1e3;
    if (res != CV_OK) {
        fprintf(stderr, "bench_fresh: %ux%u: %s\n", w, h, cv_last_error());
        cv_renderer_destroy(r);
        return false;
    }
    for (uint32_t d = 0; d < count; d++) {
        cv_vulkan_memory_stats m;
        if (cv_vulkan_get_memory_stats(devices[d], &m) != CV_OK)
            continue;
        printf("%5ux%-5u %-6s %9.1f %9.2f %10.2f %9.2f%% %9.3f%%\n", w, h, cv_device_label(devices[d]),
               (double)m.zeroed_bytes / 1e6, m.zero_ms, stats.frame_ms, 100.0 * m.zero_ms / stats.frame_ms,
               100.0 * m.zero_ms / wall_ms);
    }
    cv_render_output_free(&out);
    cv_renderer_destroy(r);
    return true;
}

int main(int argc, char **argv) {
    cv_vulkan_gpu_config gpu_config = { .total = 1 };
    if (cv_env_vulkan_gpu_args(&argc, argv, &gpu_config) != CV_OK || cv_env_vulkan_gpu_config(&gpu_config) != CV_OK) {
        fprintf(stderr, "bench_fresh: %s\n", cv_last_error());
        return 2;
    }
    options o;
    int rc = parse_options(argc, argv, &o);
    if (rc >= 0)
        return rc;
    char machine[256];
    bench_machine(machine, sizeof(machine));
    printf("bench_fresh on %s: zeroing of new resources (once per render) beside the hybrid frame, %u frames\n",
           machine, o.frames);
    cv_scene *scene = NULL;
    cv_bvh *bvh = NULL;
    cv_context *ctx = NULL;
    cv_vulkan_gpu_table table;
    cv_device *devices[CV_MAX_DEVICES] = { 0 };
    bool ok = cv_scene_make_room(1, &scene) == CV_OK && cv_bvh_build_flat(scene, NULL, &bvh) == CV_OK &&
              cv_vulkan_gpu_table_build(&gpu_config, &table) == CV_OK && cv_context_create(NULL, &ctx) == CV_OK &&
              cv_vulkan_create_devices(ctx, &table, o.validation, devices) == CV_OK;
    if (ok) {
        printf("%-11s %-6s %9s %9s %10s %10s %10s\n", "size", "device", "zeroed MB", "zero ms", "frame ms",
               "of a frame", "of render");
        /* A new set of devices per size, so each row counts one render's resources alone. */
        for (uint32_t s = 0; s < o.size_count && ok; s++) {
            if (s) {
                for (uint32_t d = 0; d < table.count; d++)
                    cv_device_destroy(devices[d]);
                ok = cv_vulkan_create_devices(ctx, &table, o.validation, devices) == CV_OK;
            }
            ok = ok && measure(devices, table.count, scene, bvh, o.widths[s], o.heights[s], o.frames);
        }
        for (uint32_t d = 0; d < table.count && ok; d++)
            cv_device_destroy(devices[d]);
    } else {
        fprintf(stderr, "bench_fresh: set-up: %s\n", cv_last_error());
    }
    cv_context_destroy(ctx);
    cv_bvh_destroy(bvh);
    cv_scene_destroy(scene);
    if (o.validation && cv_vulkan_validation_message_count() != 0) {
        fprintf(stderr, "bench_fresh: %u validation messages\n", cv_vulkan_validation_message_count());
        return 1;
    }
    return ok ? 0 : 1;
}
