/* The bake's step list (graph.h): kept passes in order, each a step with
 * one instance per device it runs on, and the cross-device transfers their
 * writes need, each placed before the first later pass that touches what it
 * moves. Windows and copy plans come from the partition (bake_partition.c). */
#include <stdlib.h>

#include "bake.h"

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
    const graph_resource *r = bake_resource_of(g, acc->id);
    bool primary = pass->policy == CV_MGPU_PRIMARY_ONLY;
    if (acc->rule != CV_GRAPH_TRANSFER_AUTO && primary != (acc->rule != CV_GRAPH_TRANSFER_TO_PRIMARY))
        return cv_error(CV_ERROR_INVALID_ARGUMENT,
                        "graph: pass '%s': writes '%s' with rule %s, which needs a %s pass "
                        "(after an ALL_DEVICES pass the primary holds only its own columns: gather them first)",
                        pass->name, r->name, cv_mgpu_transfer_name(transfer_rules[acc->rule]),
                        primary ? "ALL_DEVICES" : "PRIMARY_ONLY");
    bool to_all = false, to_primary = !primary && r->output && bake_writer_after(g, acc->id, (int32_t)p) < 0;
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
    cv_result res = bake_plan_transfer(g, b, &step);
    if (res != CV_OK || step.plan.count == 0)
        return res;
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
cv_result bake_lay_out_steps(const cv_graph *g, const bake_state *s, graph_baked *b) {
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
            cv_column_range window = bake_window(b, pass->policy, d);
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
