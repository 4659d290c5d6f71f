/* The bake's partition step (graph.h), the part of a bake redone every
 * frame: the columns of each device, the pass instances' windows and the
 * transfers' copy plans. The rest of the bake depends only on which devices
 * have columns (a copy plan's copies go to and from exactly those), so a
 * new split of the same devices keeps the structure. */
#include <stdlib.h>
#include <string.h>

#include "bake.h"

cv_result bake_partition(cv_graph *g, const cv_graph_bake_desc *desc, graph_baked *b) {
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
    b->active = 0;
    for (uint32_t d = 0; d < g->device_count; d++)
        if (b->partition.ranges[d].width)
            b->active |= GRAPH_DEVICE_BIT(d);
    return CV_OK;
}

cv_column_range bake_window(const graph_baked *b, cv_mgpu_policy policy, uint32_t device) {
    return policy == CV_MGPU_PRIMARY_ONLY ? (cv_column_range){ 0, b->width } : b->partition.ranges[device];
}

cv_result bake_plan_transfer(const cv_graph *g, const graph_baked *b, graph_step *st) {
    const graph_pass *pass = &g->passes[st->pass];
    const graph_resource *r = &g->resources[st->resource];
    cv_result res = cv_mgpu_plan_copies(&b->partition, 0, pass->policy, st->rule, &st->plan);
    for (uint32_t c = 0; c < st->plan.count && res == CV_OK; c++) {
        cv_column_range cols = st->plan.copies[c].columns;
        bool whole = cols.x == 0 && cols.width == b->width;
        uint64_t end = r->type == CV_HANDLE_TEXTURE ? r->texture.width : r->buffer.size;
        uint64_t need = r->type == CV_HANDLE_TEXTURE ? cols.x + cols.width
                        : whole                      ? r->buffer.size
                                                     : (uint64_t)(cols.x + cols.width) * r->column_bytes;
        if (r->type == CV_HANDLE_BUFFER && !whole && r->column_bytes == 0)
            return cv_error(CV_ERROR_INVALID_ARGUMENT,
                            "graph: pass '%s': buffer '%s' moves in columns (%s) but was "
                            "declared with no column_bytes",
                            pass->name, r->name, cv_mgpu_transfer_name(st->rule));
        if (need > end)
            return cv_error(CV_ERROR_OUT_OF_RANGE,
                            "graph: pass '%s': '%s' is smaller than the %u columns its %s "
                            "transfer moves",
                            pass->name, r->name, b->width, cv_mgpu_transfer_name(st->rule));
    }
    return res;
}

cv_result bake_repartition(const cv_graph *g, const graph_baked *old, graph_baked *b) {
    graph_baked next = *old;
    next.partition = b->partition;
    next.width = b->width;
    next.balanced = b->balanced;
    next.steps = malloc((old->step_count + 1) * sizeof(graph_step));
    next.instances = malloc((old->instance_count + 1) * sizeof(graph_instance));
    cv_result res = next.steps && next.instances ? CV_OK : cv_error(CV_ERROR_OUT_OF_MEMORY, "graph: bake");
    if (res == CV_OK) {
        memcpy(next.steps, old->steps, old->step_count * sizeof(graph_step));
        memcpy(next.instances, old->instances, old->instance_count * sizeof(graph_instance));
    }
    for (uint32_t i = 0; i < next.step_count && res == CV_OK; i++) {
        graph_step *st = &next.steps[i];
        if (st->transfer)
            res = bake_plan_transfer(g, &next, st);
        for (uint32_t k = 0; k < st->instance_count; k++) {
            graph_instance *inst = &next.instances[st->instance_first + k];
            inst->window = bake_window(&next, g->passes[st->pass].policy, inst->device);
        }
    }
    if (res != CV_OK) {
        free(next.steps);
        free(next.instances);
        return res;
    }
    next.active = b->active;
    next.zero_copy = b->zero_copy;
    next.sync_transfers = b->sync_transfers;
    *b = next;
    return CV_OK;
}
