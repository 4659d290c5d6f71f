/* Binned-SAH builder.
 *
 * A node is split by binning the centroids of its primitives along all three
 * axes, sweeping the bins for the cheapest SAH plane, and partitioning the
 * primitive references in place (each subtree owns a contiguous range). Big
 * subtrees are handed to a shared task stack that a pool of threads drains;
 * small ones are finished by the thread that made them. */
#include "bvh_builder.h"

#include <math.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

#include "big_alloc.h"
#include "parallel.h"

#define MAX_BINS 64u
/* Subtrees with at least this many primitives go to the shared task stack. */
#define PARALLEL_GRAIN 4096u

typedef struct task {
    uint32_t node, begin, end, depth;
    float cmin[3], cmax[3]; /* centroid bounds of refs[begin, end) */
} task;

typedef struct task_stack {
    task *items;
    uint32_t count, cap;
} task_stack;

typedef struct builder {
    cvs_prim_ref *refs;
    cvs_tree_node *nodes;
    atomic_uint node_count;
    cv_bvh_build_options opt;
    pthread_mutex_t lock;
    pthread_cond_t cond;
    task_stack shared;  /* guarded by lock */
    uint32_t busy;      /* tasks taken and not finished; guarded by lock */
    atomic_bool failed; /* an allocation failed: stop early, report OOM */
} builder;

typedef struct split {
    bool valid;
    int axis;
    uint32_t bin; /* refs with bin < this go left */
    float cost;   /* scaled by the parent's area (no division) */
    float lmin[3], lmax[3], rmin[3], rmax[3];
} split;

cv_result cvs_bvh_options_resolve(const cv_bvh_build_options *in, cv_bvh_build_options *out) {
    cv_bvh_build_options o = in ? *in : (cv_bvh_build_options){ 0 };
    if (o.bin_count == 0)
        o.bin_count = 16;
    if (o.max_leaf_size == 0)
        o.max_leaf_size = 8;
    if (o.traversal_cost == 0.0f)
        o.traversal_cost = 1.0f;
    if (o.intersection_cost == 0.0f)
        o.intersection_cost = 1.0f;
    o.thread_count = cvs_thread_count(o.thread_count);
    if (o.bin_count < 2 || o.bin_count > MAX_BINS)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "BVH options: bin_count %u not in 2..%u", o.bin_count, MAX_BINS);
    if (o.max_leaf_size > CV_BVH_MAX_LEAF_SIZE)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "BVH options: max_leaf_size %u not in 1..%u", o.max_leaf_size,
                        CV_BVH_MAX_LEAF_SIZE);
    if (!(o.traversal_cost > 0.0f) || !(o.intersection_cost > 0.0f) || o.traversal_cost > 1e6f ||
        o.intersection_cost > 1e6f)
        return cv_error(CV_ERROR_INVALID_ARGUMENT,
                        "BVH options: costs %g (traversal) and %g (intersection) "
                        "must be in (0, 1e6]",
                        (double)o.traversal_cost, (double)o.intersection_cost);
    *out = o;
    return CV_OK;
}

static inline float centroid(const cvs_prim_ref *r, int axis) { return (r->min[axis] + r->max[axis]) * 0.5f; }

static inline void box_empty(float min[3], float max[3]) {
    for (int k = 0; k < 3; k++) {
        min[k] = INFINITY;
        max[k] = -INFINITY;
    }
}

static inline void box_grow_box(float min[3], float max[3], const float bmin[3], const float bmax[3]) {
    for (int k = 0; k < 3; k++) {
        min[k] = bmin[k] < min[k] ? bmin[k] : min[k];
        max[k] = bmax[k] > max[k] ? bmax[k] : max[k];
    }
}

static inline void box_grow_centroid(float min[3], float max[3], const cvs_prim_ref *r) {
    for (int k = 0; k < 3; k++) {
        float c = centroid(r, k);
        min[k] = c < min[k] ? c : min[k];
        max[k] = c > max[k] ? c : max[k];
    }
}

