/* bench_trace: the trace_rays command on a Vulkan device, both trace paths
 * (Corvid's compute kernel and the driver's ray-tracing pipeline), against
 * Embree 3 on the same CPU cores, side by side in one run.
 *
 * For each scene (the procedural room, stress scenes of 1M and 10M triangles,
 * an imported model): BVH build Mtris/s of Corvid (CPU, binned SAH) and Embree
 * (rtcCommitScene), the device's accel write (upload, and the driver's BLAS and
 * TLAS build); then the ray sets of ray_sets.h from the primary hits of the
 * scene's camera (shadow rays to the sun, AO rays of 0.5 m and of unlimited
 * length, diffuse rays, mirror reflections; camera and random rays for
 * reference), each traced by every path with Mrays/s from the GPU timestamps of
 * the trace pass (and from submit-to-wait wall time beside it), by Embree's
 * single-ray and 16-wide packet calls, the ratios, and whether the hits agree.
 *
 * On a GPU the device is kept busy for --warmup seconds before each
 * measurement (its clock drops after ~2 s idle) and batches are millions of
 * rays; on lavapipe (a CPU device) the same cores run Embree. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "bench_util.h"
#include "corvid/bvh.h"
#include "corvid/corvid.h"
#include "corvid/ray_sets.h"
#include "corvid/scene_import.h"
#include "corvid/scene_procedural.h"
#include "corvid/trace_cpu.h"
#include "corvid/vulkan.h"
#include "embree_peer.h"

#define DEFAULT_MODEL "/usr/share/assimp/models/glTF2/2CylinderEngine-glTF-Binary/2CylinderEngine.glb"
#define FALLBACK_MODEL "/usr/share/assimp/models/OBJ/spider.obj"
#define MAX_STRESS 4
#define MAX_RUNS 100000

typedef enum embree_choice { EMBREE_DEFAULT, EMBREE_ON, EMBREE_OFF } embree_choice;

typedef struct options {
    const char *adapter;
    bool room, stress, model;
    uint64_t stress_triangles[MAX_STRESS];
    uint32_t stress_count;
    const char *model_path;
    uint32_t width, height; /* 0: by device type */
    bool compute, pipeline; /* paths asked for */
    embree_choice embree;
    uint32_t threads;
    double warmup, min_time; /* < 0: by device type */
    bool validation;
    uint32_t seed;
} options;

static void usage(FILE *f) {
    fprintf(f,
            "usage: bench_trace [options]\n"
            "Traces the same ray sets with Corvid's trace_rays on a Vulkan device (compute kernel\n"
            "and the driver's ray-tracing pipeline) and with Embree 3, and prints them side by side.\n"
            "  --adapter SPEC     Vulkan adapter: index or name part (default: the best GPU, else lavapipe)\n"
            "  --only LIST        subset of room,stress,model (default: all)\n"
            "  --stress N[,N..]   triangle counts of the stress scenes (default 1000000,10000000)\n"
            "  --model PATH       model to import (default: 2CylinderEngine.glb, else spider.obj)\n"
            "  --size WxH         primary rays (default 512x512 on a CPU device, 2048x2048 on a GPU)\n"
            "  --path P           compute, pipeline or both (default: both where offered)\n"
            "  --embree/--no-embree  run the Embree peer (default: on for a CPU device, off on a GPU)\n"
            "  --threads N        Embree and BVH build threads (default: all online CPUs)\n"
            "  --warmup S         seconds of device work before each measurement (default 0.5 on a GPU, 0)\n"
            "  --min-time S       trace time per measurement (default 0.5 on a GPU, 0.3 on a CPU device)\n"
            "  --validation       enable the Vulkan validation layer\n"
            "  --quick            smoke run: room and a 50k stress scene, 128x128 rays, no repetitions\n"
            "  --seed N           scenes and rays (default 1)\n"
            "  --help             this text\n");
}

static bool parse_stress(const char *v, options *o) {
    o->stress_count = 0;
    for (const char *p = v; *p && o->stress_count < MAX_STRESS;) {
        char *end;
        unsigned long long n = strtoull(p, &end, 10);
        if (end == p || n == 0)
            return false;
        o->stress_triangles[o->stress_count++] = n;
        p = *end == ',' ? end + 1 : end;
        if (*end && *end != ',')
            return false;
    }
    return o->stress_count > 0;
}

