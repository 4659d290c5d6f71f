/* The bake's steps (graph.h), one file each, run in order by cv_graph_bake
 * (bake.c). The structure (bake_order.c, bake_steps.c, bake_memory.c,
 * bake_barriers.c, bake_commit.c) is baked when the graph or the bake's shape
 * changed; the partition step (bake_partition.c) on every bake. Everything up
 * to the commit works on scratch state, so a bake that fails leaves the
 * previous one in place. */
#ifndef CORVID_GRAPH_BAKE_H
#define CORVID_GRAPH_BAKE_H

#include "graph_internal.h"

/* One structure bake's scratch state. */
typedef struct bake_state {
    uint32_t n;               /* passes */
    uint32_t *access_base;    /* pass p's accesses are seen[access_base[p] ...] */
    int32_t *seen;            /* per access: the pass whose write a read sees, -1 for none */
    uint8_t *dep;             /* dep[a * n + b]: BAKE_ORDER (a runs before b), BAKE_NEEDS (b needs a's data) */
    uint32_t *order;          /* all passes, topologically */
    graph_physical *physical; /* the pool, then the entries this bake adds */
    uint32_t physical_count;
    graph_device_mask *devices; /* per resource: the devices that use it */
} bake_state;

enum { BAKE_ORDER = 1, BAKE_NEEDS = 2 };

/* bake_order.c: declarations checked; the write each read sees and the
 * edges; a stable topological order (a cycle fails naming its passes); the
 * passes that reach an output kept. The resource of a declared id; the first
 * pass after `after` writing id (-1: none). */
cv_result bake_validate(const cv_graph *g);
cv_result bake_find_dependencies(const cv_graph *g, bake_state *s);
cv_result bake_order(const cv_graph *g, bake_state *s);
cv_result bake_cull(const cv_graph *g, const bake_state *s, graph_baked *b);
const graph_resource *bake_resource_of(const cv_graph *g, uint32_t id);
int32_t bake_writer_after(const cv_graph *g, uint32_t id, int32_t after);

/* bake_partition.c: the partition (given, or the balancer's split) with the
 * devices that have columns; a pass instance's window; a transfer step's copy
 * plan under b's partition (its columns checked against the resource); and
 * the partition step alone: `old`'s structure with b's partition (b then
 * holds its own steps and instances, and shares old's other arrays). */
cv_result bake_partition(cv_graph *g, const cv_graph_bake_desc *desc, graph_baked *b);
cv_column_range bake_window(const graph_baked *b, cv_mgpu_policy policy, uint32_t device);
cv_result bake_plan_transfer(const cv_graph *g, const graph_baked *b, graph_step *st);
cv_result bake_repartition(const cv_graph *g, const graph_baked *old, graph_baked *b);

/* bake_steps.c: kept passes in order with their instances and transfers. */
cv_result bake_lay_out_steps(const cv_graph *g, const bake_state *s, graph_baked *b);

/* bake_memory.c: the devices a step runs on; lifetimes and devices per
 * resource; transients to pool entries. */
graph_device_mask bake_step_devices(const graph_baked *b, const graph_step *st);
cv_result bake_lifetimes(const cv_graph *g, bake_state *s, graph_baked *b);
cv_result bake_alias(const cv_graph *g, bake_state *s, graph_baked *b);

/* bake_barriers.c: a barrier wherever a hazard is on a device. */
cv_result bake_place_barriers(const cv_graph *g, graph_baked *b);

/* bake_commit.c: creates what is new, loads resources where they are used,
 * one command list per instance. */
cv_result bake_commit(cv_graph *g, bake_state *s, graph_baked *b);

#endif
