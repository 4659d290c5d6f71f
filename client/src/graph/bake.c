/* Render graph bake (graph.h): a straight list of named steps, one comment
 * each, in cv_graph_bake at the bottom. Everything up to the commit works on
 * scratch state, so a bake that fails leaves the previous one in place. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "graph_internal.h"

typedef struct bake_state {
    uint32_t n;               /* passes */
    uint32_t *access_base;    /* pass p's accesses are seen[access_base[p] ...] */
    int32_t *seen;            /* per access: the pass whose write a read sees, -1 for none */
    uint8_t *dep;             /* dep[a * n + b]: ORDER (a runs before b), NEEDS (b needs a's data) */
    uint32_t *order;          /* all passes, topologically */
    graph_physical *physical; /* the pool, then the entries this bake adds */
    uint32_t physical_count;
    graph_device_mask *devices; /* per resource: the devices that use it */
} bake_state;

enum { ORDER = 1, NEEDS = 2 };

static void bake_state_free(bake_state *s) {
    free(s->access_base);
    free(s->seen);
    free(s->dep);
    free(s->order);
    free(s->physical);
    free(s->devices);
}

static const graph_resource *res_of(const cv_graph *g, uint32_t id) {
    return &g->resources[(id & ~GRAPH_HISTORY_BIT) - 1];
}

static bool pass_writes(const graph_pass *p, uint32_t id) {
    if (p->disabled)
        return false; /* baked as if it were not there */
    for (uint32_t a = 0; a < p->access_count; a++)
        if (p->accesses[a].write && p->accesses[a].id == id)
            return true;
    return false;
}

/* The last pass before p (or the first after `after`) that writes id; -1 if none. */
static int32_t writer_before(const cv_graph *g, uint32_t id, int32_t p) {
    for (int32_t q = p - 1; q >= 0; q--)
        if (pass_writes(&g->passes[q], id))
            return q;
    return -1;
}

static int32_t writer_after(const cv_graph *g, uint32_t id, int32_t after) {
    for (uint32_t q = (uint32_t)(after + 1); q < g->pass_count; q++)
        if (pass_writes(&g->passes[q], id))
            return (int32_t)q;
    return -1;
}

static bool same_desc(const graph_resource *a, const graph_resource *b) {
    if (a->type != b->type)
        return false;
    if (a->type == CV_HANDLE_TEXTURE)
        return a->texture.width == b->texture.width && a->texture.height == b->texture.height &&
               a->texture.format == b->texture.format;
    return a->buffer.size == b->buffer.size;
}

/* Every declaration names a resource of the graph, in a way its type allows;
 * no pass writes a resource twice without reading it between; copy passes
 * copy between like resources. */
static cv_result validate(const cv_graph *g) {
    for (uint32_t p = 0; p < g->pass_count; p++) {
        const graph_pass *pass = &g->passes[p];
        for (uint32_t a = 0; a < pass->access_count; a++) {
            const graph_access *acc = &pass->accesses[a];
            bool history;
            const graph_resource *r = graph_lookup(g, acc->id, &history);
            if (!r)
                return cv_error(CV_ERROR_NOT_FOUND, "graph: pass '%s': %s of unknown resource #%u", pass->name,
                                cv_graph_access_name(acc->access), acc->id & ~GRAPH_HISTORY_BIT);
            if (history && acc->write)
                return cv_error(CV_ERROR_INVALID_ARGUMENT,
                                "graph: pass '%s': writes the history of '%s', which is "
                                "read-only",
                                pass->name, r->name);
            bool texture_only = acc->access == CV_GRAPH_COLOR_TARGET || acc->access == CV_GRAPH_DEPTH_TARGET ||
                                acc->access == CV_GRAPH_SAMPLED;
            if (texture_only && r->type != CV_HANDLE_TEXTURE)
                return cv_error(CV_ERROR_WRONG_HANDLE_TYPE, "graph: pass '%s': '%s' is a buffer, not a %s",
                                pass->name, r->name, cv_graph_access_name(acc->access));
            if (!acc->write)
                continue;
            for (int32_t b = (int32_t)a - 1; b >= 0; b--) {
                const graph_access *prev = &pass->accesses[b];
                if (prev->id != acc->id)
                    continue;
                if (prev->write)
                    return cv_error(CV_ERROR_INVALID_ARGUMENT,
                                    "graph: pass '%s': writes '%s' twice (%s, then %s) "
                                    "with no read between",
                                    pass->name, r->name, cv_graph_access_name(prev->access),
                                    cv_graph_access_name(acc->access));
                break;
            }
        }
        if (pass->record == graph_record_copy) {
            bool h1, h2;
            const graph_resource *src = graph_lookup(g, pass->copy_src, &h1),
                                 *dst = graph_lookup(g, pass->copy_dst, &h2);
            if (src && dst && !same_desc(src, dst))
                return cv_error(CV_ERROR_FORMAT_MISMATCH,
                                "graph: pass '%s': copies '%s' to '%s', which differ in "
                                "size or format",
                                pass->name, src->name, dst->name);
        }
    }
    return CV_OK;
}

