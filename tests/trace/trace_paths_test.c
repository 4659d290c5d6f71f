/* Both trace paths of the Vulkan backend against the CPU reference traversal.
 *
 * For the procedural room, a stress scene of about 50k triangles and assimp's
 * spider.obj: 100,000 random rays, camera rays, and shadow and AO rays from the
 * camera rays' hits, traced with the trace_rays command through the public API
 * on the compute path and, where the adapter offers it, on the driver's
 * ray-tracing pipeline, closest and any hit, with and without back-face
 * culling. Each hit is compared with cv_trace_batch (two-child layout):
 *  - closest hit: the same triangle and instance, t within 1e-4 relative,
 *    misses agree;
 *  - any hit: occlusion agrees, and a reported hit is a real one: that
 *    triangle, intersected with bvh_gpu.h's rules, gives the reported t (within
 *    1e-4 relative); which of several occluders is reported depends on the
 *    traversal order, so it is not compared.
 * t is compared within 1e-4 relative, or, where that is finer than floats
 * resolve, within 8 ulps of the largest coordinate involved divided by the
 * cosine of the incidence (t_resolution below): a ray starting a millimetre
 * from a surface ten metres from the origin has a t that two correct
 * intersection routines may place a few ulps apart.
 * Two exceptions are counted, printed and allowed, each verified ray by ray:
 *  - coincident surfaces: a closest hit on a different triangle that the ray
 *    really hits at the same t (props resting on the floor: their bottom faces
 *    lie in the floor's plane). The reference keeps whichever equal-t triangle
 *    it meets first, so the choice belongs to the traversal order;
 *  - grazing rays: the ray passes within 1e-5 (barycentric) of an edge of a
 *    triangle one side reported, where the last bit, or the driver's watertight
 *    edge rule against our inclusive barycentric test, decides which triangle
 *    (if any) is hit. They must stay below 1 in 10,000 rays.
 * Any other difference fails. On lavapipe the compute path must moreover match
 * the reference bit for bit (same rounding, same traversal order).
 *
 * Also checked: the path selection (CORVID_TRACE_PATH, cv_vulkan_set_trace_path,
 * AUTO mode's measurement at the first accel write), with the validation layer
 * on and required to stay silent. */
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "test_adapter.h"
#include "corvid/bvh.h"
#include "corvid/corvid.h"
#include "corvid/ray_sets.h"
#include "corvid/scene_import.h"
#include "corvid/scene_procedural.h"
#include "corvid/trace_cpu.h"
#include "corvid/vulkan.h"

#define RANDOM_RAYS 100000u
#define T_TOLERANCE 1e-4f
#define GRAZE_SLACK 1e-5f
#define T_ULPS 8.0f

/* ---- scenes and their triangles ---------------------------------------------- */

typedef struct scene_case {
    const char *name;
    cv_scene *scene;
    cv_bvh *bvh;
    uint32_t *by_id; /* triangle indices sorted by (instance, prim) */
} scene_case;

static const cv_bvh *sort_bvh;

static int by_id_order(const void *a, const void *b) {
    const cv_bvh_tri *x = &sort_bvh->tris[*(const uint32_t *)a], *y = &sort_bvh->tris[*(const uint32_t *)b];
    if (x->instance != y->instance)
        return x->instance < y->instance ? -1 : 1;
    return x->prim < y->prim ? -1 : x->prim > y->prim;
}

/* The triangle a hit names, or NULL. */
static const cv_bvh_tri *triangle_of(const scene_case *s, const cv_hit *h) {
    uint32_t lo = 0, hi = s->bvh->tri_count;
    while (lo < hi) {
        uint32_t mid = lo + (hi - lo) / 2;
        const cv_bvh_tri *t = &s->bvh->tris[s->by_id[mid]];
        if (t->instance < h->instance || (t->instance == h->instance && t->prim < h->triangle))
            lo = mid + 1;
        else
            hi = mid;
    }
    if (lo == s->bvh->tri_count)
        return NULL;
    const cv_bvh_tri *t = &s->bvh->tris[s->by_id[lo]];
    return t->instance == h->instance && t->prim == h->triangle ? t : NULL;
}

