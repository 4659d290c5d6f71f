/* The bake's memory (graph.h): each transient's lifetime in steps and the
 * devices every resource is used on; transients with disjoint lifetimes and
 * the same description share a pool entry. */
#include <stdlib.h>
#include <string.h>

#include "bake.h"

graph_device_mask bake_step_devices(const graph_baked *b, const graph_step *st) {
    graph_device_mask mask = 0;
    if (st->transfer)
        for (uint32_t c = 0; c < st->plan.count; c++)
            mask |= GRAPH_DEVICE_BIT(st->plan.copies[c].src_device) | GRAPH_DEVICE_BIT(st->plan.copies[c].dst_device);
    for (uint32_t i = 0; i < st->instance_count; i++)
        mask |= GRAPH_DEVICE_BIT(b->instances[st->instance_first + i].device);
    return mask;
}

/* Each transient's first and last step, and the devices every resource is used on. */
cv_result bake_lifetimes(const cv_graph *g, bake_state *s, graph_baked *b) {
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
        graph_device_mask mask = bake_step_devices(b, st);
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
cv_result bake_alias(const cv_graph *g, bake_state *s, graph_baked *b) {
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