/* Which write each read sees, and the edges: a read needs the write it sees
 * and runs before the next write of that resource (write-after-read); a write
 * runs after, and keeps, the write before it (write-after-write). */
static cv_result find_dependencies(const cv_graph *g, bake_state *s) {
    uint32_t n = s->n, accesses = 0;
    s->access_base = calloc(n + 1, sizeof(uint32_t));
    for (uint32_t p = 0; p < n && s->access_base; p++)
        accesses += g->passes[p].access_count, s->access_base[p + 1] = accesses;
    s->seen = malloc((accesses + 1) * sizeof(int32_t));
    s->dep = calloc((size_t)n * n + 1, 1);
    if (!s->access_base || !s->seen || !s->dep)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "graph: bake");
    for (uint32_t p = 0; p < n; p++) {
        const graph_pass *pass = &g->passes[p];
        for (uint32_t a = 0; a < pass->access_count; a++) {
            const graph_access *acc = &pass->accesses[a];
            int32_t *seen = &s->seen[s->access_base[p] + a];
            *seen = -1;
            if (pass->disabled || (acc->id & GRAPH_HISTORY_BIT))
                continue; /* last frame's contents: no edge this frame */
            const graph_resource *r = res_of(g, acc->id);
            int32_t w = writer_before(g, acc->id, (int32_t)p);
            if (acc->write) {
                if (w >= 0)
                    s->dep[(uint32_t)w * n + p] |= ORDER | NEEDS;
                continue;
            }
            if (w < 0 && !r->imported) {
                if (pass_writes(pass, acc->id))
                    return cv_error(CV_ERROR_BAD_STATE,
                                    "graph: pass '%s': reads '%s', a transient no pass writes "
                                    "before it",
                                    pass->name, r->name);
                w = writer_after(g, acc->id, (int32_t)p);
                if (w < 0)
                    return cv_error(CV_ERROR_BAD_STATE, "graph: pass '%s': reads '%s', a transient no pass writes",
                                    pass->name, r->name);
            }
            *seen = w;
            if (w >= 0)
                s->dep[(uint32_t)w * n + p] |= ORDER | NEEDS;
            int32_t next = writer_after(g, acc->id, w);
            if (next >= 0 && (uint32_t)next != p)
                s->dep[p * n + (uint32_t)next] |= ORDER;
        }
    }
    return CV_OK;
}

/* Kahn's algorithm, always taking the earliest-declared ready pass, so the
 * order is stable; what is left over lies on or behind a cycle, which the
 * message spells out. */
static cv_result order(const cv_graph *g, bake_state *s) {
    uint32_t n = s->n;
    uint32_t *indegree = calloc(n + 1, sizeof(uint32_t));
    bool *placed = calloc(n + 1, sizeof(bool));
    s->order = malloc((n + 1) * sizeof(uint32_t));
    if (!indegree || !placed || !s->order) {
        free(indegree);
        free(placed);
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "graph: bake");
    }
    for (uint32_t a = 0; a < n; a++)
        for (uint32_t b = 0; b < n; b++)
            indegree[b] += a != b && (s->dep[a * n + b] & ORDER);
    uint32_t count = 0;
    for (; count < n; count++) {
        uint32_t p = 0;
        while (p < n && (placed[p] || indegree[p]))
            p++;
        if (p == n)
            break;
        placed[p] = true;
        s->order[count] = p;
        for (uint32_t b = 0; b < n; b++)
            indegree[b] -= b != p && (s->dep[p * n + b] & ORDER);
    }
    cv_result res = CV_OK;
    if (count < n) {
        /* Walk back through unplaced predecessors until a pass repeats. */
        uint32_t *path = malloc((n + 1) * sizeof(uint32_t)), len = 0;
        uint32_t u = 0;
        while (placed[u])
            u++;
        for (bool repeat = false; path && !repeat;) {
            path[len++] = u;
            uint32_t v = 0;
            while (v < n && (placed[v] || v == u || !(s->dep[v * n + u] & ORDER)))
                v++;
            u = v;
            for (uint32_t i = 0; i < len && !repeat; i++)
                repeat = path[i] == u;
        }
        char text[CV_ERROR_MESSAGE_MAX / 2];
        size_t at = 0;
        text[0] = 0;
        if (path) {
            uint32_t j = 0;
            while (path[j] != u)
                j++;
            at += (size_t)snprintf(text, sizeof(text), "'%s'", g->passes[u].name);
            for (uint32_t i = len; i-- > j && at < sizeof(text);)
                at += (size_t)snprintf(text + at, sizeof(text) - at, " -> '%s'", g->passes[path[i]].name);
        }
        free(path);
        res = cv_error(CV_ERROR_INVALID_ARGUMENT, "graph: cycle through passes %s", text);
    }
    free(indegree);
    free(placed);
    return res;
}

