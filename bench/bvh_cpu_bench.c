/* bench_bvh_cpu: Corvid's CPU BVH against Embree 3, side by side, same run.
 *
 * For each scene (the procedural room, a stress scene of 1M triangles, 10M
 * with --big, and an imported model): BVH build time and Mtris/s of Corvid's
 * flat and two-level builds and of Embree's rtcCommitScene; then the ray
 * sets of ray_sets.h traced by Corvid's CPU reference traversal (skip and
 * two-child layouts, flat and two-level) and by Embree (rtcIntersect1 /
 * rtcOccluded1 and the 16-wide packet calls), all on the same number of
 * threads, with Mrays/s, ratios, and whether the hits agree. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "bench_util.h"
#include "corvid/bvh.h"
#include "corvid/ray_sets.h"
#include "corvid/scene_import.h"
#include "corvid/scene_procedural.h"
#include "corvid/trace_cpu.h"
#include "embree_peer.h"

#define DEFAULT_MODEL "/usr/share/assimp/models/glTF2/2CylinderEngine-glTF-Binary/2CylinderEngine.glb"
#define FALLBACK_MODEL "/usr/share/assimp/models/OBJ/spider.obj"

typedef struct options {
    uint32_t threads;
    uint32_t width, height;
    uint64_t stress_triangles;
    bool big;
    const char *model;
    bool room, stress, imported;
    double min_time;
    uint32_t seed;
} options;

static void usage(FILE *f) {
    fprintf(f,
            "usage: bench_bvh_cpu [options]\n"
            "Builds BVHs and traces ray sets with Corvid's CPU code and with Embree 3,\n"
            "on the same scenes, rays and threads, and prints both side by side.\n"
            "  --threads N      threads for building and tracing (default: all online CPUs)\n"
            "  --size WxH       primary rays per scene (default 512x512)\n"
            "  --stress N       triangles of the stress scene (default 1000000)\n"
            "  --big            also run a stress scene of 10M triangles\n"
            "  --model PATH     model to import (default: the 2CylinderEngine glTF test model,\n"
            "                   else assimp's spider.obj)\n"
            "  --only LIST      comma-separated subset of room,stress,model\n"
            "  --min-time S     repeat each measurement for at least S seconds (default 0.3)\n"
            "  --seed N         seed of the procedural scenes and ray sets (default 1)\n"
            "  --help           this text\n");
}

static bool parse(int argc, char **argv, options *o) {
    *o = (options){ .threads = (uint32_t)sysconf(_SC_NPROCESSORS_ONLN),
                    .width = 512,
                    .height = 512,
                    .stress_triangles = 1000000,
                    .room = true,
                    .stress = true,
                    .imported = true,
                    .min_time = 0.3,
                    .seed = 1 };
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (strcmp(a, "--help") == 0 || strcmp(a, "-h") == 0) {
            usage(stdout);
            exit(0);
        } else if (strcmp(a, "--big") == 0) {
            o->big = true;
            continue;
        }
        if (!v) {
            fprintf(stderr, "bench_bvh_cpu: %s needs a value\n", a);
            return false;
        }
        i++;
        if (strcmp(a, "--threads") == 0) {
            o->threads = (uint32_t)strtoul(v, NULL, 10);
        } else if (strcmp(a, "--size") == 0) {
            if (sscanf(v, "%ux%u", &o->width, &o->height) != 2)
                o->width = 0;
        } else if (strcmp(a, "--stress") == 0) {
            o->stress_triangles = strtoull(v, NULL, 10);
        } else if (strcmp(a, "--model") == 0) {
            o->model = v;
        } else if (strcmp(a, "--only") == 0) {
            o->room = strstr(v, "room") != NULL;
            o->stress = strstr(v, "stress") != NULL;
            o->imported = strstr(v, "model") != NULL;
        } else if (strcmp(a, "--min-time") == 0) {
            o->min_time = strtod(v, NULL);
        } else if (strcmp(a, "--seed") == 0) {
            o->seed = (uint32_t)strtoul(v, NULL, 10);
        } else {
            fprintf(stderr, "bench_bvh_cpu: unknown option %s (see --help)\n", a);
            return false;
        }
    }
    if (o->threads < 1 || o->threads > 256 || o->width == 0 || o->height == 0 || o->stress_triangles == 0 ||
        !(o->min_time >= 0.0)) {
        fprintf(stderr, "bench_bvh_cpu: bad --threads, --size, --stress or --min-time (see --help)\n");
        return false;
    }
    return true;
}

/* ---- builds ---- */

