/* bench_graph_bake: the render graph's bake (graph.h) as the renderer calls
 * it every frame, the full bake against the partition step alone, side by
 * side in one run.
 *
 * The graph is the hybrid renderer's frame (a G-buffer multicast, rays and
 * visibility on every device gathered back, accumulation with history, three
 * filter passes, composite, a debug view: 9 passes, 12 resources) declared
 * with the pass builder, repeated `--frames` times in one graph (9, 90, 270
 * passes by default; at most 30 copies: each device's lists, 8 sets of them,
 * come from one context's 4096 list handles), on three mock devices, so that the figures are the
 * graph's own work and no backend's. Each bake gets a new split of the width
 * among the devices (two splits in turn, as the balancer moves boundaries):
 *   full       every bake bakes the structure too: a pass is disabled and
 *              enabled again before it (a construction call, the graph the same);
 *   partition  the structure is kept: windows and copy plans only.
 * The two run interleaved, round by round, so that background load falls on
 * both alike. Exit 1 if the two graphs' dumps differ after the same split, or
 * if a bake did (or did not) bake the structure when it should have. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bench_util.h"
#include "corvid/corvid.h"
#include "corvid/graph.h"

#define MAX_SIZES 8
#define MAX_FRAMES 30u
#define MIN_REPS 5
#define DEVICES 3u
#define WIDTH 640u
#define HEIGHT 360u

typedef struct options {
    uint32_t frames[MAX_SIZES];
    uint32_t size_n;
    double min_time;
} options;

static void usage(FILE *f) {
    fprintf(f,
            "usage: bench_graph_bake [options]\n"
            "Bakes a render graph shaped like the hybrid renderer's frame on %u mock devices with a new\n"
            "split of the width each time: the whole bake, against the partition step alone.\n"
            "  --frames LIST      copies of the 9-pass frame in one graph, 1..%u (default 1,10,30)\n"
            "  --min-time S       time per contender and size, at least %d bakes (default 0.5)\n"
            "  --quick            smoke run (< 5 s): the same sizes, 0.02 s per measurement\n"
            "  --help             this text\n",
            DEVICES, MAX_FRAMES, MIN_REPS);
}

static bool parse(int argc, char **argv, options *o) {
    *o = (options){ .frames = { 1, 10, 30 }, .size_n = 3, .min_time = 0.5 };
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (strcmp(a, "--help") == 0) {
            usage(stdout);
            exit(0);
        } else if (strcmp(a, "--quick") == 0) {
            o->min_time = 0.02;
        } else if (strcmp(a, "--min-time") == 0 && v) {
            o->min_time = strtod(v, NULL);
            i++;
            if (o->min_time < 0.0)
                return false;
        } else if (strcmp(a, "--frames") == 0 && v) {
            o->size_n = 0;
            for (const char *p = v; *p;) {
                char *end;
                unsigned long n = strtoul(p, &end, 10);
                if (end == p || n == 0 || n > MAX_FRAMES || o->size_n == MAX_SIZES)
                    return false;
                o->frames[o->size_n++] = (uint32_t)n;
                p = *end == ',' ? end + 1 : end;
                if (*end && *end != ',')
                    return false;
            }
            i++;
        } else {
            return false;
        }
    }
    return true;
}

static void record_nothing(const cv_graph_pass_context *pc, cv_command_list *list, void *user) {
    (void)pc, (void)list, (void)user;
}

typedef struct frame_builder {
    cv_graph *g;
    uint32_t copy; /* which copy of the frame: names are unique */
    cv_result res;
} frame_builder;

static cv_graph_builder *begin(frame_builder *f, const char *name, cv_queue_type queue, cv_mgpu_policy policy) {
    char label[CV_LABEL_MAX];
    snprintf(label, sizeof label, "%s %u", name, f->copy);
    return cv_graph_pass_begin(f->g, &(cv_graph_pass_desc){ label, queue, policy, record_nothing, NULL });
}

static cv_texture_desc texture(const frame_builder *f, const char *name, cv_format format) {
    cv_texture_desc d = { .width = WIDTH, .height = HEIGHT, .format = format };
    snprintf(d.label, sizeof d.label, "%s %u", name, f->copy);
    return d;
}