static bool parse(int argc, char **argv, options *o) {
    *o = (options){ .room = true,
                    .stress = true,
                    .model = true,
                    .stress_triangles = { 1000000, 10000000 },
                    .stress_count = 2,
                    .compute = true,
                    .pipeline = true,
                    .threads = (uint32_t)sysconf(_SC_NPROCESSORS_ONLN),
                    .warmup = -1.0,
                    .min_time = -1.0,
                    .seed = 1 };
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (strcmp(a, "--help") == 0 || strcmp(a, "-h") == 0) {
            usage(stdout);
            exit(0);
        } else if (strcmp(a, "--embree") == 0 || strcmp(a, "--no-embree") == 0) {
            o->embree = a[2] == 'e' ? EMBREE_ON : EMBREE_OFF;
            continue;
        } else if (strcmp(a, "--validation") == 0) {
            o->validation = true;
            continue;
        } else if (strcmp(a, "--quick") == 0) {
            o->stress_triangles[0] = 50000;
            o->stress_count = 1;
            o->width = o->height = 128;
            o->min_time = 0.0;
            o->warmup = 0.0;
            continue;
        }
        if (!v) {
            fprintf(stderr, "bench_trace: %s needs a value\n", a);
            return false;
        }
        i++;
        bool ok = true;
        if (strcmp(a, "--adapter") == 0) {
            o->adapter = v;
        } else if (strcmp(a, "--only") == 0) {
            o->room = strstr(v, "room") != NULL;
            o->stress = strstr(v, "stress") != NULL;
            o->model = strstr(v, "model") != NULL;
        } else if (strcmp(a, "--stress") == 0) {
            ok = parse_stress(v, o);
        } else if (strcmp(a, "--model") == 0) {
            o->model_path = v;
        } else if (strcmp(a, "--size") == 0) {
            ok = sscanf(v, "%ux%u", &o->width, &o->height) == 2 && o->width && o->height;
        } else if (strcmp(a, "--path") == 0) {
            o->compute = strcmp(v, "compute") == 0 || strcmp(v, "both") == 0;
            o->pipeline = strcmp(v, "pipeline") == 0 || strcmp(v, "both") == 0;
            ok = o->compute || o->pipeline;
        } else if (strcmp(a, "--threads") == 0) {
            o->threads = (uint32_t)strtoul(v, NULL, 10);
            ok = o->threads >= 1 && o->threads <= 256;
        } else if (strcmp(a, "--warmup") == 0) {
            o->warmup = strtod(v, NULL);
            ok = o->warmup >= 0.0;
        } else if (strcmp(a, "--min-time") == 0) {
            o->min_time = strtod(v, NULL);
            ok = o->min_time >= 0.0;
        } else if (strcmp(a, "--seed") == 0) {
            o->seed = (uint32_t)strtoul(v, NULL, 10);
        } else {
            fprintf(stderr, "bench_trace: unknown option %s (see --help)\n", a);
            return false;
        }
        if (!ok) {
            fprintf(stderr, "bench_trace: bad value '%s' for %s\n", v, a);
            return false;
        }
    }
    return true;
}

/* ---- the device side -------------------------------------------------------------- */

typedef struct bench {
    options o;
    cv_context *ctx;
    cv_device *dev;
    bool gpu; /* not a CPU adapter: warm up, bigger batches */
    bool pipeline_offered;
    bool embree;
} bench;

/* A list tracing `count` rays inside a timed pass, compiled for the path set
 * when it was made. */
typedef struct trace_run {
    cv_cmdlist list;
    cv_buffer rays, hits;
    uint32_t count;
} trace_run;