/* Bin of a centroid; identical arithmetic in binning and partitioning. */
static inline uint32_t bin_of(float c, float cmin, float scale, uint32_t bins) {
    int b = (int)((c - cmin) * scale);
    return b < 0 ? 0u : (uint32_t)b >= bins ? bins - 1 : (uint32_t)b;
}

/* 0 when the axis cannot be binned: no extent, or one so small that the
 * scale overflows (which would turn bin indices into inf/NaN casts). */
static inline float bin_scale(const task *t, int axis, uint32_t bins) {
    float extent = t->cmax[axis] - t->cmin[axis];
    float scale = extent > 0.0f ? (float)bins * 0.99999f / extent : 0.0f;
    return isfinite(scale) ? scale : 0.0f;
}

/* Bins for a node: fewer than primitives would only cost time. */
static inline uint32_t node_bins(const builder *b, const task *t) {
    uint32_t n = t->end - t->begin;
    return n < 2 ? 2 : n < b->opt.bin_count ? n : b->opt.bin_count;
}

/* A bin's box, four lanes wide (the fourth unused) so the compiler can grow
 * it with one vector min and one vector max. */
typedef struct bin {
    float lo[4], hi[4];
} bin;

static inline void bin_empty(bin *b) {
    for (int k = 0; k < 4; k++) {
        b->lo[k] = INFINITY;
        b->hi[k] = -INFINITY;
    }
}

static inline void bin_grow(bin *b, const float lo[4], const float hi[4]) {
    for (int k = 0; k < 4; k++) {
        b->lo[k] = lo[k] < b->lo[k] ? lo[k] : b->lo[k];
        b->hi[k] = hi[k] > b->hi[k] ? hi[k] : b->hi[k];
    }
}

static inline float bin_area(const bin *b) { return cvs_half_area(b->lo, b->hi); }

static split find_split(const builder *b, const task *t) {
    const uint32_t bins = node_bins(b, t);
    /* Two sets of bins, for even and odd references: neighbours often fall
     * in the same bin, and one set would chain every update to the last.
     * Small nodes use one (setting up the second would cost more). */
    const uint32_t sets = t->end - t->begin >= 64 ? 2 : 1;
    uint32_t count[2][3][MAX_BINS];
    bin box[2][3][MAX_BINS];
    float scale[3];
    split best = { .valid = false };
    for (int a = 0; a < 3; a++) {
        scale[a] = bin_scale(t, a, bins);
        for (uint32_t i = 0; i < bins; i++) {
            for (uint32_t set = 0; set < sets; set++) {
                count[set][a][i] = 0;
                bin_empty(&box[set][a][i]);
            }
        }
    }
    for (uint32_t i = t->begin; i < t->end; i++) {
        /* Whole 16-byte rows (lane 3 carries id / pad bits, never read back):
         * one load each instead of a store-forwarding stall. */
        float lo[4], hi[4];
        memcpy(lo, (const char *)&b->refs[i], sizeof lo);
        memcpy(hi, (const char *)&b->refs[i] + offsetof(cvs_prim_ref, max), sizeof hi);
        const uint32_t set = i & (sets - 1);
        /* The three axes written out: lets the compiler keep lo/hi in registers. */
        uint32_t kx = bin_of((lo[0] + hi[0]) * 0.5f, t->cmin[0], scale[0], bins);
        uint32_t ky = bin_of((lo[1] + hi[1]) * 0.5f, t->cmin[1], scale[1], bins);
        uint32_t kz = bin_of((lo[2] + hi[2]) * 0.5f, t->cmin[2], scale[2], bins);
        count[set][0][kx]++;
        count[set][1][ky]++;
        count[set][2][kz]++;
        bin_grow(&box[set][0][kx], lo, hi);
        bin_grow(&box[set][1][ky], lo, hi);
        bin_grow(&box[set][2][kz], lo, hi);
    }
    for (int a = 0; a < 3 && sets == 2; a++) {
        for (uint32_t k = 0; k < bins; k++) {
            count[0][a][k] += count[1][a][k];
            bin_grow(&box[0][a][k], box[1][a][k].lo, box[1][a][k].hi);
        }
    }
    for (int a = 0; a < 3; a++) {
        if (scale[a] == 0.0f)
            continue;
        /* Right-to-left sweep: area and count of bins [s, bins). */
        float rarea[MAX_BINS];
        uint32_t rcount[MAX_BINS];
        bin acc;
        bin_empty(&acc);
        uint32_t n = 0;
        for (uint32_t s = bins - 1; s > 0; s--) {
            bin_grow(&acc, box[0][a][s].lo, box[0][a][s].hi);
            n += count[0][a][s];
            rcount[s] = n;
            rarea[s] = n ? bin_area(&acc) : 0.0f;
        }
        bin_empty(&acc);
        uint32_t l = 0;
        for (uint32_t s = 1; s < bins; s++) {
            bin_grow(&acc, box[0][a][s - 1].lo, box[0][a][s - 1].hi);
            l += count[0][a][s - 1];
            if (l == 0 || rcount[s] == 0)
                continue;
            float cost = bin_area(&acc) * (float)l + rarea[s] * (float)rcount[s];
            if (!best.valid || cost < best.cost) {
                best.valid = true;
                best.axis = a;
                best.bin = s;
                best.cost = cost;
                memcpy(best.lmin, acc.lo, sizeof best.lmin);
                memcpy(best.lmax, acc.hi, sizeof best.lmax);
            }
        }
    }
    if (best.valid) {
        /* The right box of the winner, recomputed from its bins. */
        bin right;
        bin_empty(&right);
        for (uint32_t s = best.bin; s < bins; s++)
            bin_grow(&right, box[0][best.axis][s].lo, box[0][best.axis][s].hi);
        memcpy(best.rmin, right.lo, sizeof best.rmin);
        memcpy(best.rmax, right.hi, sizeof best.rmax);
    }
    return best;
}

