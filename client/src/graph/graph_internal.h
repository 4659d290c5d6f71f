/* The render graph's own structures, shared by its files: construction
 * (graph.c, builder.c), bake (bake.c and its steps, bake.h), evaluation
 * (execute.c), dumps (dump.c). */
#ifndef CORVID_GRAPH_INTERNAL_H
#define CORVID_GRAPH_INTERNAL_H

#include "corvid/graph.h"
#include "corvid/transfer.h"

/* Asynchronous transfer rings: a copy into a slot waits (on the GPU) for the
 * read of the copy two before it. Slots are bounded: making a ring costs
 * time in proportion to its memory (host-import pins and imports it into
 * both devices: on the H200 about 85 ms for a ring of three 41 MB slots,
 * docs/nvidia.md), and the whole-image G-buffer multicast of a first frame
 * may as well move in pieces. */
#define GRAPH_RING_SLOTS 2u
#define GRAPH_RING_SLOT_MIN (1ull << 20)
#define GRAPH_RING_SLOT_MAX (16ull << 20)

/* A resource handle's id: index + 1, with this bit set for its history. */
#define GRAPH_HISTORY_BIT 0x80000000u

typedef struct graph_resource {
    char name[CV_LABEL_MAX];
    cv_handle_type type; /* CV_HANDLE_BUFFER or CV_HANDLE_TEXTURE */
    cv_texture_desc texture;
    cv_buffer_desc buffer;
    uint64_t column_bytes;
    bool imported, output, history;
    cv_handle handle;        /* imported */
    cv_handle frames[2];     /* history: frames[frame & 1] is this frame's, the other the previous */
    uint64_t primary_ticket; /* imported zero-copy gathers: as graph_physical's */
} graph_resource;

typedef struct graph_access {
    uint32_t id; /* as declared: checked at bake */
    cv_graph_access access;
    cv_graph_transfer rule;
    bool write;
} graph_access;

typedef struct graph_pass {
    char name[CV_LABEL_MAX];
    cv_queue_type queue;
    cv_mgpu_policy policy;
    cv_graph_record_fn record;
    void *user;
    graph_access *accesses;
    uint32_t access_count, access_capacity;
    uint32_t copy_src, copy_dst; /* built-in copy pass: resource ids */
    bool disabled;               /* cv_graph_enable_pass(false): left out of bakes */
} graph_pass;

/* A barrier at the start of a pass instance's list. */
typedef struct graph_barrier {
    uint32_t resource; /* index */
    bool history;
    bool after_write, before_write; /* the earlier access wrote; this one writes */
} graph_barrier;

/* A pass on one device. */
typedef struct graph_instance {
    uint32_t device;
    cv_column_range window;
    uint32_t list; /* index into cv_graph.lists */
    uint32_t barrier_first, barrier_count;
} graph_instance;

typedef struct graph_step {
    bool transfer;
    uint32_t pass;                           /* the pass, or a transfer's source pass */
    uint32_t resource;                       /* transfers */
    cv_mgpu_transfer rule;                   /* transfers */
    cv_mgpu_copy_plan plan;                  /* transfers */
    uint32_t instance_first, instance_count; /* passes */
    bool zero_copy;                          /* transfers: shared memory, a GPU-side wait on the primary */
} graph_step;

/* A resource holding transients (aliased when lifetimes are disjoint). */
typedef struct graph_physical {
    cv_handle_type type;
    cv_texture_desc texture; /* key: the description, label left out */
    cv_buffer_desc buffer;
    cv_handle handle;
    /* Shared (CV_TEXTURE_USAGE_SHARED in `texture`): the primary's latest
     * ticket that used it, which secondaries wait for before using it again. */
    uint64_t primary_ticket;
} graph_physical;

/* A set of the graph's devices, bit d for device d: one bit for every device
 * a graph may have (CV_MAX_DEVICES), so never a 32-bit type. */
typedef uint64_t graph_device_mask;
_Static_assert(CV_MAX_DEVICES <= 64, "graph_device_mask has a bit per device");
#define GRAPH_DEVICE_BIT(d) ((graph_device_mask)1 << (d))