static bool run_init(bench *b, cv_accel accel, const cv_ray_set *set, uint32_t flags, trace_run *run) {
    *run = (trace_run){ .count = set->count };
    uint64_t ray_bytes = (uint64_t)set->count * sizeof(cv_ray), hit_bytes = (uint64_t)set->count * sizeof(cv_hit);
    cv_command_list *l;
    cv_result r = cv_buffer_create(b->ctx, &(cv_buffer_desc){ .size = ray_bytes, .label = "rays" }, &run->rays);
    if (r == CV_OK)
        r = cv_buffer_create(b->ctx, &(cv_buffer_desc){ .size = hit_bytes, .label = "hits" }, &run->hits);
    if (r == CV_OK)
        r = cv_device_load(b->dev, cv_any(run->rays));
    if (r == CV_OK)
        r = cv_device_load(b->dev, cv_any(run->hits));
    if (r == CV_OK)
        r = cv_device_write_buffer(b->dev, run->rays, 0, ray_bytes, set->rays);
    if (r == CV_OK)
        r = cv_cmdlist_create(b->ctx, &run->list);
    if (r == CV_OK)
        r = cv_cmdlist_begin(b->ctx, run->list, &l);
    if (r == CV_OK) {
        cv_cmd_begin_marker(l, CV_QUEUE_COMPUTE, &(cv_begin_marker_args){ .label = "trace" });
        cv_cmd_trace_rays(
            l, CV_QUEUE_COMPUTE,
            &(cv_trace_rays_args){
                .accel = accel, .rays = run->rays, .hits = run->hits, .count = set->count, .flags = flags });
        cv_cmd_end_marker(l, CV_QUEUE_COMPUTE, &(cv_end_marker_args){ 0 });
        r = cv_command_list_end(l);
    }
    /* Compiled now, on the path just set, so that no measurement includes it. */
    if (r == CV_OK)
        r = cv_device_compile(b->dev, run->list);
    if (r != CV_OK)
        fprintf(stderr, "bench_trace: trace list: %s\n", cv_last_error());
    return r == CV_OK;
}

static void run_finish(bench *b, trace_run *run) {
    cv_cmdlist_destroy(b->ctx, run->list);
    cv_buffer_destroy(b->ctx, run->rays);
    cv_buffer_destroy(b->ctx, run->hits);
}

/* One submission: *trace_s from the pass's timestamps (wall time when the
 * device has none), *wall_s from submit to the end of the wait. */
static bool submit_once(bench *b, trace_run *run, double *trace_s, double *wall_s) {
    uint64_t ticket;
    double t0 = bench_now();
    cv_result r = cv_device_submit(b->dev, run->list, &ticket);
    if (r == CV_OK)
        r = cv_device_wait(b->dev, ticket, UINT64_MAX);
    *wall_s = bench_now() - t0;
    cv_pass_timing timing;
    uint32_t n = 0;
    if (r == CV_OK)
        r = cv_device_timings(b->dev, ticket, &timing, 1, &n);
    if (r != CV_OK) {
        fprintf(stderr, "bench_trace: trace: %s\n", cv_last_error());
        return false;
    }
    *trace_s = n == 1 ? timing.duration_ms * 1e-3 : *wall_s;
    return true;
}

typedef struct rate {
    double trace, wall; /* Mrays/s; 0 = not measured */
} rate;

/* Keeps the device busy for the warm-up time, then submits until the trace
 * time reaches min_time (at least once). */
static rate measure_device(bench *b, trace_run *run) {
    double trace_s, wall_s, t0 = bench_now();
    while (bench_now() - t0 < b->o.warmup)
        if (!submit_once(b, run, &trace_s, &wall_s))
            return (rate){ 0 };
    double trace_total = 0.0, wall_total = 0.0;
    uint64_t rays = 0;
    for (int runs = 0; runs < MAX_RUNS && (runs == 0 || trace_total < b->o.min_time); runs++) {
        if (!submit_once(b, run, &trace_s, &wall_s))
            return (rate){ 0 };
        trace_total += trace_s;
        wall_total += wall_s;
        rays += run->count;
    }
    return (rate){ trace_total > 0 ? (double)rays / trace_total * 1e-6 : 0.0,
                   wall_total > 0 ? (double)rays / wall_total * 1e-6 : 0.0 };
}

static bool set_path(bench *b, cv_vulkan_trace_path path) {
    if (cv_vulkan_set_trace_path(b->dev, path) == CV_OK)
        return true;
    fprintf(stderr, "bench_trace: %s\n", cv_last_error());
    return false;
}

/* Traces a set on one path: its rate, and its hits in `hits`. */
static rate trace_on_path(bench *b, cv_accel accel, cv_vulkan_trace_path path, const cv_ray_set *set, uint32_t flags,
                          cv_hit *hits) {
    trace_run run;
    rate result = { 0 };
    if (set_path(b, path) && run_init(b, accel, set, flags, &run)) {
        result = measure_device(b, &run);
        if (cv_device_read_buffer(b->dev, run.hits, 0, (uint64_t)set->count * sizeof(cv_hit), hits) != CV_OK)
            fprintf(stderr, "bench_trace: hits: %s\n", cv_last_error());
        run_finish(b, &run);
    }
    return result;
}