/* In-place partition by bin; returns the first right index and fills the
 * children's centroid bounds. */
static uint32_t partition_bins(builder *b, const task *t, const split *s, task *left, task *right) {
    const int a = s->axis;
    const uint32_t bins = node_bins(b, t);
    const float scale = bin_scale(t, a, bins);
    uint32_t i = t->begin, j = t->end;
    box_empty(left->cmin, left->cmax);
    box_empty(right->cmin, right->cmax);
    while (i < j) {
        cvs_prim_ref *r = &b->refs[i];
        if (bin_of(centroid(r, a), t->cmin[a], scale, bins) < s->bin) {
            box_grow_centroid(left->cmin, left->cmax, r);
            i++;
        } else {
            j--;
            cvs_prim_ref tmp = *r;
            *r = b->refs[j];
            b->refs[j] = tmp;
            box_grow_centroid(right->cmin, right->cmax, &b->refs[j]);
        }
    }
    return i;
}

/* Reorders refs[begin, end) so that the k-th smallest centroid along axis is
 * at k and everything before it is not larger (quickselect, median-of-three
 * pivots: deterministic). */
static void select_kth(cvs_prim_ref *refs, uint32_t begin, uint32_t end, uint32_t k, int axis) {
    while (end - begin > 1) {
        uint32_t mid = begin + (end - begin) / 2;
        float a = centroid(&refs[begin], axis), m = centroid(&refs[mid], axis), z = centroid(&refs[end - 1], axis);
        float pivot = a < m ? (m < z ? m : (a < z ? z : a)) : (a < z ? a : (m < z ? z : m));
        /* Three-way partition: [begin, lt) < pivot, [lt, gt) == pivot, [gt, end) > pivot. */
        uint32_t lt = begin, i = begin, gt = end;
        while (i < gt) {
            float c = centroid(&refs[i], axis);
            if (c < pivot) {
                cvs_prim_ref tmp = refs[lt];
                refs[lt++] = refs[i];
                refs[i++] = tmp;
            } else if (c > pivot) {
                cvs_prim_ref tmp = refs[--gt];
                refs[gt] = refs[i];
                refs[i] = tmp;
            } else {
                i++;
            }
        }
        if (k < lt)
            end = lt;
        else if (k >= gt)
            begin = gt;
        else
            return;
    }
}