static bool load_scene(scene_case *s, const char *name, cv_result made, cv_scene *scene) {
    s->name = name;
    s->scene = scene;
    CHECK_OK(made);
    if (made != CV_OK)
        return false;
    CHECK_OK(cv_bvh_build_flat(scene, &(cv_bvh_build_options){ .thread_count = 2 }, &s->bvh));
    if (!s->bvh)
        return false;
    s->by_id = malloc(s->bvh->tri_count * sizeof(uint32_t));
    for (uint32_t i = 0; i < s->bvh->tri_count; i++)
        s->by_id[i] = i;
    sort_bvh = s->bvh;
    qsort(s->by_id, s->bvh->tri_count, sizeof(uint32_t), by_id_order);
    return true;
}

static void free_scene(scene_case *s) {
    free(s->by_id);
    cv_bvh_destroy(s->bvh);
    cv_scene_destroy(s->scene);
}

/* ---- the comparison rule ------------------------------------------------------- */

/* Whether the ray passes within `slack` of an edge of the triangle, inside
 * (or that close to) it, at a t within the ray's interval. */
static bool grazes(const cv_bvh_tri *tri, const cv_ray *ray) {
    const float *d = ray->dir, *e1 = tri->e1, *e2 = tri->e2;
    double p[3] = { (double)d[1] * e2[2] - (double)d[2] * e2[1], (double)d[2] * e2[0] - (double)d[0] * e2[2],
                    (double)d[0] * e2[1] - (double)d[1] * e2[0] };
    double det = e1[0] * p[0] + e1[1] * p[1] + e1[2] * p[2];
    if (fabs(det) < 1e-30)
        return false;
    double s[3] = { (double)ray->origin[0] - tri->v0[0], (double)ray->origin[1] - tri->v0[1],
                    (double)ray->origin[2] - tri->v0[2] };
    double u = (s[0] * p[0] + s[1] * p[1] + s[2] * p[2]) / det;
    double q[3] = { s[1] * e1[2] - s[2] * e1[1], s[2] * e1[0] - s[0] * e1[2], s[0] * e1[1] - s[1] * e1[0] };
    double v = (d[0] * q[0] + d[1] * q[1] + d[2] * q[2]) / det;
    double t = (e2[0] * q[0] + e2[1] * q[1] + e2[2] * q[2]) / det;
    double slack = GRAZE_SLACK;
    bool inside = u >= -slack && v >= -slack && u + v <= 1.0 + slack;
    bool near_edge = fabs(u) <= slack || fabs(v) <= slack || fabs(u + v - 1.0) <= slack;
    return inside && near_edge && t >= ray->tmin * (1.0 - 1e-4) && t <= ray->tmax * (1.0 + 1e-4);
}

/* Float resolution of t for this ray and triangle: a coordinate of magnitude
 * L is known to ulp(L) = L * FLT_EPSILON, and a ray meeting the plane at an
 * angle whose cosine to the normal is c turns that into ulp(L) / c along the
 * ray. Two correct intersection routines (ours; a driver's watertight one,
 * which first translates the vertices to the ray origin) may differ by a few
 * of those, whatever t is. */
