/* CPU reference traversal: the loops a GPU kernel runs, in plain C, over the
 * arrays of bvh_gpu.h. One traversal per (layout, level) pair; the bottom
 * level is shared by the flat BVH and the BLASes. */
#include "corvid/trace_cpu.h"

#include <assert.h>
#include <math.h>

#include "bvh_builder.h"
#include "parallel.h"

typedef struct ray_state {
    float o[3], d[3], inv[3];
    float tmin, tmax; /* tmax: the current limit (lowered by closest hits) */
    bool cull, any;
} ray_state;

/* The hit found so far: the triangle record and its instance. */
typedef struct best_hit {
    const cv_bvh_tri *tri;
    uint32_t instance;
    float t, u, v;
} best_hit;

static inline float fmin_(float a, float b) { return a < b ? a : b; }
static inline float fmax_(float a, float b) { return a > b ? a : b; }

static inline void ray_init(ray_state *s, const float o[3], const float d[3], float tmin, float tmax) {
    for (int k = 0; k < 3; k++) {
        s->o[k] = o[k];
        s->d[k] = d[k];
        float dk = fabsf(d[k]) < CV_BVH_MIN_DIR ? copysignf(CV_BVH_MIN_DIR, d[k]) : d[k];
        s->inv[k] = 1.0f / dk;
    }
    s->tmin = tmin;
    s->tmax = tmax;
}

/* Slab test; *tnear is the entry distance when hit. */
static inline bool box_hit(const ray_state *s, const float bmin[3], const float bmax[3], float *tnear) {
    float x0 = (bmin[0] - s->o[0]) * s->inv[0], x1 = (bmax[0] - s->o[0]) * s->inv[0];
    float y0 = (bmin[1] - s->o[1]) * s->inv[1], y1 = (bmax[1] - s->o[1]) * s->inv[1];
    float z0 = (bmin[2] - s->o[2]) * s->inv[2], z1 = (bmax[2] - s->o[2]) * s->inv[2];
    float tn = fmax_(fmax_(fmin_(x0, x1), fmin_(y0, y1)), fmax_(fmin_(z0, z1), s->tmin));
    float tf = fmin_(fmin_(fmax_(x0, x1), fmax_(y0, y1)), fmax_(z0, z1)) * CV_BVH_TFAR_SCALE;
    tf = fmin_(tf, s->tmax);
    *tnear = tn;
    return tn <= tf;
}

static inline bool tri_hit(const cv_bvh_tri *tri, const float o[3], const float d[3], float tmin, float tlimit,
                           bool cull, float *t_out, float *u_out, float *v_out) {
    const float *e1 = tri->e1, *e2 = tri->e2;
    float p[3] = { d[1] * e2[2] - d[2] * e2[1], d[2] * e2[0] - d[0] * e2[2], d[0] * e2[1] - d[1] * e2[0] };
    float det = e1[0] * p[0] + e1[1] * p[1] + e1[2] * p[2];
    if (cull ? !(det >= CV_BVH_DET_EPSILON) : !(fabsf(det) >= CV_BVH_DET_EPSILON))
        return false;
    float inv_det = 1.0f / det;
    float s[3] = { o[0] - tri->v0[0], o[1] - tri->v0[1], o[2] - tri->v0[2] };
    float u = (s[0] * p[0] + s[1] * p[1] + s[2] * p[2]) * inv_det;
    if (!(u >= 0.0f && u <= 1.0f))
        return false;
    float q[3] = { s[1] * e1[2] - s[2] * e1[1], s[2] * e1[0] - s[0] * e1[2], s[0] * e1[1] - s[1] * e1[0] };
    float v = (d[0] * q[0] + d[1] * q[1] + d[2] * q[2]) * inv_det;
    if (!(v >= 0.0f && u + v <= 1.0f))
        return false;
    float t = (e2[0] * q[0] + e2[1] * q[1] + e2[2] * q[2]) * inv_det;
    if (!(t >= tmin && t < tlimit))
        return false;
    *t_out = t;
    *u_out = u;
    *v_out = v;
    return true;
}

bool cv_intersect_triangle(const cv_bvh_tri *tri, const cv_ray *ray, float t_limit, bool cull_back_faces, float *t,
                           float *u, float *v) {
    return tri_hit(tri, ray->origin, ray->dir, ray->tmin, t_limit, cull_back_faces, t, u, v);
}

/* Tests one leaf's triangles; true when the search may stop (any-hit found). */
static inline bool leaf_hit(const cv_bvh_tri *tris, uint32_t first, uint32_t count, ray_state *s, uint32_t instance,
                            best_hit *best) {
    for (uint32_t k = first; k < first + count; k++) {
        float t, u, v;
        if (!tri_hit(&tris[k], s->o, s->d, s->tmin, s->tmax, s->cull, &t, &u, &v))
            continue;
        s->tmax = t;
        *best = (best_hit){ .tri = &tris[k], .instance = instance, .t = t, .u = u, .v = v };
        if (s->any)
            return true;
    }
    return false;
}