typedef struct graph_baked {
    bool valid;
    /* The partition step's, redone by every bake. */
    uint32_t width;
    bool balanced; /* the partition came from the balancer */
    cv_partition partition;
    bool sync_transfers; /* cv_graph_bake_desc.sync_transfers */
    graph_step *steps;   /* (their copy plans) */
    uint32_t step_count;
    graph_instance *instances; /* (their windows) */
    uint32_t instance_count;
    /* The structure's, kept by bakes while its key below holds. */
    graph_barrier *barriers;
    uint32_t barrier_count;
    bool *kept;              /* per pass */
    int32_t *physical;       /* per resource: pool index or -1 */
    uint32_t *first, *last;  /* per resource: lifetime in steps (transients) */
    bool *shared;            /* per resource: a zero-copy gather (in a shared pool entry) */
    bool zero_copy_required; /* CV_GRAPH_ZERO_COPY_ON: a texture that cannot be shared fails the bake */
    cv_graph_stats stats;
    /* The structure's key: the graph's structure_epoch, the devices with
     * columns (a partition's copy plans and instances follow them) and the
     * zero-copy choice it was baked with (and the width and tile, above). */
    uint64_t epoch;
    graph_device_mask active;
    cv_graph_zero_copy zero_copy;
} graph_baked;

/* What one evaluated frame ran, for cv_graph_collect: per pass instance its
 * device, ticket and list, per transfer its bytes and host time. */
typedef struct graph_entry {
    bool transfer;
    uint32_t pass;     /* the pass, or a transfer's source pass */
    uint32_t resource; /* transfers */
    uint32_t device;   /* a transfer: its first source device */
    uint64_t ticket;   /* passes */
    double ms;         /* transfers: host time issuing (async) or moving (sync) */
    double host_ms;    /* transfers: when it began, CLOCK_MONOTONIC */
    uint64_t bytes;    /* transfers */
} graph_entry;

typedef struct graph_frame {
    uint64_t id; /* cv_graph_frame_id of the frame recorded here; 0: none */
    bool collected;
    uint64_t last[CV_MAX_DEVICES]; /* each device's last ticket of the frame (0: none) */
    graph_entry *entries;
    uint32_t count, capacity;
    cv_partition partition;
    bool balanced;
} graph_frame;

struct cv_graph {
    cv_context *ctx;
    cv_device *devices[CV_MAX_DEVICES];
    uint32_t device_count;
    graph_resource *resources;
    uint32_t resource_count, resource_capacity;
    graph_pass *passes;
    uint32_t pass_count, pass_capacity;
    graph_physical *pool;
    uint32_t pool_count, pool_capacity;
    cv_cmdlist *lists; /* the list set of the frame being evaluated: list_sets[frame % CV_GRAPH_FRAMES_KEPT] */
    cv_cmdlist *list_sets[CV_GRAPH_FRAMES_KEPT];
    uint32_t list_count; /* lists in each set */
    graph_frame frames[CV_GRAPH_FRAMES_KEPT];
    /* Asynchronous transfer rings per (source, destination) device pair, where
     * the pair allows them (transfer.h): made when a bake first plans copies
     * between the pair (graph_make_rings), so the first frames do not pay for
     * them (host-import: ~85 ms a ring on the H200), else at the first copy. */
    cv_transfer_ring *rings[CV_MAX_DEVICES][CV_MAX_DEVICES];
    cv_balancer balancer;
    uint64_t frame;                          /* executes so far: picks the history frames */
    uint64_t history_epoch;                  /* g->frame when history frames were last created */
    uint64_t primary_waited[CV_MAX_DEVICES]; /* per secondary: the primary's ticket it last GPU-waited for */
    graph_baked baked;
    /* Bumped by every construction call (graph_changed): a bake redoes the
     * structure when it moved since the structure was last baked. */
    uint64_t structure_epoch;
    uint32_t structure_bakes; /* cv_graph_stats.structure_bakes */
};