static void end(frame_builder *f, cv_graph_builder *b, cv_graph_pass *out) {
    cv_result res = cv_graph_pass_end(b, out);
    f->res = f->res == CV_OK ? res : f->res;
}

/* One hybrid frame; *debug its last pass (culled: it reaches no output). */
static void add_frame(frame_builder *f, cv_graph_resource vertices, cv_graph_pass *debug) {
    cv_graph_resource position = { 0 }, normal = { 0 }, depth = { 0 }, rays = { 0 }, visibility = { 0 },
                      accumulated = { 0 }, history = { 0 }, ping[4] = { { 0 } }, radiance = { 0 }, view = { 0 };
    cv_texture_desc d = texture(f, "accumulated", CV_FORMAT_RGBA16F);
    cv_result res = cv_graph_create_texture(f->g, &d, &accumulated);
    if (res == CV_OK)
        res = cv_graph_history(f->g, accumulated, &history);
    f->res = f->res == CV_OK ? res : f->res;
    cv_graph_builder *b = begin(f, "gbuffer", CV_QUEUE_GRAPHICS, CV_MGPU_PRIMARY_ONLY);
    cv_graph_pass_read(b, vertices, CV_GRAPH_STORAGE_READ);
    d = texture(f, "position", CV_FORMAT_RGBA32F);
    cv_graph_pass_create_texture(b, &d, CV_GRAPH_COLOR_TARGET, CV_GRAPH_TRANSFER_AUTO, &position);
    d = texture(f, "normal", CV_FORMAT_RGBA32F);
    cv_graph_pass_create_texture(b, &d, CV_GRAPH_COLOR_TARGET, CV_GRAPH_TRANSFER_AUTO, &normal);
    d = texture(f, "depth", CV_FORMAT_D32F);
    cv_graph_pass_create_texture(b, &d, CV_GRAPH_DEPTH_TARGET, CV_GRAPH_TRANSFER_AUTO, &depth);
    end(f, b, NULL);
    b = begin(f, "raygen", CV_QUEUE_COMPUTE, CV_MGPU_ALL_DEVICES);
    cv_graph_pass_read(b, position, CV_GRAPH_STORAGE_READ);
    cv_graph_pass_read(b, normal, CV_GRAPH_STORAGE_READ);
    cv_buffer_desc rd = { .size = (uint64_t)WIDTH * HEIGHT * CV_RAY_BYTES };
    snprintf(rd.label, sizeof rd.label, "rays %u", f->copy);
    cv_graph_pass_create_buffer(b, &rd, HEIGHT * CV_RAY_BYTES, CV_GRAPH_STORAGE_WRITE, CV_GRAPH_TRANSFER_AUTO, &rays);
    end(f, b, NULL);
    b = begin(f, "trace", CV_QUEUE_COMPUTE, CV_MGPU_ALL_DEVICES);
    cv_graph_pass_read(b, rays, CV_GRAPH_STORAGE_READ);
    d = texture(f, "visibility", CV_FORMAT_RGBA16F);
    cv_graph_pass_create_texture(b, &d, CV_GRAPH_STORAGE_WRITE, CV_GRAPH_TRANSFER_AUTO, &visibility);
    end(f, b, NULL);
    b = begin(f, "accumulate", CV_QUEUE_COMPUTE, CV_MGPU_PRIMARY_ONLY);
    cv_graph_pass_read(b, visibility, CV_GRAPH_STORAGE_READ);
    cv_graph_pass_read(b, history, CV_GRAPH_STORAGE_READ);
    cv_graph_pass_write(b, accumulated, CV_GRAPH_STORAGE_WRITE, CV_GRAPH_TRANSFER_AUTO);
    end(f, b, NULL);
    ping[0] = accumulated;
    for (int i = 0; i < 3; i++) {
        char name[16];
        snprintf(name, sizeof name, "filter %d", i + 1);
        b = begin(f, name, CV_QUEUE_COMPUTE, CV_MGPU_PRIMARY_ONLY);
        cv_graph_pass_read(b, position, CV_GRAPH_STORAGE_READ);
        cv_graph_pass_read(b, normal, CV_GRAPH_STORAGE_READ);
        cv_graph_pass_read(b, ping[i], CV_GRAPH_STORAGE_READ);
        d = texture(f, name, CV_FORMAT_RGBA16F);
        cv_graph_pass_create_texture(b, &d, CV_GRAPH_STORAGE_WRITE, CV_GRAPH_TRANSFER_AUTO, &ping[i + 1]);
        end(f, b, NULL);
    }
    b = begin(f, "composite", CV_QUEUE_COMPUTE, CV_MGPU_PRIMARY_ONLY);
    cv_graph_pass_read(b, position, CV_GRAPH_STORAGE_READ);
    cv_graph_pass_read(b, ping[3], CV_GRAPH_STORAGE_READ);
    cv_graph_pass_read(b, vertices, CV_GRAPH_STORAGE_READ);
    d = texture(f, "radiance", CV_FORMAT_RGBA32F);
    cv_graph_pass_create_texture(b, &d, CV_GRAPH_STORAGE_WRITE, CV_GRAPH_TRANSFER_AUTO, &radiance);
    end(f, b, NULL);
    b = begin(f, "debug view", CV_QUEUE_COMPUTE, CV_MGPU_PRIMARY_ONLY);
    cv_graph_pass_read(b, normal, CV_GRAPH_SAMPLED);
    d = texture(f, "debug normals", CV_FORMAT_RGBA32F);
    cv_graph_pass_create_texture(b, &d, CV_GRAPH_STORAGE_WRITE, CV_GRAPH_TRANSFER_AUTO, &view);
    end(f, b, debug);
    if (f->res == CV_OK)
        f->res = cv_graph_output(f->g, radiance);
}