typedef struct builds {
    cv_bvh *flat;
    cv_scene_bvh *two_level;
    embree_peer *embree;
    double flat_s, two_level_s, embree_s; /* best of the repetitions */
} builds;

/* Further runs of a build that took `first` seconds (the best run is kept,
 * shared machines are noisy): two more, up to four to fill min_time; none
 * for builds over two seconds. */
static int build_reps(const options *o, double first) {
    if (first > 2.0)
        return 0;
    int reps = first > 0.0 ? (int)(o->min_time / first) : 4;
    return reps < 2 ? 2 : reps > 4 ? 4 : reps;
}

static bool build_all(const options *o, const cv_scene *s, builds *b) {
    cv_bvh_build_options opt = { .thread_count = o->threads };
    double t0 = bench_now();
    if (cv_bvh_build_flat(s, &opt, &b->flat) != CV_OK) {
        fprintf(stderr, "corvid flat build failed: %s\n", cv_last_error());
        return false;
    }
    b->flat_s = bench_now() - t0;
    for (int r = build_reps(o, b->flat_s); r > 0; r--) {
        cv_bvh *again;
        t0 = bench_now();
        if (cv_bvh_build_flat(s, &opt, &again) != CV_OK)
            break;
        double t = bench_now() - t0;
        b->flat_s = t < b->flat_s ? t : b->flat_s;
        cv_bvh_destroy(again);
    }
    t0 = bench_now();
    if (cv_scene_bvh_build(s, &opt, &b->two_level) != CV_OK) {
        fprintf(stderr, "corvid two-level build failed: %s\n", cv_last_error());
        return false;
    }
    b->two_level_s = bench_now() - t0;
    b->embree = embree_peer_create(s, o->threads, &b->embree_s);
    if (!b->embree)
        return false;
    for (int r = build_reps(o, b->embree_s); r > 0; r--) {
        double t = embree_peer_rebuild(b->embree);
        b->embree_s = t < b->embree_s ? t : b->embree_s;
    }
    return true;
}

static void print_builds(const cv_scene *s, const builds *b) {
    double tris = (double)cv_scene_world_triangle_count(s);
    cv_bvh_report rep;
    bool checked = cv_bvh_check(b->flat, &rep) == CV_OK;
    printf("  build (best of runs)          time        Mtris/s\n");
    printf("  corvid flat                %8.1f ms  %8.2f   (%u nodes, SAH %.1f, invariants %s)\n", b->flat_s * 1e3,
           tris / b->flat_s * 1e-6, b->flat->node_count, checked ? rep.sah_cost : 0.0,
           checked ? "ok" : cv_last_error());
    printf("  corvid two-level           %8.1f ms  %8.2f   (%u meshes, %u instances)\n", b->two_level_s * 1e3,
           tris / b->two_level_s * 1e-6, b->two_level->mesh_count, b->two_level->instance_count);
    printf("  embree rtcCommitScene      %8.1f ms  %8.2f   corvid flat / embree: %.2fx the time\n", b->embree_s * 1e3,
           tris / b->embree_s * 1e-6, b->flat_s / b->embree_s);
}

/* ---- tracing ---- */

enum { T_SKIP, T_NODE2, T_TWO_LEVEL, T_EMBREE1, T_EMBREE16, TRACERS };
static const char *const tracer_names[TRACERS] = { "corvid skip", "corvid node2", "corvid 2-lvl", "embree x1",
                                                   "embree x16" };

typedef struct run_ctx {
    const options *o;
    const builds *b;
    const cv_ray_set *set;
    bool occlusion;
} run_ctx;

static void trace_once(const run_ctx *c, int tracer, cv_hit *hits) {
    uint32_t flags = c->occlusion ? CV_TRACE_ANY_HIT : CV_TRACE_CLOSEST;
    cv_trace_target t = { .flat = c->b->flat, .layout = CV_BVH_LAYOUT_SKIP };
    switch (tracer) {
    case T_NODE2: t.layout = CV_BVH_LAYOUT_NODE2; break;
    case T_TWO_LEVEL: t = (cv_trace_target){ .two_level = c->b->two_level, .layout = CV_BVH_LAYOUT_NODE2 }; break;
    case T_EMBREE1:
    case T_EMBREE16:
        embree_peer_trace(c->b->embree, c->set->rays, c->set->count, c->occlusion, tracer == T_EMBREE1 ? 1 : 16,
                          c->o->threads, hits);
        return;
    default: break;
    }
    cv_trace_batch(&t, c->set->rays, c->set->count, flags, c->o->threads, hits);
}