static bool resource_reaches_output(const cv_graph *g, uint32_t index) {
    const graph_resource *r = &g->resources[index];
    if (r->output)
        return true;
    if (!r->history)
        return false;
    for (uint32_t p = 0; p < g->pass_count; p++)
        for (uint32_t a = 0; a < g->passes[p].access_count && !g->passes[p].disabled; a++)
            if (g->passes[p].accesses[a].id == ((index + 1) | GRAPH_HISTORY_BIT))
                return true; /* next frame reads it */
    return false;
}

/* Keeps the passes that write an output (or a resource whose history is read)
 * and, walking back, every pass whose data a kept pass needs. */
static cv_result cull(const cv_graph *g, const bake_state *s, graph_baked *b) {
    uint32_t n = s->n;
    b->kept = calloc(n + 1, sizeof(bool));
    uint32_t *work = malloc((n + 1) * sizeof(uint32_t)), top = 0;
    if (!b->kept || !work) {
        free(work);
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "graph: bake");
    }
    for (uint32_t p = 0; p < n; p++)
        for (uint32_t a = 0; a < g->passes[p].access_count && !b->kept[p] && !g->passes[p].disabled; a++) {
            const graph_access *acc = &g->passes[p].accesses[a];
            if (acc->write && resource_reaches_output(g, (acc->id & ~GRAPH_HISTORY_BIT) - 1)) {
                b->kept[p] = true;
                work[top++] = p;
            }
        }
    while (top) {
        uint32_t p = work[--top];
        for (uint32_t q = 0; q < n; q++)
            if (!b->kept[q] && q != p && (s->dep[q * n + p] & NEEDS)) {
                b->kept[q] = true;
                work[top++] = q;
            }
    }
    free(work);
    for (uint32_t p = 0; p < n; p++)
        b->stats.culled += !b->kept[p];
    b->stats.passes = n - b->stats.culled;
    return CV_OK;
}

/* The given partition, checked, or the balancer's split of the width. */
static cv_result partition(cv_graph *g, const cv_graph_bake_desc *desc, graph_baked *b) {
    if (desc->partition) {
        cv_result res = cv_partition_validate(desc->partition);
        if (res != CV_OK)
            return res;
        if (desc->partition->device_count != g->device_count ||
            (desc->width && desc->width != desc->partition->width))
            return cv_error(CV_ERROR_INVALID_ARGUMENT,
                            "graph: bake: the partition is for %u devices and %u columns, "
                            "the graph has %u devices and a width of %u",
                            desc->partition->device_count, desc->partition->width, g->device_count, desc->width);
        b->partition = *desc->partition;
    } else {
        cv_result res = cv_balancer_split(&g->balancer, desc->width, desc->tile ? desc->tile : 8, &b->partition);
        if (res != CV_OK)
            return res;
        b->balanced = true;
    }
    b->width = b->partition.width;
    return CV_OK;
}

/* Appends a step to a growing array (the baked steps, or the transfers waiting for their reader). */
static cv_result append_step(graph_step **items, uint32_t *count, uint32_t *capacity, const graph_step *step) {
    if (*count == *capacity) {
        uint32_t cap = *capacity ? *capacity * 2 : 16;
        graph_step *p = realloc(*items, cap * sizeof(*p));
        if (!p)
            return cv_error(CV_ERROR_OUT_OF_MEMORY, "graph: bake");
        *items = p;
        *capacity = cap;
    }
    (*items)[(*count)++] = *step;
    return CV_OK;
}

static cv_result push_step(graph_baked *b, uint32_t *capacity, const graph_step *step) {
    return append_step(&b->steps, &b->step_count, capacity, step);
}

static const cv_mgpu_transfer transfer_rules[] = {
    [CV_GRAPH_TRANSFER_MULTICAST] = CV_MGPU_MULTICAST,
    [CV_GRAPH_TRANSFER_TO_PRIMARY] = CV_MGPU_ISOLATED_TO_ISOLATED,
    [CV_GRAPH_TRANSFER_PRIMARY_TO_WINDOWS] = CV_MGPU_PRIMARY_TO_ISOLATED,
};

/* The copies one write needs: to all devices when a pass on all devices reads
 * what the primary wrote, back to the primary when the primary reads (or the
 * graph outputs) what all devices wrote; appended to `pending` (none: nothing). */