/* ---- the Embree side ---------------------------------------------------------------- */

static double measure_embree(bench *b, embree_peer *peer, const cv_ray_set *set, bool occlusion, int width,
                             cv_hit *hits) {
    double total = 0.0;
    uint64_t rays = 0;
    do {
        double t0 = bench_now();
        embree_peer_trace(peer, set->rays, set->count, occlusion, width, b->o.threads, hits);
        total += bench_now() - t0;
        rays += set->count;
    } while (total < b->o.min_time);
    return total > 0.0 ? (double)rays / total * 1e-6 : 0.0;
}

/* ---- one scene ------------------------------------------------------------------------ */

enum { P_COMPUTE, P_PIPELINE, PATHS };
static const cv_vulkan_trace_path path_of[PATHS] = { CV_VULKAN_TRACE_COMPUTE, CV_VULKAN_TRACE_PIPELINE };

typedef struct scene_run {
    bench *b;
    const cv_scene *scene;
    cv_bvh *bvh;
    embree_peer *embree;
    cv_accel accel;
    bool path_on[PATHS];
    cv_hit *hits[PATHS + 1]; /* per path, and Embree's */
} scene_run;

/* Rays where one side hit and the other missed. */
static uint32_t hit_miss_differences(const cv_hit *a, const cv_hit *b, uint32_t n) {
    uint32_t k = 0;
    for (uint32_t i = 0; i < n; i++)
        k += (a[i].triangle == CV_BVH_INVALID) != (b[i].triangle == CV_BVH_INVALID);
    return k;
}

static void print_rate(rate r) {
    if (r.trace > 0)
        printf(" %8.2f (%7.2f)", r.trace, r.wall);
    else
        printf(" %8s %9s", "-", "");
}

static void print_number(double v) {
    if (v > 0)
        printf(" %9.2f", v);
    else
        printf(" %9s", "-");
}

static void trace_set(scene_run *s, const cv_ray_set *set) {
    bench *b = s->b;
    bool occlusion = cv_ray_kind_is_occlusion(set->kind);
    uint32_t flags = occlusion ? CV_TRACE_ANY_HIT : 0;
    rate device[PATHS] = { { 0 } };
    for (int p = 0; p < PATHS; p++)
        if (s->path_on[p])
            device[p] = trace_on_path(b, s->accel, path_of[p], set, flags, s->hits[p]);
    double embree1 = 0.0, embree16 = 0.0;
    if (s->embree) {
        embree1 = measure_embree(b, s->embree, set, occlusion, 1, s->hits[PATHS]);
        embree16 = measure_embree(b, s->embree, set, occlusion, 16, s->hits[PATHS]);
    }
    double best_embree = embree1 > embree16 ? embree1 : embree16;
    printf("  %-10s %8u %-7s", cv_ray_kind_name(set->kind), set->count, occlusion ? "any" : "closest");
    print_rate(device[P_COMPUTE]);
    print_rate(device[P_PIPELINE]);
    print_number(embree1);
    print_number(embree16);
    print_number(best_embree > 0 && device[P_COMPUTE].trace > 0 ? device[P_COMPUTE].trace / best_embree : 0);
    print_number(device[P_PIPELINE].trace > 0 ? device[P_COMPUTE].trace / device[P_PIPELINE].trace : 0);
    /* Hit/miss differences against the first tracer that ran (compute, else pipeline). */
    int ref = s->path_on[P_COMPUTE] ? P_COMPUTE : P_PIPELINE;
    printf("   ");
    if (s->path_on[P_COMPUTE] && s->path_on[P_PIPELINE])
        printf(" pipeline %u", hit_miss_differences(s->hits[P_PIPELINE], s->hits[ref], set->count));
    if (s->embree)
        printf(" embree %u", hit_miss_differences(s->hits[PATHS], s->hits[ref], set->count));
    printf("\n");
    fflush(stdout);
}

