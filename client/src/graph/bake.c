/* Render graph bake (graph.h): a straight list of named steps, one comment
 * each, in two parts: the structure (bake_structure), baked again only when
 * its key changed, and the partition step, run by every bake. The steps live
 * in the bake_*.c files (bake.h). Everything up to the commit works on
 * scratch state, so a bake that fails leaves the previous one in place. */
#include <stdlib.h>

#include "bake.h"

static void bake_state_free(bake_state *s) {
    free(s->access_base);
    free(s->seen);
    free(s->dep);
    free(s->order);
    free(s->physical);
    free(s->devices);
}

/* Whether the baked structure holds for b (its key: no construction call
 * since, the same width, tile, devices with columns and zero-copy choice). */
static bool structure_holds(const cv_graph *g, const graph_baked *b) {
    const graph_baked *old = &g->baked;
    return old->valid && old->epoch == b->epoch && old->width == b->width &&
           old->partition.tile == b->partition.tile && old->active == b->active && old->zero_copy == b->zero_copy;
}

/* Everything that does not depend on the columns, for b's partition. */
static cv_result bake_structure(cv_graph *g, graph_baked *b) {
    bake_state s = { .n = g->pass_count };
    /* 1. Validate: known resources, accesses their types allow, no double write in a pass. */
    cv_result res = bake_validate(g);
    /* 2. Dependencies: the write each read sees; read-after-write, write-after-write, write-after-read edges. */
    if (res == CV_OK)
        res = bake_find_dependencies(g, &s);
    /* 3. Order: stable topological sort of every pass; a cycle is an error naming its passes. */
    if (res == CV_OK)
        res = bake_order(g, &s);
    /* 4. Cull: keep only passes that reach an output. */
    if (res == CV_OK)
        res = bake_cull(g, &s, b);
    /* 5. Steps: kept passes in order with their device instances, each followed
     *    by the cross-device transfers its writes need (cv_mgpu_plan_copies). */
    if (res == CV_OK)
        res = bake_lay_out_steps(g, &s, b);
    /* 6. Lifetimes: each transient's first and last step; the devices using each resource. */
    if (res == CV_OK)
        res = bake_lifetimes(g, &s, b);
    /* 7. Zero-copy: the gathered textures the devices share (graph.h, cv_graph_zero_copy). */
    if (res == CV_OK)
        res = graph_choose_zero_copy(g, b->zero_copy, b);
    /* 8. Alias: transients to pool entries keyed by description, shared when lifetimes are disjoint. */
    if (res == CV_OK)
        res = bake_alias(g, &s, b);
    /* 9. Barriers: exactly where a hazard is on a device (write->read, write->write, read->write). */
    if (res == CV_OK)
        res = bake_place_barriers(g, b);
    /* 10. Commit: create what is new, load resources where they are used, one command list per instance. */
    if (res == CV_OK)
        res = bake_commit(g, &s, b);
    bake_state_free(&s);
    return res;
}

cv_result cv_graph_bake(cv_graph *g, const cv_graph_bake_desc *desc) {
    if (!g || !desc)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_graph_bake: NULL argument");
    if ((unsigned)desc->zero_copy > CV_GRAPH_ZERO_COPY_OFF)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_graph_bake: zero_copy %d is not AUTO, ON or OFF",
                        (int)desc->zero_copy);
    graph_baked b = { .epoch = g->structure_epoch,
                      .zero_copy = desc->zero_copy,
                      .sync_transfers = desc->sync_transfers };
    /* 1. Partition: the columns of each device (given, or the balancer's). */
    cv_result res = bake_partition(g, desc, &b);
    /* 2. The structure, kept while it holds: then only the windows and copy plans
     *    of its steps follow the partition; else baked anew. */
    bool holds = res == CV_OK && structure_holds(g, &b);
    if (res == CV_OK)
        res = holds ? bake_repartition(g, &g->baked, &b) : bake_structure(g, &b);
    if (res != CV_OK) {
        if (!holds)
            graph_baked_free(&b);
        return res;
    }
    if (holds) { /* b shares the rest with g->baked */
        free(g->baked.steps);
        free(g->baked.instances);
    } else {
        graph_baked_free(&g->baked);
        g->structure_bakes++;
    }
    b.valid = true;
    g->baked = b;
    /* 3. Rings for the pairs it copies between, outside the frames (best effort). */
    graph_make_rings(g);
    return CV_OK;
}

cv_result cv_graph_get_stats(const cv_graph *g, cv_graph_stats *out) {
    if (!g || !out || !g->baked.valid)
        return cv_error(CV_ERROR_BAD_STATE, "cv_graph_get_stats: the graph is not baked");
    *out = g->baked.stats;
    out->structure_bakes = g->structure_bakes;
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