/* Bottom level, skip layout: stackless. */
static bool tris_skip(const cv_bvh_node *nodes, int32_t root, const cv_bvh_tri *tris, ray_state *s, uint32_t instance,
                      best_hit *best) {
    int32_t i = root;
    while (i != -1) {
        const cv_bvh_node *n = &nodes[i];
        float tn;
        if (!box_hit(s, n->bmin, n->bmax, &tn)) {
            i = n->skip;
        } else if (n->info != CV_BVH_INTERIOR) {
            if (leaf_hit(tris, cv_bvh_leaf_first(n->info), cv_bvh_leaf_count(n->info), s, instance, best))
                return true;
            i = n->skip;
        } else {
            i++;
        }
    }
    return false;
}

typedef struct stack_entry {
    uint32_t node;
    float tnear;
} stack_entry;

/* Bottom level, two-child layout: leaves first, then the nearer child, the
 * farther one on the stack (dropped when popped beyond the current hit). */
static bool tris_node2(const cv_bvh_node2 *nodes, uint32_t root, const cv_bvh_tri *tris, ray_state *s,
                       uint32_t instance, best_hit *best) {
    stack_entry stack[CV_BVH_MAX_DEPTH + 2];
    uint32_t top = 0, node = root;
    for (;;) {
        const cv_bvh_node2 *n = &nodes[node];
        float ta, tb;
        bool ha = box_hit(s, n->a_min, n->a_max, &ta);
        bool hb = box_hit(s, n->b_min, n->b_max, &tb);
        if (ha && (n->a_link & CV_BVH_LEAF_BIT)) {
            if (leaf_hit(tris, n->a_link & ~CV_BVH_LEAF_BIT, n->a_count, s, instance, best))
                return true;
            ha = false;
        }
        if (hb && (n->b_link & CV_BVH_LEAF_BIT)) {
            if (leaf_hit(tris, n->b_link & ~CV_BVH_LEAF_BIT, n->b_count, s, instance, best))
                return true;
            hb = false;
        }
        if (ha && hb) {
            bool a_first = ta <= tb;
            stack[top++] = (stack_entry){ a_first ? n->b_link : n->a_link, a_first ? tb : ta };
            node = a_first ? n->a_link : n->b_link;
            continue;
        }
        if (ha) {
            node = n->a_link;
            continue;
        }
        if (hb) {
            node = n->b_link;
            continue;
        }
        do {
            if (top == 0)
                return false;
            top--;
        } while (stack[top].tnear > s->tmax);
        node = stack[top].node;
    }
}

/* Enters one instance: the ray in object space, same t. */
static bool instance_hit(const cv_scene_bvh *bvh, const cv_bvh_instance *inst, bool node2, ray_state *world,
                         best_hit *best) {
    const float(*m)[4] = inst->world_to_object;
    float o[3], d[3];
    for (int k = 0; k < 3; k++) {
        o[k] = m[k][0] * world->o[0] + m[k][1] * world->o[1] + m[k][2] * world->o[2] + m[k][3];
        d[k] = m[k][0] * world->d[0] + m[k][1] * world->d[1] + m[k][2] * world->d[2];
    }
    ray_state s;
    ray_init(&s, o, d, world->tmin, world->tmax);
    s.cull = world->cull;
    s.any = world->any;
    bool stop = node2
                    ? tris_node2(bvh->blas_nodes2, inst->blas_root2, bvh->blas_tris, &s, inst->instance, best)
                    : tris_skip(bvh->blas_nodes, (int32_t)inst->blas_root, bvh->blas_tris, &s, inst->instance, best);
    world->tmax = s.tmax;
    return stop;
}

static bool instances_hit(const cv_scene_bvh *bvh, uint32_t first, uint32_t count, bool node2, ray_state *s,
                          best_hit *best) {
    for (uint32_t k = first; k < first + count; k++)
        if (instance_hit(bvh, &bvh->instances[k], node2, s, best))
            return true;
    return false;
}

static void top_skip(const cv_scene_bvh *bvh, ray_state *s, best_hit *best) {
    int32_t i = bvh->tlas_node_count ? 0 : -1;
    while (i != -1) {
        const cv_bvh_node *n = &bvh->tlas_nodes[i];
        float tn;
        if (!box_hit(s, n->bmin, n->bmax, &tn)) {
            i = n->skip;
        } else if (n->info != CV_BVH_INTERIOR) {
            if (instances_hit(bvh, cv_bvh_leaf_first(n->info), cv_bvh_leaf_count(n->info), false, s, best))
                return;
            i = n->skip;
        } else {
            i++;
        }
    }
}