static float t_resolution(const cv_bvh_tri *tri, const cv_ray *ray) {
    float scale = 0.0f;
    for (int k = 0; k < 3; k++) {
        float c[4] = { ray->origin[k], tri->v0[k], tri->v0[k] + tri->e1[k], tri->v0[k] + tri->e2[k] };
        for (int i = 0; i < 4; i++)
            scale = fabsf(c[i]) > scale ? fabsf(c[i]) : scale;
    }
    const float *a = tri->e1, *b = tri->e2, *d = ray->dir;
    float n[3] = { a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0] };
    float nn = sqrtf(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]), dd = sqrtf(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    float cosine = nn > 0.0f && dd > 0.0f ? fabsf(n[0] * d[0] + n[1] * d[1] + n[2] * d[2]) / (nn * dd) : 0.0f;
    return T_ULPS * scale * FLT_EPSILON / (cosine > 1e-3f ? cosine : 1e-3f) / (dd > 0.0f ? dd : 1.0f);
}

/* t values agree: within 1e-4 relative, or within the float resolution at
 * this triangle (for small t, where 1e-4 of t is below what floats resolve). */
static bool near_t(const cv_bvh_tri *tri, const cv_ray *ray, float a, float b) {
    return fabsf(a - b) <= T_TOLERANCE * fabsf(b) || fabsf(a - b) <= t_resolution(tri, ray);
}

/* Whether a hit names a triangle the ray really hits (intersected with
 * bvh_gpu.h's rules) at its t. */
static bool real_hit(const scene_case *s, const cv_ray *ray, const cv_hit *h, uint32_t flags) {
    const cv_bvh_tri *tri = triangle_of(s, h);
    float t, u, v;
    return tri && cv_intersect_triangle(tri, ray, ray->tmax, (flags & CV_TRACE_CULL_BACK_FACES) != 0, &t, &u, &v) &&
           near_t(tri, ray, h->t, t);
}

typedef enum verdict { SAME, COINCIDENT, GRAZING, WRONG } verdict;

static verdict judge(const scene_case *s, const cv_ray *ray, const cv_hit *gpu, const cv_hit *cpu, uint32_t flags) {
    bool g_hit = gpu->triangle != CV_BVH_INVALID, c_hit = cpu->triangle != CV_BVH_INVALID;
    const cv_bvh_tri *g_tri = g_hit ? triangle_of(s, gpu) : NULL, *c_tri = c_hit ? triangle_of(s, cpu) : NULL;
    if (g_hit == c_hit && !g_hit)
        return SAME;
    if (g_hit == c_hit && real_hit(s, ray, gpu, flags)) {
        if (flags & CV_TRACE_ANY_HIT)
            return SAME;
        bool same_triangle = gpu->triangle == cpu->triangle && gpu->instance == cpu->instance;
        if (near_t(g_tri, ray, gpu->t, cpu->t))
            return same_triangle ? SAME : COINCIDENT;
    }
    return (g_tri && grazes(g_tri, ray)) || (c_tri && grazes(c_tri, ray)) ? GRAZING : WRONG;
}

/* ---- tracing through the public API --------------------------------------------- */

typedef struct rig {
    cv_context *ctx;
    cv_device *dev;
    bool pipeline_offered;
    bool lavapipe;
} rig;

static void trace_on_device(rig *g, cv_accel accel, const cv_ray_set *set, uint32_t flags, cv_hit *out) {
    uint64_t ray_bytes = (uint64_t)set->count * sizeof(cv_ray), hit_bytes = (uint64_t)set->count * sizeof(cv_hit);
    cv_buffer rays = { 0 }, hits = { 0 };
    CHECK_OK(cv_buffer_create(g->ctx, &(cv_buffer_desc){ .size = ray_bytes, .label = "rays" }, &rays));
    CHECK_OK(cv_buffer_create(g->ctx, &(cv_buffer_desc){ .size = hit_bytes, .label = "hits" }, &hits));
    CHECK_OK(cv_device_load(g->dev, cv_any(rays)));
    CHECK_OK(cv_device_load(g->dev, cv_any(hits)));
    CHECK_OK(cv_device_write_buffer(g->dev, rays, 0, ray_bytes, set->rays));
    cv_cmdlist list;
    cv_command_list *l;
    CHECK_OK(cv_cmdlist_create(g->ctx, &list));
    CHECK_OK(cv_cmdlist_begin(g->ctx, list, &l));
    cv_cmd_trace_rays(l, CV_QUEUE_COMPUTE,
                      &(cv_trace_rays_args){
                          .accel = accel, .rays = rays, .hits = hits, .count = set->count, .flags = flags });
    CHECK_OK(cv_command_list_end(l));
    uint64_t ticket = 0;
    CHECK_OK(cv_device_submit(g->dev, list, &ticket));
    CHECK_OK(cv_device_wait(g->dev, ticket, UINT64_MAX));
    CHECK_OK(cv_device_read_buffer(g->dev, hits, 0, hit_bytes, out));
    CHECK_OK(cv_cmdlist_destroy(g->ctx, list));
    CHECK_OK(cv_buffer_destroy(g->ctx, rays));
    CHECK_OK(cv_buffer_destroy(g->ctx, hits));
}