static void trace_all(scene_run *s) {
    bench *b = s->b;
    cv_ray_set_desc desc = {
        .width = b->o.width, .height = b->o.height, .seed = b->o.seed, .random_count = b->o.width * b->o.height
    };
    cv_ray_set primary;
    if (cv_ray_set_make(s->scene, CV_RAYS_PRIMARY, &desc, &primary) != CV_OK) {
        fprintf(stderr, "bench_trace: primary rays: %s\n", cv_last_error());
        return;
    }
    for (int p = 0; p <= PATHS; p++)
        s->hits[p] = calloc(primary.count, sizeof(cv_hit));
    printf(
        "  Mrays/s from the trace pass's timestamps (from submit-to-wait wall time);\n"
        "  embree on %u threads; ratios are compute / best embree and compute / pipeline;\n"
        "  last columns: rays whose hit/miss differs from the compute path's\n",
        b->o.threads);
    printf("  %-10s %8s %-7s %18s %18s %9s %9s %9s %9s\n", "rays", "count", "query", "compute", "pipeline", "embree1",
           "embree16", "/embree", "/pipeline");
    trace_set(s, &primary);
    /* The secondary rays start at the primary hits of the path that ran first. */
    const cv_hit *primary_hits = s->hits[s->path_on[P_COMPUTE] ? P_COMPUTE : P_PIPELINE];
    cv_hit *kept = malloc((size_t)primary.count * sizeof(cv_hit));
    memcpy(kept, primary_hits, (size_t)primary.count * sizeof(cv_hit));
    for (int kind = CV_RAYS_SHADOW; kind < CV_RAY_KIND_COUNT; kind++) {
        cv_ray_set set;
        cv_result r = kind == CV_RAYS_RANDOM
                          ? cv_ray_set_make(s->scene, CV_RAYS_RANDOM, &desc, &set)
                          : cv_ray_set_make_secondary(s->scene, (cv_ray_kind)kind, &desc, &primary, kept, &set);
        if (r != CV_OK) {
            fprintf(stderr, "bench_trace: %s rays: %s\n", cv_ray_kind_name((cv_ray_kind)kind), cv_last_error());
            continue;
        }
        if (set.count)
            trace_set(s, &set);
        cv_ray_set_free(&set);
    }
    free(kept);
    for (int p = 0; p <= PATHS; p++)
        free(s->hits[p]);
    cv_ray_set_free(&primary);
}

/* Builds (best of up to three runs for builds under a second). */
static bool build(scene_run *s, double *corvid_s, double *embree_s) {
    bench *b = s->b;
    cv_bvh_build_options opt = { .thread_count = b->o.threads };
    *corvid_s = INFINITY;
    for (int run = 0; run < 3 && (run == 0 || *corvid_s < 1.0); run++) {
        cv_bvh *bvh = NULL;
        double t0 = bench_now();
        if (cv_bvh_build_flat(s->scene, &opt, &bvh) != CV_OK) {
            fprintf(stderr, "bench_trace: BVH build: %s\n", cv_last_error());
            return false;
        }
        double t = bench_now() - t0;
        *corvid_s = t < *corvid_s ? t : *corvid_s;
        cv_bvh_destroy(s->bvh);
        s->bvh = bvh;
    }
    *embree_s = 0.0;
    if (b->embree) {
        s->embree = embree_peer_create(s->scene, b->o.threads, embree_s);
        if (!s->embree)
            return false;
        for (int run = 1; run < 3 && *embree_s < 1.0; run++) {
            double t = embree_peer_rebuild(s->embree);
            *embree_s = t < *embree_s ? t : *embree_s;
        }
    }
    return true;
}

/* Writes the accel on the compute path (upload only), then on the pipeline
 * path (upload and the driver's build), and reports both. */
static bool write_accel(scene_run *s) {
    bench *b = s->b;
    cv_accel_desc desc = { .triangle_count = s->bvh->tri_count, .node_count = s->bvh->node2_count, .label = "bench" };
    if (cv_accel_create(b->ctx, &desc, &s->accel) != CV_OK || cv_device_load(b->dev, cv_any(s->accel)) != CV_OK) {
        fprintf(stderr, "bench_trace: accel: %s\n", cv_last_error());
        return false;
    }
    double upload_s = 0.0, with_build_s = 0.0;
    for (int p = 0; p < PATHS; p++) {
        if (!s->path_on[p] || !set_path(b, path_of[p]))
            continue;
        double t0 = bench_now();
        if (cv_device_write_accel(b->dev, s->accel, s->bvh->nodes2, s->bvh->tris) != CV_OK) {
            fprintf(stderr, "bench_trace: accel write (%s path): %s\n", cv_vulkan_trace_path_name(path_of[p]),
                    cv_last_error());
            return false;
        }
        *(p == P_COMPUTE ? &upload_s : &with_build_s) = bench_now() - t0;
    }
    double tris = (double)s->bvh->tri_count;
    printf("  device accel write        ");
    if (s->path_on[P_COMPUTE])
        printf(" %8.1f ms upload (compute path)", upload_s * 1e3);
    if (s->path_on[P_PIPELINE])
        printf("%s %.1f ms upload + driver BLAS/TLAS build", s->path_on[P_COMPUTE] ? ";" : "", with_build_s * 1e3);
    if (s->path_on[P_COMPUTE] && s->path_on[P_PIPELINE] && with_build_s > upload_s)
        printf(" (build ~%.1f ms, %.2f Mtris/s)", (with_build_s - upload_s) * 1e3,
               tris / (with_build_s - upload_s) * 1e-6);
    printf("\n");
    return true;
}