static cv_result transfers_of(const cv_graph *g, const bake_state *s, graph_baked *b, uint32_t p, uint32_t a,
                              graph_step **pending, uint32_t *pending_count, uint32_t *pending_capacity) {
    const graph_pass *pass = &g->passes[p];
    const graph_access *acc = &pass->accesses[a];
    const graph_resource *r = res_of(g, acc->id);
    bool primary = pass->policy == CV_MGPU_PRIMARY_ONLY;
    if (acc->rule != CV_GRAPH_TRANSFER_AUTO && primary != (acc->rule != CV_GRAPH_TRANSFER_TO_PRIMARY))
        return cv_error(CV_ERROR_INVALID_ARGUMENT,
                        "graph: pass '%s': writes '%s' with rule %s, which needs a %s pass "
                        "(after an ALL_DEVICES pass the primary holds only its own columns: gather them first)",
                        pass->name, r->name, cv_mgpu_transfer_name(transfer_rules[acc->rule]),
                        primary ? "ALL_DEVICES" : "PRIMARY_ONLY");
    bool to_all = false, to_primary = !primary && r->output && writer_after(g, acc->id, (int32_t)p) < 0;
    for (uint32_t q = 0; q < s->n; q++) {
        if (!b->kept[q] || q == p)
            continue;
        const graph_pass *reader = &g->passes[q];
        for (uint32_t c = 0; c < reader->access_count; c++)
            if (!reader->accesses[c].write && reader->accesses[c].id == acc->id &&
                s->seen[s->access_base[q] + c] == (int32_t)p) {
                to_all |= primary && reader->policy == CV_MGPU_ALL_DEVICES;
                to_primary |= !primary && reader->policy == CV_MGPU_PRIMARY_ONLY;
            }
    }
    if (!to_all && !to_primary)
        return CV_OK;
    graph_step step = { .transfer = true, .pass = p, .resource = (acc->id & ~GRAPH_HISTORY_BIT) - 1 };
    step.rule = to_primary                                          ? CV_MGPU_ISOLATED_TO_ISOLATED
                : acc->rule == CV_GRAPH_TRANSFER_PRIMARY_TO_WINDOWS ? CV_MGPU_PRIMARY_TO_ISOLATED
                                                                    : CV_MGPU_MULTICAST;
    cv_result res = cv_mgpu_plan_copies(&b->partition, 0, pass->policy, step.rule, &step.plan);
    if (res != CV_OK || step.plan.count == 0)
        return res;
    for (uint32_t c = 0; c < step.plan.count; c++) {
        cv_column_range cols = step.plan.copies[c].columns;
        bool whole = cols.x == 0 && cols.width == b->width;
        uint64_t end = r->type == CV_HANDLE_TEXTURE ? r->texture.width : r->buffer.size;
        uint64_t need = r->type == CV_HANDLE_TEXTURE ? cols.x + cols.width
                        : whole                      ? r->buffer.size
                                                     : (uint64_t)(cols.x + cols.width) * r->column_bytes;
        if (r->type == CV_HANDLE_BUFFER && !whole && r->column_bytes == 0)
            return cv_error(CV_ERROR_INVALID_ARGUMENT,
                            "graph: pass '%s': buffer '%s' moves in columns (%s) but was "
                            "declared with no column_bytes",
                            pass->name, r->name, cv_mgpu_transfer_name(step.rule));
        if (need > end)
            return cv_error(CV_ERROR_OUT_OF_RANGE,
                            "graph: pass '%s': '%s' is smaller than the %u columns its %s "
                            "transfer moves",
                            pass->name, r->name, b->width, cv_mgpu_transfer_name(step.rule));
    }
    b->stats.transfers++;
    b->stats.copies += step.plan.count;
    return append_step(pending, pending_count, pending_capacity, &step);
}

/* Moves the pending transfers that pass q (NULL: the end of the frame) must
 * come after into the steps, in the order they were made. */
static cv_result flush_transfers(graph_baked *b, uint32_t *capacity, graph_step *pending, uint32_t *count,
                                 const graph_pass *q) {
    uint32_t kept = 0;
    cv_result res = CV_OK;
    for (uint32_t i = 0; i < *count; i++) {
        if (res == CV_OK && (!q || graph_pass_touches(q, pending[i].resource)))
            res = push_step(b, capacity, &pending[i]);
        else
            pending[kept++] = pending[i];
    }
    *count = kept;
    return res;
}

/* Kept passes in order, each a step with one instance per device it runs on.
 * The transfers of what a pass wrote wait until the first later pass that
 * reads or writes the resource (or the frame's end, for outputs): devices run
 * their submissions in order, so a copy placed right after its producer would
 * hold every device it touches until its source is done, also passes that do
 * not need it (measured on an H200: the primary's reflect pass waited 0.9 ms
 * for the visibility copy-back, which only accumulate reads). */