/* Traces one set with one flag combination on one path; checks every hit. */
static void check_set(rig *g, const scene_case *s, cv_accel accel, cv_vulkan_trace_path path, const cv_ray_set *set,
                      uint32_t flags, cv_hit *gpu, cv_hit *cpu) {
    cv_trace_target target = { .flat = s->bvh, .layout = CV_BVH_LAYOUT_NODE2 };
    CHECK_OK(cv_trace_batch(&target, set->rays, set->count, flags, 2, cpu));
    trace_on_device(g, accel, set, flags, gpu);
    uint32_t hits = 0, identical = 0, coincident = 0, grazing = 0, wrong = 0;
    for (uint32_t i = 0; i < set->count; i++) {
        hits += cpu[i].triangle != CV_BVH_INVALID;
        identical += memcmp(&gpu[i], &cpu[i], sizeof(cv_hit)) == 0;
        verdict v = judge(s, &set->rays[i], &gpu[i], &cpu[i], flags);
        coincident += v == COINCIDENT;
        grazing += v == GRAZING;
        if (v == WRONG && wrong++ < 3)
            fprintf(stderr, "  ray %u: gpu t %.9g tri %u inst %u, cpu t %.9g tri %u inst %u\n", i, gpu[i].t,
                    gpu[i].triangle, gpu[i].instance, cpu[i].t, cpu[i].triangle, cpu[i].instance);
    }
    printf("  %-8s %-10s %-12s %7u rays %7u hits: %7u identical, %u coincident, %u grazing, %u wrong\n",
           cv_vulkan_trace_path_name(path), cv_ray_kind_name(set->kind),
           flags == 0                          ? "closest"
           : flags == CV_TRACE_ANY_HIT         ? "any"
           : flags == CV_TRACE_CULL_BACK_FACES ? "closest+cull"
                                               : "any+cull",
           set->count, hits, identical, coincident, grazing, wrong);
    CHECK(hits > 0);
    CHECK_EQ_INT(wrong, 0);
    CHECK(grazing * 10000ull <= set->count);
    /* On lavapipe the compute kernel rounds as the CPU does and visits nodes in
     * its order: every hit is the reference's, bit for bit. */
    if (path == CV_VULKAN_TRACE_COMPUTE && g->lavapipe)
        CHECK_EQ_INT(identical, set->count);
}