/* Mrays/s over repetitions filling min_time. */
static double measure(const run_ctx *c, int tracer, cv_hit *hits) {
    double total = 0.0;
    uint64_t rays = 0;
    do {
        double t0 = bench_now();
        trace_once(c, tracer, hits);
        total += bench_now() - t0;
        rays += c->set->count;
    } while (total < c->o->min_time);
    return total > 0.0 ? (double)rays / total * 1e-6 : 0.0;
}

static uint32_t count_hits(const cv_hit *h, uint32_t n) {
    uint32_t k = 0;
    for (uint32_t i = 0; i < n; i++)
        k += h[i].triangle != CV_BVH_INVALID;
    return k;
}

/* Rays where one side hit and the other missed, and (closest hits) where
 * both hit different triangles at distances more than 1e-4 apart. */
static void disagreements(const cv_hit *a, const cv_hit *b, uint32_t n, bool occlusion, uint32_t *hit_miss,
                          uint32_t *closest) {
    *hit_miss = *closest = 0;
    for (uint32_t i = 0; i < n; i++) {
        bool ha = a[i].triangle != CV_BVH_INVALID, hb = b[i].triangle != CV_BVH_INVALID;
        if (ha != hb)
            (*hit_miss)++;
        else if (ha && !occlusion && (a[i].triangle != b[i].triangle || a[i].instance != b[i].instance) &&
                 fabsf(a[i].t - b[i].t) > 1e-4f * fabsf(b[i].t))
            (*closest)++;
    }
}

static void trace_set(const options *o, const builds *b, const cv_ray_set *set) {
    run_ctx c = { .o = o, .b = b, .set = set, .occlusion = cv_ray_kind_is_occlusion(set->kind) };
    cv_hit *hits[TRACERS];
    double mrays[TRACERS];
    for (int t = 0; t < TRACERS; t++) {
        hits[t] = malloc((size_t)set->count * sizeof(cv_hit) + 1);
        if (!hits[t]) {
            fprintf(stderr, "no memory for %u hits\n", set->count);
            exit(1);
        }
        mrays[t] = measure(&c, t, hits[t]);
    }
    uint32_t hm, cl, worst_hm = 0;
    for (int t = 0; t < T_EMBREE1; t++) {
        disagreements(hits[t], hits[T_EMBREE1], set->count, c.occlusion, &hm, &cl);
        worst_hm = hm > worst_hm ? hm : worst_hm;
    }
    disagreements(hits[T_NODE2], hits[T_EMBREE1], set->count, c.occlusion, &hm, &cl);
    uint32_t corvid_hits = count_hits(hits[T_NODE2], set->count),
             embree_hits = count_hits(hits[T_EMBREE1], set->count);
    printf("  %-10s %8u %-7s", cv_ray_kind_name(set->kind), set->count, c.occlusion ? "any" : "closest");
    for (int t = 0; t < TRACERS; t++)
        printf(" %12.2f", mrays[t]);
    printf("  %6.2f %6.2f   %8u %8u  %s (%u hit/miss, %u closest)\n", mrays[T_NODE2] / mrays[T_EMBREE1],
           mrays[T_NODE2] / mrays[T_EMBREE16], corvid_hits, embree_hits,
           worst_hm * 10000ull <= set->count && cl * 10000ull <= set->count ? "agree" : "DIFFER", hm, cl);
    for (int t = 0; t < TRACERS; t++)
        free(hits[t]);
}