/* What a record callback's pc->instance points at. */
typedef struct graph_record_ctx {
    const cv_graph *graph;
    uint32_t pass;
    uint32_t device;
} graph_record_ctx;

/* graph.c, shared with the builder (builder.c): growth of the graph's
 * arrays; a pass description's checks against the graph (name, queue, policy,
 * callback, limits); the pass appended (its arrays grown beforehand; it takes
 * `accesses`, heap memory, over); a construction change (structure_epoch). */
bool graph_grow(void **items, uint32_t *capacity, uint32_t needed, size_t size);
cv_result graph_check_pass(const cv_graph *g, const cv_graph_pass_desc *desc);
cv_graph_pass graph_push_pass(cv_graph *g, const cv_graph_pass_desc *desc, graph_access *accesses, uint32_t count);
void graph_changed(cv_graph *g);
/* Whether a transient texture's description is one (sizes, format); a
 * transient's record (texture or buffer: the other NULL). */
bool graph_texture_ok(const cv_texture_desc *desc);
graph_resource graph_transient(const cv_texture_desc *texture, const cv_buffer_desc *buffer, uint64_t column_bytes);
/* The resource behind an id, or NULL (sets *history). */
const graph_resource *graph_lookup(const cv_graph *g, uint32_t id, bool *history);
/* The handle an access to resource `index` (its history if `history`) uses on the devices. */
cv_handle graph_handle_of(const cv_graph *g, uint32_t index, bool history);
bool graph_access_writes(cv_graph_access a);
/* Whether pass q reads or writes resource index r (its own or its history). */
bool graph_pass_touches(const graph_pass *q, uint32_t r);
void graph_baked_free(graph_baked *b);
/* The built-in copy pass's record callback. */
void graph_record_copy(const cv_graph_pass_context *pc, cv_command_list *list, void *user);

/* execute.c: the bytes of one planned copy; the pair's ring (made or replaced
 * for the path in force, sized from `bytes`; NULL: copy synchronously); the
 * rings of every pair the baked steps copy between, made now (bake). */
uint64_t graph_copy_bytes(const cv_graph *g, const graph_step *st, const cv_mgpu_copy *cp);
cv_transfer_ring *graph_pair_ring(cv_graph *g, uint32_t s, uint32_t d, uint64_t bytes);
void graph_make_rings(cv_graph *g);

/* zero_copy.c: which gathered textures the devices share (graph.h,
 * cv_graph_zero_copy), decided after the steps are laid out: sets b->shared
 * and the steps' zero_copy, moves their copies in the stats. */
cv_result graph_choose_zero_copy(cv_graph *g, cv_graph_zero_copy mode, graph_baked *b);
/* Resource r copies after all (its texture could not be shared): its steps
 * and the stats go back to copies. */
void graph_unshare(graph_baked *b, uint32_t r);
/* Whether pool entry p is shared memory. */
bool graph_physical_shared(const graph_physical *p);
/* Loads h (a shared pool entry, or an imported texture created with
 * CV_TEXTURE_USAGE_SHARED) on the devices in mask: with `shared`, on the
 * primary and as aliases of it on the others; without, an ordinary
 * representation everywhere (an alias an earlier bake made is replaced). */
cv_result graph_load_shared(cv_graph *g, cv_handle h, graph_device_mask mask, bool shared);
/* Execution: a zero-copy transfer step (the primary waits for each source's
 * instance of the writing pass in frame fr; last[] rises to the waits'
 * tickets); before a secondary's instance, its wait for the
 * primary's last use of the shared entries the pass touches; after a step,
 * the primary's ticket recorded on them. */
cv_result graph_zero_copy_handover(cv_graph *g, const graph_step *st, const graph_frame *fr, uint64_t *last);
cv_result graph_zero_copy_before(cv_graph *g, const graph_step *st, uint32_t device, uint64_t *last);
void graph_zero_copy_after(cv_graph *g, const graph_step *st, uint64_t primary_ticket);

#endif