static void check_scene(rig *g, scene_case *s) {
    printf("%s: %u triangles, %u nodes\n", s->name, s->bvh->tri_count, s->bvh->node2_count);
    cv_accel accel = { 0 };
    cv_accel_desc desc = { .triangle_count = s->bvh->tri_count, .node_count = s->bvh->node2_count };
    snprintf(desc.label, sizeof(desc.label), "%s", s->name);
    CHECK_OK(cv_accel_create(g->ctx, &desc, &accel));
    CHECK_OK(cv_device_load(g->dev, cv_any(accel)));
    CHECK_OK(cv_device_write_accel(g->dev, accel, s->bvh->nodes2, s->bvh->tris));

    cv_ray_set_desc rd = { .width = 160, .height = 120, .random_count = RANDOM_RAYS, .seed = 11 };
    cv_ray_set sets[5] = { 0 };
    CHECK_OK(cv_ray_set_make(s->scene, CV_RAYS_RANDOM, &rd, &sets[0]));
    CHECK_OK(cv_ray_set_make(s->scene, CV_RAYS_PRIMARY, &rd, &sets[1]));
    cv_hit *cpu = malloc(RANDOM_RAYS * sizeof(cv_hit)), *gpu = malloc(RANDOM_RAYS * sizeof(cv_hit));
    cv_trace_target target = { .flat = s->bvh, .layout = CV_BVH_LAYOUT_NODE2 };
    CHECK_OK(cv_trace_batch(&target, sets[1].rays, sets[1].count, 0, 2, cpu));
    const cv_ray_kind secondary[3] = { CV_RAYS_SHADOW, CV_RAYS_AO_SHORT, CV_RAYS_AO_LONG };
    for (int k = 0; k < 3; k++)
        CHECK_OK(cv_ray_set_make_secondary(s->scene, secondary[k], &rd, &sets[1], cpu, &sets[2 + k]));

    const cv_vulkan_trace_path paths[2] = { CV_VULKAN_TRACE_COMPUTE, CV_VULKAN_TRACE_PIPELINE };
    for (int p = 0; p < (g->pipeline_offered ? 2 : 1); p++) {
        CHECK_OK(cv_vulkan_set_trace_path(g->dev, paths[p]));
        cv_vulkan_trace_status status;
        CHECK_OK(cv_vulkan_get_trace_status(g->dev, &status));
        CHECK_EQ_INT(status.path, paths[p]);
        for (uint32_t flags = 0; flags <= CV_TRACE_FLAGS_ALL; flags++)
            check_set(g, s, accel, paths[p], &sets[0], flags, gpu, cpu);
        for (uint32_t cull = 0; cull <= CV_TRACE_CULL_BACK_FACES; cull += CV_TRACE_CULL_BACK_FACES) {
            check_set(g, s, accel, paths[p], &sets[1], cull, gpu, cpu);
            for (int k = 2; k < 5; k++)
                if (sets[k].count)
                    check_set(g, s, accel, paths[p], &sets[k], CV_TRACE_ANY_HIT | cull, gpu, cpu);
        }
    }
    CHECK_OK(cv_vulkan_set_trace_path(g->dev, CV_VULKAN_TRACE_AUTO));
    for (int k = 0; k < 5; k++)
        cv_ray_set_free(&sets[k]);
    free(cpu);
    free(gpu);
    CHECK_OK(cv_accel_destroy(g->ctx, accel));
}

/* ---- path selection ------------------------------------------------------------------ */

static cv_device *device_with_path(cv_context *ctx, cv_vulkan_trace_path path, cv_result expected) {
    cv_vulkan_device_options options = { .trace_path = path };
    cv_device *dev = NULL;
    cv_device_desc desc = {
        .adapter = cv_test_adapter(), .validation = true, .label = "option", .backend_options = &options
    };
    CHECK_RESULT(cv_device_create(ctx, cv_vulkan_backend(), &desc, &dev), expected);
    return dev;
}