typedef struct world {
    cv_context *ctx;
    cv_device *devices[DEVICES];
    cv_graph *graph;
    cv_buffer vertices;
    cv_graph_pass debug; /* the pass the full bakes toggle */
} world;

static cv_result world_open(world *w, uint32_t frames) {
    memset(w, 0, sizeof(*w));
    cv_result res = cv_context_create(NULL, &w->ctx);
    for (uint32_t d = 0; d < DEVICES && res == CV_OK; d++) {
        cv_device_desc desc = { 0 };
        snprintf(desc.label, sizeof desc.label, "mock%u", d);
        res = cv_device_create(w->ctx, cv_mock_backend(), &desc, &w->devices[d]);
    }
    if (res == CV_OK)
        res = cv_graph_create(w->ctx, w->devices, DEVICES, &w->graph);
    if (res == CV_OK)
        res = cv_buffer_create(w->ctx, &(cv_buffer_desc){ .size = 4096, .label = "scene vertices" }, &w->vertices);
    cv_graph_resource vertices = { 0 };
    if (res == CV_OK)
        res = cv_graph_import_buffer(w->graph, w->vertices, 0, &vertices);
    frame_builder f = { .g = w->graph, .res = res };
    for (uint32_t i = 0; i < frames && f.res == CV_OK; i++) {
        f.copy = i;
        add_frame(&f, vertices, &w->debug);
    }
    return f.res;
}

static void world_close(world *w) {
    cv_graph_destroy(w->graph);
    cv_context_destroy(w->ctx);
}

static cv_result bake(world *w, const cv_partition *p, bool full) {
    cv_result res = CV_OK;
    if (full) {
        res = cv_graph_enable_pass(w->graph, w->debug, false);
        if (res == CV_OK)
            res = cv_graph_enable_pass(w->graph, w->debug, true);
    }
    return res == CV_OK ? cv_graph_bake(w->graph, &(cv_graph_bake_desc){ .width = WIDTH, .partition = p }) : res;
}

static char *dump(const cv_graph *g) {
    char *text = NULL;
    size_t size = 0;
    FILE *f = open_memstream(&text, &size);
    if (!f)
        return NULL;
    cv_result res = cv_graph_dump_text(g, f);
    fclose(f);
    if (res != CV_OK) {
        free(text);
        return NULL;
    }
    return text;
}