static void child_bounds(const builder *b, task *c, float min[3], float max[3]) {
    box_empty(min, max);
    box_empty(c->cmin, c->cmax);
    for (uint32_t i = c->begin; i < c->end; i++) {
        box_grow_box(min, max, b->refs[i].min, b->refs[i].max);
        box_grow_centroid(c->cmin, c->cmax, &b->refs[i]);
    }
}

static uint32_t ceil_log2(uint32_t n) {
    uint32_t l = 0;
    while ((1ull << l) < n)
        l++;
    return l;
}

/* Splits the task's node or makes it a leaf; returns true with two child tasks. */
static bool process(builder *b, const task *t, task out[2]) {
    cvs_tree_node *node = &b->nodes[t->node];
    const uint32_t n = t->end - t->begin;
    const cv_bvh_build_options *o = &b->opt;
    split s = { .valid = false };
    bool halve = t->depth + ceil_log2(n) >= CV_BVH_MAX_DEPTH;
    if (n > 1 && !halve)
        s = find_split(b, t);
    float area = cvs_half_area(node->min, node->max);
    float leaf_cost = o->intersection_cost * (float)n * area;
    float split_cost = o->traversal_cost * area + o->intersection_cost * s.cost;
    if (n == 1 || (n <= o->max_leaf_size && (!s.valid || leaf_cost <= split_cost))) {
        node->index = t->begin;
        node->count = n;
        return false;
    }
    task left = { .begin = t->begin, .depth = t->depth + 1 };
    task right = { .end = t->end, .depth = t->depth + 1 };
    uint32_t child = atomic_fetch_add(&b->node_count, 2);
    cvs_tree_node *l = &b->nodes[child], *r = &b->nodes[child + 1];
    if (s.valid) {
        left.end = right.begin = partition_bins(b, t, &s, &left, &right);
        memcpy(l->min, s.lmin, sizeof l->min);
        memcpy(l->max, s.lmax, sizeof l->max);
        memcpy(r->min, s.rmin, sizeof r->min);
        memcpy(r->max, s.rmax, sizeof r->max);
    } else {
        /* No usable plane (centroids coincide) or too deep: halve by count
         * along the axis of widest centroid spread. */
        int axis = 0;
        for (int k = 1; k < 3; k++)
            if (t->cmax[k] - t->cmin[k] > t->cmax[axis] - t->cmin[axis])
                axis = k;
        left.end = right.begin = t->begin + n / 2;
        if (t->cmax[axis] > t->cmin[axis])
            select_kth(b->refs, t->begin, t->end, left.end, axis);
        child_bounds(b, &left, l->min, l->max);
        child_bounds(b, &right, r->min, r->max);
    }
    node->index = child;
    node->count = 0;
    left.node = child;
    right.node = child + 1;
    out[0] = left;
    out[1] = right;
    return true;
}

static bool stack_push(task_stack *s, const task *t) {
    if (s->count == s->cap) {
        uint32_t cap = s->cap ? s->cap * 2 : 64;
        task *p = realloc(s->items, cap * sizeof(task));
        if (!p)
            return false;
        s->items = p;
        s->cap = cap;
    }
    s->items[s->count++] = *t;
    return true;
}

static void share(builder *b, const task *t, task_stack *local) {
    pthread_mutex_lock(&b->lock);
    bool ok = stack_push(&b->shared, t);
    if (ok)
        pthread_cond_signal(&b->cond);
    pthread_mutex_unlock(&b->lock);
    if (!ok && !stack_push(local, t))
        atomic_store(&b->failed, true);
}