static void bench_scene(bench *b, const char *name, cv_scene *scene) {
    if (!scene)
        return;
    printf("\n== %s: %llu world triangles (%llu stored), %u instances\n", name,
           (unsigned long long)cv_scene_world_triangle_count(scene),
           (unsigned long long)cv_scene_triangle_count(scene), cv_scene_instance_count(scene));
    fflush(stdout);
    scene_run s = { .b = b, .scene = scene, .path_on = { b->o.compute, b->o.pipeline && b->pipeline_offered } };
    double corvid_s, embree_s;
    if (build(&s, &corvid_s, &embree_s)) {
        double tris = (double)cv_scene_world_triangle_count(scene);
        printf("  build                          time      Mtris/s\n");
        printf("  corvid BVH (CPU)          %8.1f ms  %8.2f   (%u threads)\n", corvid_s * 1e3, tris / corvid_s * 1e-6,
               b->o.threads);
        if (s.embree)
            printf("  embree rtcCommitScene     %8.1f ms  %8.2f   corvid / embree: %.2fx the rate\n", embree_s * 1e3,
                   tris / embree_s * 1e-6, embree_s / corvid_s);
        fflush(stdout);
        if (write_accel(&s))
            trace_all(&s);
    }
    if (s.accel.id)
        cv_accel_destroy(b->ctx, s.accel);
    embree_peer_destroy(s.embree);
    cv_bvh_destroy(s.bvh);
    cv_scene_destroy(scene);
}

/* The device's own AUTO choice: the first accel written in AUTO mode (the
 * room's) makes it measure both paths. */
static void report_auto_choice(bench *b) {
    cv_scene *room = NULL;
    cv_bvh *bvh = NULL;
    cv_accel accel = { 0 };
    cv_vulkan_trace_status st;
    cv_result r = cv_scene_make_room(b->o.seed, &room);
    if (r == CV_OK)
        r = cv_bvh_build_flat(room, &(cv_bvh_build_options){ .thread_count = b->o.threads }, &bvh);
    if (r == CV_OK)
        r = cv_vulkan_set_trace_path(b->dev, CV_VULKAN_TRACE_AUTO);
    if (r == CV_OK)
        r = cv_accel_create(b->ctx,
                            &(cv_accel_desc){
                                .triangle_count = bvh->tri_count, .node_count = bvh->node2_count, .label = "auto" },
                            &accel);
    if (r == CV_OK)
        r = cv_device_load(b->dev, cv_any(accel));
    if (r == CV_OK)
        r = cv_device_write_accel(b->dev, accel, bvh->nodes2, bvh->tris);
    if (r == CV_OK)
        r = cv_vulkan_get_trace_status(b->dev, &st);
    if (r != CV_OK)
        fprintf(stderr, "bench_trace: AUTO measurement: %s\n", cv_last_error());
    else if (st.measured)
        printf(
            "device's own choice (AUTO, measured on the room, %u rays per query): compute %.2f, pipeline %.2f "
            "Mrays/s -> %s\n",
            st.measured_rays, st.compute_mrays, st.pipeline_mrays, cv_vulkan_trace_path_name(st.path));
    else
        printf("device's own choice: %s\n", cv_vulkan_trace_path_name(st.path));
    if (accel.id)
        cv_accel_destroy(b->ctx, accel);
    cv_bvh_destroy(bvh);
    cv_scene_destroy(room);
}