static cv_result lay_out_steps(const cv_graph *g, const bake_state *s, graph_baked *b) {
    uint32_t capacity = 0, instance_capacity = 0, pending_count = 0, pending_capacity = 0;
    graph_step *pending = NULL; /* transfers waiting for their first reader */
    cv_result res = CV_OK;
    for (uint32_t i = 0; i < s->n && res == CV_OK; i++) {
        uint32_t p = s->order[i];
        if (!b->kept[p])
            continue;
        const graph_pass *pass = &g->passes[p];
        res = flush_transfers(b, &capacity, pending, &pending_count, pass);
        graph_step step = { .pass = p, .instance_first = b->instance_count };
        for (uint32_t d = 0; d < g->device_count && res == CV_OK; d++) {
            cv_column_range window = pass->policy == CV_MGPU_PRIMARY_ONLY ? (cv_column_range){ 0, b->width }
                                                                          : b->partition.ranges[d];
            if (window.width == 0 || (pass->policy == CV_MGPU_PRIMARY_ONLY && d != 0))
                continue;
            if (b->instance_count == instance_capacity) {
                instance_capacity = instance_capacity ? instance_capacity * 2 : 16;
                graph_instance *q = realloc(b->instances, instance_capacity * sizeof(*q));
                if (!q) {
                    res = cv_error(CV_ERROR_OUT_OF_MEMORY, "graph: bake");
                    break;
                }
                b->instances = q;
            }
            b->instances[b->instance_count] = (graph_instance){ .device = d,
                                                                .window = window,
                                                                .list = b->instance_count };
            b->instance_count++;
            step.instance_count++;
        }
        if (res == CV_OK)
            res = push_step(b, &capacity, &step);
        for (uint32_t a = 0; a < pass->access_count && res == CV_OK; a++) {
            const graph_access *acc = &pass->accesses[a];
            bool first_write = acc->write;
            for (uint32_t c = 0; c < a && first_write; c++)
                first_write = !(pass->accesses[c].write && pass->accesses[c].id == acc->id);
            if (first_write)
                res = transfers_of(g, s, b, p, a, &pending, &pending_count, &pending_capacity);
        }
    }
    if (res == CV_OK)
        res = flush_transfers(b, &capacity, pending, &pending_count, NULL);
    free(pending);
    if (res != CV_OK)
        return res;
    b->stats.steps = b->step_count;
    return CV_OK;
}

static graph_device_mask step_devices(const graph_baked *b, const graph_step *st) {
    graph_device_mask mask = 0;
    if (st->transfer)
        for (uint32_t c = 0; c < st->plan.count; c++)
            mask |= GRAPH_DEVICE_BIT(st->plan.copies[c].src_device) | GRAPH_DEVICE_BIT(st->plan.copies[c].dst_device);
    for (uint32_t i = 0; i < st->instance_count; i++)
        mask |= GRAPH_DEVICE_BIT(b->instances[st->instance_first + i].device);
    return mask;
}

/* Each transient's first and last step, and the devices every resource is used on. */
static cv_result lifetimes(const cv_graph *g, bake_state *s, graph_baked *b) {
    uint32_t n = g->resource_count;
    b->first = malloc((n + 1) * sizeof(uint32_t));
    b->last = calloc(n + 1, sizeof(uint32_t));
    s->devices = calloc(n + 1, sizeof(*s->devices));
    if (!b->first || !b->last || !s->devices)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "graph: bake");
    for (uint32_t r = 0; r < n; r++)
        b->first[r] = UINT32_MAX;
    for (uint32_t i = 0; i < b->step_count; i++) {
        const graph_step *st = &b->steps[i];
        graph_device_mask mask = step_devices(b, st);
        const graph_pass *pass = &g->passes[st->pass];
        for (uint32_t a = 0; a < (st->transfer ? 1 : pass->access_count); a++) {
            uint32_t r = st->transfer ? st->resource : (pass->accesses[a].id & ~GRAPH_HISTORY_BIT) - 1;
            s->devices[r] |= mask;
            if (!st->transfer && (pass->accesses[a].id & GRAPH_HISTORY_BIT))
                continue;
            if (b->first[r] == UINT32_MAX)
                b->first[r] = i;
            b->last[r] = i;
        }
    }
    return CV_OK;
}

/* The usage a transient's pool entry has: its own (0: the default), with
 * CV_TEXTURE_USAGE_SHARED exactly when it is a zero-copy gather. */
static uint32_t pool_usage(const graph_resource *r, bool shared) {
    uint32_t u = r->texture.usage;
    if (u == 0)
        u = cv_format_is_depth(r->texture.format) ? CV_TEXTURE_USAGE_DEPTH_TARGET | CV_TEXTURE_USAGE_SAMPLED
                                                  : CV_TEXTURE_USAGE_SAMPLED | CV_TEXTURE_USAGE_STORAGE;
    return shared ? u | CV_TEXTURE_USAGE_SHARED : u & ~(uint32_t)CV_TEXTURE_USAGE_SHARED;
}

static bool same_key(const graph_physical *p, const graph_resource *r, bool shared) {
    if (p->type != r->type)
        return false;
    if (p->type == CV_HANDLE_TEXTURE)
        return p->texture.width == r->texture.width && p->texture.height == r->texture.height &&
               p->texture.format == r->texture.format && p->texture.usage == pool_usage(r, shared);
    return p->buffer.size == r->buffer.size && p->buffer.usage == r->buffer.usage;
}