static void check_selection(cv_context *ctx, rig *g) {
    cv_device *dev = device_with_path(ctx, CV_VULKAN_TRACE_COMPUTE, CV_OK);
    if (dev) {
        CHECK(strcmp(cv_device_get_info(dev)->trace_path, "compute") == 0);
        cv_vulkan_trace_status st;
        CHECK_OK(cv_vulkan_get_trace_status(dev, &st));
        CHECK_EQ_INT(st.mode, CV_VULKAN_TRACE_COMPUTE);
        cv_device_destroy(dev);
    }
    dev = device_with_path(ctx, CV_VULKAN_TRACE_PIPELINE, g->pipeline_offered ? CV_OK : CV_ERROR_UNSUPPORTED);
    if (dev) {
        CHECK(strcmp(cv_device_get_info(dev)->trace_path, "pipeline") == 0);
        cv_device_destroy(dev);
    }
    CHECK(device_with_path(ctx, (cv_vulkan_trace_path)7, CV_ERROR_INVALID_ARGUMENT) == NULL);
    CHECK_RESULT(cv_vulkan_set_trace_path(g->dev, (cv_vulkan_trace_path)7), CV_ERROR_INVALID_ARGUMENT);
    if (!g->pipeline_offered)
        CHECK_RESULT(cv_vulkan_set_trace_path(g->dev, CV_VULKAN_TRACE_PIPELINE), CV_ERROR_UNSUPPORTED);
}

/* After the first accel write in AUTO mode the adapter has been measured and
 * the device uses the faster path. */
static void check_measured(rig *g) {
    cv_vulkan_trace_status st;
    CHECK_OK(cv_vulkan_get_trace_status(g->dev, &st));
    CHECK_EQ_INT(st.mode, CV_VULKAN_TRACE_AUTO);
    CHECK_EQ_INT(st.pipeline_offered, g->pipeline_offered);
    if (!g->pipeline_offered) {
        CHECK_EQ_INT(st.path, CV_VULKAN_TRACE_COMPUTE);
        return;
    }
    CHECK(st.measured);
    CHECK(st.measured_rays > 0 && st.compute_mrays > 0.0 && st.pipeline_mrays > 0.0);
    CHECK_EQ_INT(st.path, st.pipeline_mrays > st.compute_mrays ? CV_VULKAN_TRACE_PIPELINE : CV_VULKAN_TRACE_COMPUTE);
    printf("measured on %u rays: compute %.2f, pipeline %.2f Mrays/s; using %s\n", st.measured_rays, st.compute_mrays,
           st.pipeline_mrays, cv_vulkan_trace_path_name(st.path));
}

int main(void) {
    rig g = { 0 };
    CHECK_OK(cv_context_create(NULL, &g.ctx));
    cv_device_desc desc = { .adapter = cv_test_adapter(), .validation = true, .label = "trace" };
    CHECK_OK(cv_device_create(g.ctx, cv_vulkan_backend(), &desc, &g.dev));
    if (!g.dev)
        return check_report("trace_paths");
    const cv_device_info *info = cv_device_get_info(g.dev);
    g.pipeline_offered = info->ray_tracing_pipeline;
    g.lavapipe = strstr(info->name, "llvmpipe") != NULL;
    printf("%s (%s): ray-tracing pipeline %s\n", info->name, info->driver, g.pipeline_offered ? "offered" : "absent");
    check_selection(g.ctx, &g);

    scene_case scenes[3] = { 0 };
    cv_scene *scene = NULL;
    cv_result made = cv_scene_make_room(7, &scene);
    if (load_scene(&scenes[0], "room", made, scene)) {
        check_scene(&g, &scenes[0]);
        check_measured(&g);
    }
    scene = NULL;
    made = cv_scene_make_stress(5, 50000, &scene);
    if (load_scene(&scenes[1], "stress 50k", made, scene))
        check_scene(&g, &scenes[1]);
    scene = NULL;
    made = cv_scene_import(CORVID_ASSIMP_MODELS "/OBJ/spider.obj", &scene);
    if (load_scene(&scenes[2], "spider.obj", made, scene))
        check_scene(&g, &scenes[2]);
    for (int i = 0; i < 3; i++)
        free_scene(&scenes[i]);

    cv_device_destroy(g.dev);
    cv_context_destroy(g.ctx);
    cv_vulkan_message_counts m = cv_vulkan_get_message_counts();
    CHECK_EQ_INT(m.errors, 0);
    CHECK_EQ_INT(m.warnings, 0);
    return check_report("trace_paths");
}