static bool open_device(bench *b) {
    if (cv_context_create(NULL, &b->ctx) != CV_OK)
        return false;
    cv_device_desc desc = { .adapter = b->o.adapter, .validation = b->o.validation, .label = "bench" };
    if (cv_device_create(b->ctx, cv_vulkan_backend(), &desc, &b->dev) != CV_OK) {
        fprintf(stderr, "bench_trace: device: %s\n", cv_last_error());
        return false;
    }
    const cv_device_info *info = cv_device_get_info(b->dev);
    cv_vulkan_adapter_info adapters[16];
    uint32_t count = 0;
    cv_vulkan_adapters(adapters, 16, &count);
    b->gpu = !(info->adapter_index < count && adapters[info->adapter_index].type == CV_VULKAN_ADAPTER_CPU);
    b->pipeline_offered = info->ray_tracing_pipeline;
    if (!b->o.compute && !b->pipeline_offered) {
        fprintf(stderr, "bench_trace: --path pipeline, but '%s' has no ray-tracing pipeline\n", info->name);
        return false;
    }
    b->embree = b->o.embree == EMBREE_ON || (b->o.embree == EMBREE_DEFAULT && !b->gpu);
    if (!b->o.width)
        b->o.width = b->o.height = b->gpu ? 2048 : 512;
    if (b->o.warmup < 0)
        b->o.warmup = b->gpu ? 0.5 : 0.0;
    if (b->o.min_time < 0)
        b->o.min_time = b->gpu ? 0.5 : 0.3;
    printf("device: %s (%s), %s; ray-tracing pipeline %s; GPU timestamps %s\n", info->name, info->driver,
           b->gpu ? "GPU" : "CPU device", b->pipeline_offered ? "offered" : "not offered",
           info->gpu_timestamps ? "yes" : "no");
    printf("paths: %s%s%s; embree: %s; %ux%u primary rays; warm-up %.2f s, min time %.2f s per measurement\n",
           b->o.compute ? "compute " : "", b->o.pipeline && b->pipeline_offered ? "pipeline " : "",
           b->o.pipeline && !b->pipeline_offered ? "(pipeline not offered)" : "",
           b->embree ? embree_peer_version() : "off", b->o.width, b->o.height, b->o.warmup, b->o.min_time);
    return true;
}

int main(int argc, char **argv) {
    bench b = { 0 };
    if (!parse(argc, argv, &b.o)) {
        usage(stderr);
        return 2;
    }
    char machine[320];
    bench_machine(machine, sizeof machine);
    printf("bench_trace: Corvid trace_rays (compute kernel, driver ray-tracing pipeline) vs Embree %s\n",
           embree_peer_version());
    printf("machine: %s\n", machine);
    if (!open_device(&b)) {
        if (b.dev)
            cv_device_destroy(b.dev);
        cv_context_destroy(b.ctx);
        return 1;
    }
    if (b.pipeline_offered)
        report_auto_choice(&b);
    if (b.o.room) {
        cv_scene *s = NULL;
        if (cv_scene_make_room(b.o.seed, &s) != CV_OK)
            fprintf(stderr, "bench_trace: room: %s\n", cv_last_error());
        bench_scene(&b, "room", s);
    }
    for (uint32_t i = 0; b.o.stress && i < b.o.stress_count; i++) {
        cv_scene *s = NULL;
        if (cv_scene_make_stress(b.o.seed, b.o.stress_triangles[i], &s) != CV_OK)
            fprintf(stderr, "bench_trace: stress scene: %s\n", cv_last_error());
        char name[64];
        snprintf(name, sizeof name, "stress %llu", (unsigned long long)b.o.stress_triangles[i]);
        bench_scene(&b, name, s);
    }
    if (b.o.model) {
        const char *path = b.o.model_path                     ? b.o.model_path
                           : access(DEFAULT_MODEL, R_OK) == 0 ? DEFAULT_MODEL
                                                              : FALLBACK_MODEL;
        cv_scene *s = NULL;
        if (cv_scene_import(path, &s) != CV_OK)
            fprintf(stderr, "bench_trace: model: %s\n", cv_last_error());
        bench_scene(&b, path, s);
    }
    cv_device_destroy(b.dev);
    cv_context_destroy(b.ctx);
    if (b.o.validation && cv_vulkan_validation_message_count() != 0) {
        fprintf(stderr, "bench_trace: %u validation messages\n", cv_vulkan_validation_message_count());
        return 1;
    }
    return 0;
}