/* Transients, by first use, take the first pool entry of their description
 * that is free by then (its last user's lifetime is over), else a new one. */
static cv_result alias(const cv_graph *g, bake_state *s, graph_baked *b) {
    uint32_t n = g->resource_count;
    b->physical = malloc((n + 1) * sizeof(int32_t));
    s->physical = malloc((g->pool_count + n + 1) * sizeof(graph_physical));
    int64_t *busy_until = malloc((g->pool_count + n + 1) * sizeof(int64_t));
    if (!b->physical || !s->physical || !busy_until) {
        free(busy_until);
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "graph: bake");
    }
    if (g->pool_count) /* g->pool is NULL before the first bake */
        memcpy(s->physical, g->pool, g->pool_count * sizeof(graph_physical));
    s->physical_count = g->pool_count;
    for (uint32_t i = 0; i < g->pool_count + n; i++)
        busy_until[i] = -2; /* -2: unused this bake */
    for (uint32_t r = 0; r < n; r++)
        b->physical[r] = -1;
    for (uint32_t step = 0; step < b->step_count; step++)
        for (uint32_t r = 0; r < n; r++) {
            const graph_resource *res = &g->resources[r];
            if (b->first[r] != step || res->imported || res->history)
                continue;
            uint32_t i = 0;
            while (i < s->physical_count &&
                   !(same_key(&s->physical[i], res, b->shared[r]) && busy_until[i] < (int64_t)step))
                i++;
            if (i == s->physical_count) {
                s->physical[i] = (graph_physical){ .type = res->type,
                                                   .texture = res->texture,
                                                   .buffer = res->buffer };
                if (res->type == CV_HANDLE_TEXTURE)
                    s->physical[i].texture.usage = pool_usage(res, b->shared[r]);
                s->physical_count++;
            }
            b->stats.physical += busy_until[i] == -2;
            busy_until[i] = b->last[r];
            b->physical[r] = (int32_t)i;
            b->stats.transients++;
        }
    free(busy_until);
    return CV_OK;
}

typedef struct track {
    uint64_t key;
    bool written;
} track;

/* The identity of what an access touches: a pool entry (shared by aliases),
 * an imported handle, or one of a history resource's two frames. */
static uint64_t physical_key(const graph_baked *b, uint32_t r, bool history) {
    if (b->physical[r] >= 0)
        return 1 + (uint64_t)b->physical[r];
    return ((uint64_t)(history ? 3 : 2) << 32) | r;
}

/* Walks each device's steps in order with the last access to everything they
 * touch: a barrier goes before a pass wherever a write meets a later access
 * or a read meets a later write (never between two reads). A transfer waits
 * on the host, so it leaves nothing pending on either device. */
static cv_result place_barriers(const cv_graph *g, graph_baked *b) {
    uint32_t cap = 64, count = 0, tracked[CV_MAX_DEVICES] = { 0 };
    track *state[CV_MAX_DEVICES] = { 0 };
    cv_result res = CV_OK;
    b->barriers = malloc(cap * sizeof(graph_barrier));
    for (uint32_t d = 0; d < g->device_count; d++)
        if (!(state[d] = malloc((2 * g->resource_count + 1) * sizeof(track))))
            res = CV_ERROR_OUT_OF_MEMORY;
    if (!b->barriers)
        res = CV_ERROR_OUT_OF_MEMORY;
    for (uint32_t i = 0; i < b->step_count && res == CV_OK; i++) {
        graph_step *st = &b->steps[i];
        if (st->transfer) {
            uint64_t key = physical_key(b, st->resource, false);
            for (uint32_t d = 0; d < g->device_count; d++)
                for (uint32_t t = 0; t < tracked[d]; t++)
                    if (state[d][t].key == key && (step_devices(b, st) >> d & 1))
                        state[d][t] = state[d][--tracked[d]];
            continue;
        }
        const graph_pass *pass = &g->passes[st->pass];
        for (uint32_t k = 0; k < st->instance_count && res == CV_OK; k++) {
            graph_instance *inst = &b->instances[st->instance_first + k];
            uint32_t d = inst->device;
            inst->barrier_first = count;
            for (uint32_t a = 0; a < pass->access_count; a++) {
                uint32_t id = pass->accesses[a].id, r = (id & ~GRAPH_HISTORY_BIT) - 1;
                bool history = id & GRAPH_HISTORY_BIT, seen_before = false, write = false;
                for (uint32_t c = 0; c < pass->access_count; c++) {
                    seen_before |= c < a && pass->accesses[c].id == id;
                    write |= pass->accesses[c].id == id && pass->accesses[c].write;
                }
                if (seen_before)
                    continue;
                uint64_t key = physical_key(b, r, history);
                track *t = NULL;
                for (uint32_t j = 0; j < tracked[d] && !t; j++)
                    t = state[d][j].key == key ? &state[d][j] : NULL;
                if (t && (t->written || write)) {
                    if (count == cap) {
                        cap *= 2;
                        graph_barrier *q = realloc(b->barriers, cap * sizeof(*q));
                        if (!q) {
                            res = CV_ERROR_OUT_OF_MEMORY;
                            break;
                        }
                        b->barriers = q;
                    }
                    b->barriers[count++] = (graph_barrier){
                        .resource = r, .history = history, .after_write = t->written, .before_write = write
                    };
                }
                if (!t) {
                    t = &state[d][tracked[d]++];
                    t->key = key;
                    t->written = false;
                }
                t->written = write;
            }
            inst->barrier_count = count - inst->barrier_first;
        }
    }
    for (uint32_t d = 0; d < g->device_count; d++)
        free(state[d]);
    b->barrier_count = count;
    b->stats.barriers = count;
    return res == CV_OK ? CV_OK : cv_error(res, "graph: bake: barriers");
}

