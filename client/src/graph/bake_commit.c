/* The bake's commit (graph.h): what the structure needs is created and
 * loaded: new pool entries, history frames, command lists, and every resource
 * on the devices that use it. The only step of a bake that changes the graph
 * (its pools are caches: what it made stays even if a later load fails). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bake.h"

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
cv_result bake_commit(cv_graph *g, bake_state *s, graph_baked *b) {
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