/* Builds the subtree of `t`, sharing big child subtrees when other threads exist. */
static void run_subtree(builder *b, const task *t, task_stack *local, bool threaded) {
    local->count = 0;
    if (!stack_push(local, t)) {
        atomic_store(&b->failed, true);
        return;
    }
    while (local->count > 0 && !atomic_load_explicit(&b->failed, memory_order_relaxed)) {
        task cur = local->items[--local->count], kids[2];
        if (!process(b, &cur, kids))
            continue;
        if (threaded && kids[1].end - kids[1].begin >= PARALLEL_GRAIN)
            share(b, &kids[1], local);
        else if (!stack_push(local, &kids[1]))
            atomic_store(&b->failed, true);
        if (!stack_push(local, &kids[0]))
            atomic_store(&b->failed, true);
    }
}

static void *worker(void *arg) {
    builder *b = arg;
    task_stack local = { 0 };
    for (;;) {
        pthread_mutex_lock(&b->lock);
        while (b->shared.count == 0 && b->busy > 0)
            pthread_cond_wait(&b->cond, &b->lock);
        if (b->shared.count == 0) {
            pthread_mutex_unlock(&b->lock);
            break;
        }
        task t = b->shared.items[--b->shared.count];
        b->busy++;
        pthread_mutex_unlock(&b->lock);

        run_subtree(b, &t, &local, true);

        pthread_mutex_lock(&b->lock);
        if (atomic_load(&b->failed))
            b->shared.count = 0;
        if (--b->busy == 0 && b->shared.count == 0)
            pthread_cond_broadcast(&b->cond);
        pthread_mutex_unlock(&b->lock);
    }
    free(local.items);
    return NULL;
}

static void run_threads(builder *b, const task *root) {
    pthread_mutex_init(&b->lock, NULL);
    pthread_cond_init(&b->cond, NULL);
    if (!stack_push(&b->shared, root)) {
        atomic_store(&b->failed, true);
    } else {
        pthread_t tids[CVS_MAX_THREADS];
        uint32_t started = 0;
        for (uint32_t i = 1; i < b->opt.thread_count; i++) {
            if (pthread_create(&tids[started], NULL, worker, b) != 0)
                break;
            started++;
        }
        worker(b);
        for (uint32_t i = 0; i < started; i++)
            pthread_join(tids[i], NULL);
    }
    free(b->shared.items);
    pthread_cond_destroy(&b->cond);
    pthread_mutex_destroy(&b->lock);
}

cv_result cvs_tree_build(cvs_prim_ref *refs, uint32_t count, const cv_bvh_build_options *opt, cvs_tree *out) {
    memset(out, 0, sizeof *out);
    if (count == 0)
        return CV_OK;
    builder b = { .refs = refs, .opt = *opt };
    /* A binary tree with count leaves at most has 2 * count - 1 nodes; the
     * untouched tail of the allocation is never paged in. */
    b.nodes = cvs_big_alloc(((size_t)2 * count) * sizeof(cvs_tree_node));
    uint32_t *ids = malloc((size_t)count * sizeof(uint32_t));
    if (!b.nodes || !ids) {
        free(b.nodes);
        free(ids);
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "BVH build: no memory for the tree of %u primitives", count);
    }
    atomic_init(&b.node_count, 1);
    atomic_init(&b.failed, false);
    task root = { .node = 0, .begin = 0, .end = count, .depth = 0 };
    child_bounds(&b, &root, b.nodes[0].min, b.nodes[0].max);
    if (count >= CVS_BVH_PARALLEL_MIN && opt->thread_count > 1) {
        run_threads(&b, &root);
    } else {
        task_stack local = { 0 };
        run_subtree(&b, &root, &local, false);
        free(local.items);
    }
    if (atomic_load(&b.failed)) {
        free(b.nodes);
        free(ids);
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "BVH build: out of memory for task stacks (%u primitives)", count);
    }
    for (uint32_t i = 0; i < count; i++)
        ids[i] = refs[i].id;
    out->nodes = b.nodes;
    out->node_count = atomic_load(&b.node_count);
    out->prim_ids = ids;
    out->prim_count = count;
    return CV_OK;
}

void cvs_tree_free(cvs_tree *tree) {
    free(tree->nodes);
    free(tree->prim_ids);
    memset(tree, 0, sizeof *tree);
}