static cv_result create_like(cv_graph *g, cv_handle_type type, const cv_texture_desc *t, const cv_buffer_desc *bd,
                             const char *label, cv_handle *out) {
    cv_result res;
    if (type == CV_HANDLE_TEXTURE) {
        cv_texture_desc desc = *t;
        snprintf(desc.label, sizeof(desc.label), "%s", label);
        cv_texture h;
        res = cv_texture_create(g->ctx, &desc, &h);
        *out = cv_any(h);
    } else {
        cv_buffer_desc desc = *bd;
        snprintf(desc.label, sizeof(desc.label), "%s", label);
        cv_buffer h;
        res = cv_buffer_create(g->ctx, &desc, &h);
        *out = cv_any(h);
    }
    return res;
}

static cv_result load_on(cv_graph *g, cv_handle h, graph_device_mask mask) {
    cv_result res = CV_OK;
    for (uint32_t d = 0; d < g->device_count && res == CV_OK; d++)
        if ((mask >> d & 1) && !cv_device_has(g->devices[d], h))
            res = cv_device_load(g->devices[d], h);
    return res;
}

/* Creates the new pool entries, history frames and command lists, and loads
 * every resource on the devices that use it. What it created stays in the
 * graph's pools even if a later load fails (they are caches). */
static cv_result commit(cv_graph *g, bake_state *s, graph_baked *b) {
    if (s->physical_count > g->pool_capacity) {
        graph_physical *p = realloc(g->pool, s->physical_count * sizeof(*p));
        if (!p)
            return cv_error(CV_ERROR_OUT_OF_MEMORY, "graph: bake: pool");
        g->pool = p;
        g->pool_capacity = s->physical_count;
    }
    cv_result res = CV_OK;
    for (uint32_t i = g->pool_count; i < s->physical_count && res == CV_OK; i++) {
        const char *label = "";
        for (uint32_t r = 0; r < g->resource_count && !*label; r++)
            label = b->physical[r] == (int32_t)i ? g->resources[r].name : "";
        res = create_like(g, s->physical[i].type, &s->physical[i].texture, &s->physical[i].buffer, label,
                          &s->physical[i].handle);
        if (res == CV_OK)
            g->pool[g->pool_count++] = s->physical[i];
    }
    for (uint32_t r = 0; r < g->resource_count && res == CV_OK; r++) {
        graph_resource *gr = &g->resources[r];
        for (int f = 0; f < 2 && res == CV_OK && gr->history; f++)
            if (!gr->frames[f].id) {
                res = create_like(g, gr->type, &gr->texture, &gr->buffer, gr->name, &gr->frames[f]);
                g->history_epoch = g->frame;
            }
        if (res == CV_OK && s->devices[r]) {
            if (gr->history) {
                res = load_on(g, gr->frames[0], s->devices[r]);
                if (res == CV_OK)
                    res = load_on(g, gr->frames[1], s->devices[r]);
            } else {
                cv_handle h = gr->imported ? gr->handle : g->pool[b->physical[r]].handle;
                bool shareable = gr->imported
                                     ? gr->type == CV_HANDLE_TEXTURE && (gr->texture.usage & CV_TEXTURE_USAGE_SHARED)
                                     : graph_physical_shared(&g->pool[b->physical[r]]);
                res = shareable ? graph_load_shared(g, h, s->devices[r], b->shared[r]) : load_on(g, h, s->devices[r]);
                if (res == CV_ERROR_UNSUPPORTED && b->shared[r] && !b->zero_copy_required) {
                    /* auto: the adapter could not export this texture: copies, as without zero-copy */
                    graph_unshare(b, r);
                    res = graph_load_shared(g, h, s->devices[r], false);
                }
            }
        }
    }
    /* Every set of lists (one per frame kept for cv_graph_collect) grows alike. */
    for (uint32_t k = 0; k < CV_GRAPH_FRAMES_KEPT && res == CV_OK && b->instance_count > g->list_count; k++) {
        cv_cmdlist *lists = realloc(g->list_sets[k], b->instance_count * sizeof(*lists));
        if (!lists)
            return cv_error(CV_ERROR_OUT_OF_MEMORY, "graph: bake: lists");
        memset(lists + g->list_count, 0, (b->instance_count - g->list_count) * sizeof(*lists));
        g->list_sets[k] = lists;
    }
    while (res == CV_OK && g->list_count < b->instance_count) {
        uint32_t made = 0;
        for (; made < CV_GRAPH_FRAMES_KEPT && res == CV_OK; made++)
            res = cv_cmdlist_create(g->ctx, &g->list_sets[made][g->list_count]);
        if (res != CV_OK) /* every set has list_count lists: drop this row's */
            for (uint32_t k = 0; k + 1 < made; k++)
                cv_cmdlist_destroy(g->ctx, g->list_sets[k][g->list_count]);
        g->list_count += res == CV_OK;
    }
    return res;
}

