/* The bake's barriers (graph.h): where a hazard lies on a device between
 * two accesses to the same memory (aliases share it). */
#include <stdlib.h>

#include "bake.h"

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
cv_result bake_place_barriers(const cv_graph *g, graph_baked *b) {
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
                    if (state[d][t].key == key && (bake_step_devices(b, st) >> d & 1))
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