static void trace_all(const options *o, const cv_scene *s, const builds *b) {
    cv_ray_set_desc desc = {
        .width = o->width, .height = o->height, .seed = o->seed, .random_count = o->width * o->height
    };
    cv_ray_set primary;
    if (cv_ray_set_make(s, CV_RAYS_PRIMARY, &desc, &primary) != CV_OK) {
        fprintf(stderr, "primary rays: %s\n", cv_last_error());
        return;
    }
    cv_hit *hits = malloc((size_t)primary.count * sizeof(cv_hit) + 1);
    cv_trace_target t = { .flat = b->flat, .layout = CV_BVH_LAYOUT_NODE2 };
    if (!hits || cv_trace_batch(&t, primary.rays, primary.count, 0, o->threads, hits) != CV_OK) {
        fprintf(stderr, "primary trace failed\n");
        exit(1);
    }
    printf("  Mrays/s, %u threads each\n  %-10s %8s %-7s", o->threads, "rays", "count", "query");
    for (int k = 0; k < TRACERS; k++)
        printf(" %12s", tracer_names[k]);
    printf("  node2/embree  hits: corvid   embree\n");
    printf("  %-10s %8s %-7s %12s %12s %12s %12s %12s  %6s %6s\n", "", "", "", "", "", "", "", "", "x1", "x16");
    trace_set(o, b, &primary);
    for (int kind = CV_RAYS_SHADOW; kind < CV_RAY_KIND_COUNT; kind++) {
        cv_ray_set set;
        cv_result r = kind == CV_RAYS_RANDOM
                          ? cv_ray_set_make(s, CV_RAYS_RANDOM, &desc, &set)
                          : cv_ray_set_make_secondary(s, (cv_ray_kind)kind, &desc, &primary, hits, &set);
        if (r != CV_OK) {
            fprintf(stderr, "%s rays: %s\n", cv_ray_kind_name((cv_ray_kind)kind), cv_last_error());
            continue;
        }
        if (set.count)
            trace_set(o, b, &set);
        cv_ray_set_free(&set);
    }
    free(hits);
    cv_ray_set_free(&primary);
}

static void bench_scene(const options *o, const char *name, cv_scene *s) {
    if (!s)
        return;
    printf("\n== %s: %llu world triangles (%llu stored), %u meshes, %u instances\n", name,
           (unsigned long long)cv_scene_world_triangle_count(s), (unsigned long long)cv_scene_triangle_count(s),
           cv_scene_mesh_count(s), cv_scene_instance_count(s));
    fflush(stdout);
    builds b = { 0 };
    if (build_all(o, s, &b)) {
        print_builds(s, &b);
        printf("  peer: %s\n", embree_peer_describe(b.embree));
        fflush(stdout);
        trace_all(o, s, &b);
    }
    cv_bvh_destroy(b.flat);
    cv_scene_bvh_destroy(b.two_level);
    embree_peer_destroy(b.embree);
    cv_scene_destroy(s);
    fflush(stdout);
}

static cv_scene *make_stress(const options *o, uint64_t triangles) {
    cv_scene *s = NULL;
    if (cv_scene_make_stress(o->seed, triangles, &s) != CV_OK)
        fprintf(stderr, "stress scene: %s\n", cv_last_error());
    return s;
}

int main(int argc, char **argv) {
    options o;
    if (!parse(argc, argv, &o)) {
        usage(stderr);
        return 2;
    }
    char machine[320];
    bench_machine(machine, sizeof machine);
    printf("bench_bvh_cpu: Corvid CPU BVH vs Embree %s\n", embree_peer_version());
    printf("machine: %s; %u threads for both; %ux%u primary rays; compiler %s\n", machine, o.threads, o.width,
           o.height, __VERSION__);
    printf(
        "corvid: binned SAH (16 bins, leaves <= 8), build time includes transforming the triangles;\n"
        "embree: default build quality, time of rtcCommitScene only (vertex buffers filled beforehand)\n");
    if (o.room) {
        cv_scene *s = NULL;
        if (cv_scene_make_room(o.seed, &s) != CV_OK)
            fprintf(stderr, "room: %s\n", cv_last_error());
        bench_scene(&o, "room", s);
    }
    if (o.stress) {
        char name[64];
        snprintf(name, sizeof name, "stress %llu", (unsigned long long)o.stress_triangles);
        bench_scene(&o, name, make_stress(&o, o.stress_triangles));
        if (o.big)
            bench_scene(&o, "stress 10000000", make_stress(&o, 10000000));
    }
    if (o.imported) {
        const char *path = o.model ? o.model : access(DEFAULT_MODEL, R_OK) == 0 ? DEFAULT_MODEL : FALLBACK_MODEL;
        cv_scene *s = NULL;
        if (cv_scene_import(path, &s) != CV_OK)
            fprintf(stderr, "model: %s\n", cv_last_error());
        bench_scene(&o, path, s);
    }
    return 0;
}