static void top_node2(const cv_scene_bvh *bvh, ray_state *s, best_hit *best) {
    if (bvh->tlas_node2_count == 0)
        return;
    stack_entry stack[CV_BVH_MAX_DEPTH + 2];
    uint32_t top = 0, node = 0;
    for (;;) {
        const cv_bvh_node2 *n = &bvh->tlas_nodes2[node];
        float ta, tb;
        bool ha = box_hit(s, n->a_min, n->a_max, &ta);
        bool hb = box_hit(s, n->b_min, n->b_max, &tb);
        if (ha && (n->a_link & CV_BVH_LEAF_BIT)) {
            if (instances_hit(bvh, n->a_link & ~CV_BVH_LEAF_BIT, n->a_count, true, s, best))
                return;
            ha = false;
        }
        if (hb && (n->b_link & CV_BVH_LEAF_BIT)) {
            if (instances_hit(bvh, n->b_link & ~CV_BVH_LEAF_BIT, n->b_count, true, s, best))
                return;
            hb = false;
        }
        if (ha && hb) {
            bool a_first = ta <= tb;
            stack[top++] = (stack_entry){ a_first ? n->b_link : n->a_link, a_first ? tb : ta };
            node = a_first ? n->a_link : n->b_link;
            continue;
        }
        if (ha) {
            node = n->a_link;
            continue;
        }
        if (hb) {
            node = n->b_link;
            continue;
        }
        do {
            if (top == 0)
                return;
            top--;
        } while (stack[top].tnear > s->tmax);
        node = stack[top].node;
    }
}

cv_hit cv_hit_miss(void) {
    return (cv_hit){ .t = INFINITY, .u = 0.0f, .v = 0.0f, .triangle = CV_BVH_INVALID, .instance = CV_BVH_INVALID };
}

bool cv_trace_ray(const cv_trace_target *target, const cv_ray *ray, uint32_t flags, cv_hit *hit) {
    assert(target && (target->flat != NULL) != (target->two_level != NULL));
    ray_state s;
    ray_init(&s, ray->origin, ray->dir, ray->tmin, ray->tmax);
    s.cull = (flags & CV_TRACE_CULL_BACK_FACES) != 0;
    s.any = (flags & CV_TRACE_ANY_HIT) != 0;
    best_hit best = { .tri = NULL };
    bool node2 = target->layout == CV_BVH_LAYOUT_NODE2;
    if (target->flat) {
        const cv_bvh *b = target->flat;
        if (node2 && b->node2_count)
            tris_node2(b->nodes2, 0, b->tris, &s, CV_BVH_INVALID, &best);
        else if (!node2 && b->node_count)
            tris_skip(b->nodes, 0, b->tris, &s, CV_BVH_INVALID, &best);
    } else if (node2) {
        top_node2(target->two_level, &s, &best);
    } else {
        top_skip(target->two_level, &s, &best);
    }
    if (!best.tri) {
        *hit = cv_hit_miss();
        return false;
    }
    *hit = (cv_hit){
        .t = best.t,
        .u = best.u,
        .v = best.v,
        .triangle = best.tri->prim,
        .instance = target->flat ? best.tri->instance : best.instance,
    };
    return true;
}

typedef struct batch {
    const cv_trace_target *target;
    const cv_ray *rays;
    cv_hit *hits;
    uint32_t flags;
} batch;

static void trace_range(void *ctx, size_t begin, size_t end, uint32_t worker) {
    (void)worker;
    const batch *b = ctx;
    for (size_t i = begin; i < end; i++)
        cv_trace_ray(b->target, &b->rays[i], b->flags, &b->hits[i]);
}

cv_result cv_trace_batch(const cv_trace_target *target, const cv_ray *rays, uint32_t count, uint32_t flags,
                         uint32_t thread_count, cv_hit *hits) {
    if (!target || (count && (!rays || !hits)))
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_trace_batch: target, rays or hits is NULL");
    if ((target->flat != NULL) == (target->two_level != NULL))
        return cv_error(CV_ERROR_INVALID_ARGUMENT,
                        "cv_trace_batch: set exactly one of target->flat and "
                        "target->two_level");
    if (target->layout != CV_BVH_LAYOUT_SKIP && target->layout != CV_BVH_LAYOUT_NODE2)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_trace_batch: unknown layout %d", (int)target->layout);
    if (flags & ~(uint32_t)(CV_TRACE_ANY_HIT | CV_TRACE_CULL_BACK_FACES))
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_trace_batch: unknown flags 0x%x", flags);
    batch b = { .target = target, .rays = rays, .hits = hits, .flags = flags };
    cvs_parallel_for(cvs_thread_count(thread_count), count, 256, trace_range, &b);
    return CV_OK;
}