cv_result cv_graph_bake(cv_graph *g, const cv_graph_bake_desc *desc) {
    if (!g || !desc)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_graph_bake: NULL argument");
    bake_state s = { .n = g->pass_count };
    graph_baked b = { 0 };
    /* 1. Validate: known resources, accesses their types allow, no double write in a pass;
     *    the environment's transfer switch (graph.h). */
    bool async;
    cv_result res = graph_transfer_async(&async);
    if (res == CV_OK)
        res = validate(g);
    /* 2. Dependencies: the write each read sees; read-after-write, write-after-write, write-after-read edges. */
    if (res == CV_OK)
        res = find_dependencies(g, &s);
    /* 3. Order: stable topological sort of every pass; a cycle is an error naming its passes. */
    if (res == CV_OK)
        res = order(g, &s);
    /* 4. Cull: keep only passes that reach an output. */
    if (res == CV_OK)
        res = cull(g, &s, &b);
    /* 5. Partition: the columns of each device (given, or the balancer's). */
    if (res == CV_OK)
        res = partition(g, desc, &b);
    /* 6. Steps: kept passes in order with their device instances, each followed
     *    by the cross-device transfers its writes need (cv_mgpu_plan_copies). */
    if (res == CV_OK)
        res = lay_out_steps(g, &s, &b);
    /* 7. Lifetimes: each transient's first and last step; the devices using each resource. */
    if (res == CV_OK)
        res = lifetimes(g, &s, &b);
    /* 7b. Zero-copy: the gathered textures the devices share (graph.h, cv_graph_zero_copy). */
    if (res == CV_OK)
        res = graph_choose_zero_copy(g, desc, &b);
    /* 8. Alias: transients to pool entries keyed by description, shared when lifetimes are disjoint. */
    if (res == CV_OK)
        res = alias(g, &s, &b);
    /* 9. Barriers: exactly where a hazard is on a device (write->read, write->write, read->write). */
    if (res == CV_OK)
        res = place_barriers(g, &b);
    /* 10. Commit: create what is new, load resources where they are used, one command list per instance. */
    if (res == CV_OK)
        res = commit(g, &s, &b);
    bake_state_free(&s);
    if (res != CV_OK) {
        graph_baked_free(&b);
        return res;
    }
    graph_baked_free(&g->baked);
    b.valid = true;
    g->baked = b;
    /* 11. Rings for the pairs it copies between, outside the frames (best effort). */
    graph_make_rings(g);
    return CV_OK;
}

cv_result cv_graph_get_stats(const cv_graph *g, cv_graph_stats *out) {
    if (!g || !out || !g->baked.valid)
        return cv_error(CV_ERROR_BAD_STATE, "cv_graph_get_stats: the graph is not baked");
    *out = g->baked.stats;
    out->rings = 0;
    for (uint32_t s = 0; s < g->device_count; s++)
        for (uint32_t d = 0; d < g->device_count; d++)
            out->rings += g->rings[s][d] != NULL;
    return CV_OK;
}

cv_result cv_graph_get_partition(const cv_graph *g, cv_partition *out) {
    if (!g || !out || !g->baked.valid)
        return cv_error(CV_ERROR_BAD_STATE, "cv_graph_get_partition: the graph is not baked");
    *out = g->baked.partition;
    return CV_OK;
}

bool cv_graph_pass_kept(const cv_graph *g, cv_graph_pass p) {
    return g && g->baked.valid && p.id && p.id <= g->baked.stats.passes + g->baked.stats.culled &&
           g->baked.kept[p.id - 1];
}

int32_t cv_graph_physical_of(const cv_graph *g, cv_graph_resource r) {
    uint32_t index = r.id & ~GRAPH_HISTORY_BIT;
    if (!g || !g->baked.valid || index == 0 || index > g->resource_count)
        return -1;
    return g->baked.physical[index - 1];
}