typedef struct figures {
    uint32_t passes, steps;
    double full_us, partition_us;
    uint32_t full_structures, partition_structures; /* structure bakes during the timed bakes */
    bool same;
} figures;

static cv_result run_size(uint32_t frames, double min_time, figures *out) {
    world full, part;
    cv_result res = world_open(&full, frames);
    cv_result res2 = world_open(&part, frames);
    res = res == CV_OK ? res2 : res;
    cv_partition splits[2];
    if (res == CV_OK)
        res = cv_partition_split(WIDTH, 8, DEVICES, (const double[]){ 1.0, 1.0, 1.0 }, &splits[0]);
    if (res == CV_OK)
        res = cv_partition_split(WIDTH, 8, DEVICES, (const double[]){ 1.2, 0.9, 1.0 }, &splits[1]);
    cv_graph_stats before[2] = { { 0 } }, after[2] = { { 0 } };
    if (res == CV_OK)
        res = bake(&full, &splits[0], true); /* the first bake creates resources and lists: not timed */
    if (res == CV_OK)
        res = bake(&part, &splits[0], true);
    if (res == CV_OK)
        res = cv_graph_get_stats(full.graph, &before[0]);
    if (res == CV_OK)
        res = cv_graph_get_stats(part.graph, &before[1]);
    double spent[2] = { 0.0, 0.0 };
    uint32_t reps = 0;
    while (res == CV_OK && (reps < MIN_REPS || spent[0] < min_time || spent[1] < min_time)) {
        const cv_partition *p = &splits[(reps + 1) % 2];
        for (int c = 0; c < 2 && res == CV_OK; c++) {
            double t0 = bench_now();
            res = bake(c == 0 ? &full : &part, p, c == 0);
            spent[c] += bench_now() - t0;
        }
        reps++;
    }
    if (res == CV_OK)
        res = cv_graph_get_stats(full.graph, &after[0]);
    if (res == CV_OK)
        res = cv_graph_get_stats(part.graph, &after[1]);
    if (res == CV_OK) {
        char *a = dump(full.graph), *b = dump(part.graph);
        *out = (figures){ .passes = after[0].passes + after[0].culled,
                          .steps = after[0].steps,
                          .full_us = spent[0] / reps * 1e6,
                          .partition_us = spent[1] / reps * 1e6,
                          .full_structures = after[0].structure_bakes - before[0].structure_bakes,
                          .partition_structures = after[1].structure_bakes - before[1].structure_bakes,
                          .same = a && b && strcmp(a, b) == 0 };
        free(a);
        free(b);
        out->same = out->same && out->full_structures == reps && out->partition_structures == 0;
    }
    world_close(&full);
    world_close(&part);
    return res;
}

int main(int argc, char **argv) {
    options o;
    if (!parse(argc, argv, &o)) {
        usage(stderr);
        return 2;
    }
    char machine[256];
    bench_machine(machine, sizeof machine);
    printf("bench_graph_bake: cv_graph_bake of the hybrid frame on %u mock devices, %ux%u, a new split each bake\n",
           DEVICES, WIDTH, HEIGHT);
    printf("machine: %s\n\n", machine);
    printf("| passes | steps | full bake us | partition step us | full / partition | same dump |\n");
    printf("|---|---|---|---|---|---|\n");
    bool wrong = false;
    for (uint32_t i = 0; i < o.size_n; i++) {
        figures f = { 0 };
        cv_result res = run_size(o.frames[i], o.min_time, &f);
        if (res != CV_OK) {
            fprintf(stderr, "bench_graph_bake: %u frames: %s\n", o.frames[i], cv_last_error());
            return 1;
        }
        printf("| %u | %u | %.1f | %.1f | %.1fx | %s |\n", f.passes, f.steps, f.full_us, f.partition_us,
               f.full_us / f.partition_us, f.same ? "yes" : "NO");
        fflush(stdout);
        wrong |= !f.same;
    }
    if (wrong)
        fprintf(stderr,
                "bench_graph_bake: the partition-only bake differs from the full one (or the structure "
                "was baked when it should not have been)\n");
    return wrong ? 1 : 0;
}
