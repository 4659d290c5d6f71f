/* The render graph: a frame described as passes over resources, baked into
 * per-device command lists, cross-device transfers and barriers.
 *
 * Two phases, as in Halcyon (seed 004) and Frostbite's frame graph:
 *
 * Construction (serial, one thread). Resources are declared by description
 * (transient textures and buffers the graph allocates) or imported (handles
 * the application already owns). Passes are added with a name, a queue type, a
 * multi-GPU policy (partition.h: PRIMARY_ONLY runs on devices[0] over the whole
 * width; ALL_DEVICES runs on every device over its column window) and typed
 * declarations of what they read and write. A write may carry a transfer rule
 * saying where its data must go when a pass on other devices reads it; left at
 * AUTO, a PRIMARY_ONLY -> ALL_DEVICES edge is a multicast and an
 * ALL_DEVICES -> PRIMARY_ONLY edge gathers each device's columns to the primary.
 *
 * A read sees the nearest write of the resource declared before it, or, for a
 * transient with no earlier writer, its first writer (so passes of single-writer
 * resources may be added in any order). A read of an imported resource with no
 * earlier writer sees what the application put there. cv_graph_history() names
 * the previous frame's contents of a transient, for temporal passes.
 *
 * Bake (cv_graph_bake) validates, culls passes that reach no output, orders,
 * places cross-device transfers, allocates transients from a pool (two with
 * the same description and disjoint lifetimes share one resource), places
 * barriers and lays out one command list per pass and device: the structure,
 * baked again only when the graph, the width, the tile, the devices that get
 * columns or the zero-copy choice changed. The partition step runs on every
 * bake (the renderer bakes every frame, with the balancer's new split): each
 * device's column window and the transfers' copy plans. A bake that fails
 * changes nothing: the previous bake stays executable.
 *
 * Evaluation (cv_graph_execute) records every pass instance on worker threads
 * through its record callback, submits in step order on each device, runs each
 * cross-device transfer once its source has finished, waits, and returns
 * per-pass timings. Transfers between devices whose backends have
 * asynchronous copies on a shared or host-import path (transfer.h: rings, one
 * per device pair, made by the graph) are queued on both devices with GPU-side
 * waits: then no step of the frame waits on the host. cv_graph_submit returns
 * without waiting at all; cv_graph_collect reads such a frame's timings and
 * feeds the balancer later, once it finished (lagged feedback: the balancer
 * then splits from a frame a few frames old, which converges the same way,
 * only later). cv_graph_bake_desc.sync_transfers makes every transfer
 * synchronous, as before rings existed (for comparisons: bench/mgpu_frames.sh).
 *
 * A pass is declared as one chain (kajiya's way): cv_graph_pass_begin() opens a
 * builder, each read, write or create returns the use the record callback
 * binds, and cv_graph_pass_end() adds the pass. The chain's calls keep the
 * first error, as command lists do: after a failing call the rest do nothing,
 * and the end returns that error naming the pass and the resource
 * ("graph: pass 'trace': write of 'visibility': ...") and adds nothing. A
 * record callback sees its column window and its uses' handles, never the
 * device count:
 *
 *     typedef struct trace_pass { cv_graph_use gbuffer, visibility; } trace_pass;
 *
 *     static void trace(const cv_graph_pass_context *pc, cv_command_list *l, void *user) {
 *         const trace_pass *t = user;
 *         cv_binding b[2] = { cv_graph_use_binding(pc, t->gbuffer), cv_graph_use_binding(pc, t->visibility) };
 *         struct { uint32_t x0, width; } push = { pc->x, pc->width };
 *         cv_cmd_dispatch(l, pc->queue, &(cv_dispatch_args){ ... .groups_x = (pc->width + 7) / 8 ... });
 *     }
 *
 *     cv_graph *g;
 *     cv_graph_create(ctx, devices, n, &g);
 *     cv_graph_resource gbuf, vis;
 *     raster_pass r;                                               // its uses, for raster()
 *     cv_graph_builder *b = cv_graph_pass_begin(g, &(cv_graph_pass_desc){ "gbuffer", CV_QUEUE_GRAPHICS,
 *                                                                         CV_MGPU_PRIMARY_ONLY, raster, &r });
 *     r.position = cv_graph_pass_create_texture(b, &(cv_texture_desc){ w, h, CV_FORMAT_RGBA32F,
 *                                                                     .label = "gbuffer" },
 *                                               CV_GRAPH_COLOR_TARGET, CV_GRAPH_TRANSFER_AUTO, &gbuf);
 *     cv_graph_pass_end(b, NULL);                                  // multicast to the trace pass
 *     trace_pass t;
 *     b = cv_graph_pass_begin(g, &(cv_graph_pass_desc){ "trace", CV_QUEUE_COMPUTE, CV_MGPU_ALL_DEVICES, trace, &t });
 *     t.gbuffer = cv_graph_pass_read(b, gbuf, CV_GRAPH_STORAGE_READ);
 *     t.visibility = cv_graph_pass_create_texture(b, &(cv_texture_desc){ w, h, CV_FORMAT_RGBA16F,
 *                                                                       .label = "visibility" },
 *                                                 CV_GRAPH_STORAGE_WRITE, CV_GRAPH_TRANSFER_AUTO, &vis);
 *     if (cv_graph_pass_end(b, NULL) != CV_OK)                     // gathered for the filter
 *         ... cv_last_error() names the pass and the declaration that failed ...
 *     ... a PRIMARY_ONLY "filter" pass reads vis and writes "image" ...
 *     cv_graph_output(g, image);
 *     each frame:
 *         cv_graph_bake(g, &(cv_graph_bake_desc){ .width = w, .tile = 8 });   // after the first: the partition step
 *                                                                              // only (the balancer's new split)
 *         cv_graph_execute(g, timings, CV_GRAPH_MAX_STEPS, &count);
 *     cv_graph_destroy(g);
 *
 * The older calls (cv_graph_create_texture, cv_graph_add_pass, cv_graph_read,
 * cv_graph_write, cv_graph_texture) still work and build the same graph; the
 * builder is the preferred way, since a pass then names each resource once.
 *
 * Errors name the pass and resource ("graph: pass 'trace': reads 'rays', a
 * transient no pass writes"). A graph is used by one thread at a time. */
#ifndef CORVID_GRAPH_H
#define CORVID_GRAPH_H

#include <stdio.h>

#include "corvid/device.h"
#include "corvid/partition.h"

typedef struct cv_graph cv_graph;

/* Handles within one graph; 0 is invalid. */
typedef struct cv_graph_resource {
    uint32_t id;
} cv_graph_resource;
typedef struct cv_graph_pass {
    uint32_t id;
} cv_graph_pass;

#define CV_GRAPH_MAX_PASSES 1024u
#define CV_GRAPH_MAX_RESOURCES 1024u
/* Evaluated frames whose records cv_graph_collect can still read. */
#define CV_GRAPH_FRAMES_KEPT 8u
/* Passes and transfers of one bake. */
#define CV_GRAPH_MAX_STEPS (2u * CV_GRAPH_MAX_PASSES)

/* How a pass uses a resource. The first four write, the others read; a
 * read-modify-write is declared as both a read and a write. */
typedef enum cv_graph_access {
    CV_GRAPH_COLOR_TARGET = 0, /* textures */
    CV_GRAPH_DEPTH_TARGET,     /* depth textures */
    CV_GRAPH_STORAGE_WRITE,
    CV_GRAPH_TRANSFER_DST,
    CV_GRAPH_STORAGE_READ,
    CV_GRAPH_SAMPLED, /* textures */
    CV_GRAPH_TRANSFER_SRC,
    CV_GRAPH_ACCESS_COUNT
} cv_graph_access;

/* Where a write's data goes when passes on other devices read it. */
typedef enum cv_graph_transfer {
    CV_GRAPH_TRANSFER_AUTO = 0,           /* multicast after PRIMARY_ONLY, gather after ALL_DEVICES */
    CV_GRAPH_TRANSFER_MULTICAST,          /* the primary's whole width to every device with a window */
    CV_GRAPH_TRANSFER_TO_PRIMARY,         /* each device's own columns back to the primary (isolated) */
    CV_GRAPH_TRANSFER_PRIMARY_TO_WINDOWS, /* from the primary, each device gets only its window */
} cv_graph_transfer;

typedef struct cv_graph_pass_context {
    const char *name;     /* the pass's name */
    cv_queue_type queue;  /* record on this queue */
    uint32_t x, width;    /* the pass's column window */
    uint32_t full_width;  /* the bake's width */
    bool history_valid;   /* history reads hold the previous frame (false on the first) */
    const void *instance; /* the graph's, for cv_graph_texture/cv_graph_buffer */
} cv_graph_pass_context;

/* The record callback of a pass: records the pass's commands for one device
 * (the window in pc) into `list`. Called on a worker thread, one call per list;
 * calls for different devices may run at once. Errors are the list's (sticky). */
typedef void (*cv_graph_record_fn)(const cv_graph_pass_context *pc, cv_command_list *list, void *user);

typedef struct cv_graph_pass_desc {
    const char *name; /* 1..CV_LABEL_MAX-1 bytes, unique in the graph */
    cv_queue_type queue;
    cv_mgpu_policy policy;
    cv_graph_record_fn record;
    void *user;
} cv_graph_pass_desc;

/* The handle a pass records for one of its declared resources on the device
 * it is recording for; an undeclared or wrong-typed resource gives id 0, which
 * the list rejects. */
cv_texture cv_graph_texture(const cv_graph_pass_context *pc, cv_graph_resource r);
cv_buffer cv_graph_buffer(const cv_graph_pass_context *pc, cv_graph_resource r);

/* devices[0] is the primary; all devices must belong to ctx. */
cv_result cv_graph_create(cv_context *ctx, cv_device *const *devices, uint32_t count, cv_graph **out);
/* Waits for the devices, destroys every resource and list the graph made. */
void cv_graph_destroy(cv_graph *g);

/* Construction. Transients: the graph allocates them (the label names them in
 * messages and dumps). column_bytes: for copies of a column range of a buffer,
 * bytes per column (0: the buffer only moves whole). */
cv_result cv_graph_create_texture(cv_graph *g, const cv_texture_desc *desc, cv_graph_resource *out);
cv_result cv_graph_create_buffer(cv_graph *g, const cv_buffer_desc *desc, uint64_t column_bytes,
                                 cv_graph_resource *out);
/* Imported: the application's handle, loaded on the devices that use it. */
cv_result cv_graph_import_texture(cv_graph *g, cv_texture t, cv_graph_resource *out);
cv_result cv_graph_import_buffer(cv_graph *g, cv_buffer b, uint64_t column_bytes, cv_graph_resource *out);
/* The previous frame's contents of transient r (read-only). r then keeps its
 * memory from frame to frame (it is not aliased). */
cv_result cv_graph_history(cv_graph *g, cv_graph_resource r, cv_graph_resource *out);
/* Marks r as a result of the graph: passes that reach it are kept, and it is
 * whole on the primary after execute. */
cv_result cv_graph_output(cv_graph *g, cv_graph_resource r);

cv_result cv_graph_add_pass(cv_graph *g, const cv_graph_pass_desc *desc, cv_graph_pass *out);
/* Leaves pass p out of the bakes that follow (enabled = false), or puts it
 * back. A disabled pass is baked as if it had never been added: its writes are
 * not seen, so a read of an imported resource it would have written sees what
 * the application (or an earlier execute) left there. For passes that run on
 * some frames only (a G-buffer drawn once, a filter on the last frame). */
cv_result cv_graph_enable_pass(cv_graph *g, cv_graph_pass p, bool enabled);
/* Declarations. Resources are checked at bake, so passes may name resources
 * in any order; these fail only on a bad pass or argument. */
cv_result cv_graph_read(cv_graph *g, cv_graph_pass p, cv_graph_resource r, cv_graph_access access);
cv_result cv_graph_write(cv_graph *g, cv_graph_pass p, cv_graph_resource r, cv_graph_access access,
                         cv_graph_transfer rule);
/* A built-in pass copying src to dst (same description) with copy commands,
 * over its window under ALL_DEVICES. */
cv_result cv_graph_add_copy_pass(cv_graph *g, const char *name, cv_mgpu_policy policy, cv_graph_resource src,
                                 cv_graph_resource dst, cv_graph_pass *out);

/* Graph pass builder: a pass under construction (graph.h's top comment).
 * Every builder cv_graph_pass_begin returns must be ended by cv_graph_pass_end,
 * which frees it. */
typedef struct cv_graph_builder cv_graph_builder;
/* One declaration of a pass: the resource (its id) and which declaration of
 * the pass it is (1, 2, ...). {0, 0}: the call failed, or an earlier one did. */
typedef struct cv_graph_use {
    uint32_t resource;
    uint32_t access;
} cv_graph_use;

/* Opens a builder for a pass of this description (checked now and again at
 * the end). Never NULL: a builder that could not be made fails at its end. */
cv_graph_builder *cv_graph_pass_begin(cv_graph *g, const cv_graph_pass_desc *desc);
/* Declarations, checked now (a known resource, an access of the right kind
 * for its type, no write of a history, a rule that fits the pass's policy, no
 * second write without a read between). After the chain's first failure they
 * do nothing and return {0, 0}. */
cv_graph_use cv_graph_pass_read(cv_graph_builder *b, cv_graph_resource r, cv_graph_access a);
cv_graph_use cv_graph_pass_write(cv_graph_builder *b, cv_graph_resource r, cv_graph_access a, cv_graph_transfer rule);
/* A transient the pass creates and writes (access a must be a write); *out
 * (may be NULL) its handle, usable by later passes, or {0} after a failure.
 * It joins the graph at the end, with the pass: no resource may be added to
 * the graph in between (the end then fails). */
cv_graph_use cv_graph_pass_create_texture(cv_graph_builder *b, const cv_texture_desc *desc, cv_graph_access a,
                                          cv_graph_transfer rule, cv_graph_resource *out);
cv_graph_use cv_graph_pass_create_buffer(cv_graph_builder *b, const cv_buffer_desc *desc, uint64_t column_bytes,
                                         cv_graph_access a, cv_graph_transfer rule, cv_graph_resource *out);
/* Ends the chain and frees the builder: the first error of any call above
 * (its message names the pass and the resource, cv_last_error() again), or
 * adds the pass with all its declarations and transients. A failed end adds
 * nothing. *out (may be NULL): the pass, {0} on failure. */
cv_result cv_graph_pass_end(cv_graph_builder *b, cv_graph_pass *out);
/* Record side: the handle or binding of a declared use on the device being
 * recorded. A use of another pass, a failed use, or a texture asked as a
 * buffer (or the reverse) gives id 0, which the list rejects. */
cv_texture cv_graph_use_texture(const cv_graph_pass_context *pc, cv_graph_use u);
cv_buffer cv_graph_use_buffer(const cv_graph_pass_context *pc, cv_graph_use u);
cv_binding cv_graph_use_binding(const cv_graph_pass_context *pc, cv_graph_use u);

/* Zero-copy gathers. A gathered texture (written by ALL_DEVICES passes, read
 * by the primary) can live in one memory that every device of one adapter
 * shares (cv_device_load_alias): each device writes its window straight into
 * the primary's texels and the transfer becomes a GPU-side wait on the
 * primary, moving no byte. A texture qualifies when it is a transient with no
 * history, every transfer of it is a gather to the primary, and no
 * ALL_DEVICES pass touches it after its gather; ALL_DEVICES passes must then
 * not read its texels outside their window (the other devices write them at
 * the same time). Before a device writes such a texture again, it waits on the
 * GPU for the primary's last use of it.
 *   AUTO: shares where every secondary can alias the primary and no
 *         transfer path is forced (transfer.h: a forced path is kept, for
 *         comparisons); a texture whose format the adapter cannot export (the
 *         alias is refused) is copied. (Programs read CORVID_ZERO_COPY into
 *         this field: apps/common/env_graph.h.)
 *   ON:   shares, or the bake fails naming the pair that cannot.
 *   OFF:  copies. */
typedef enum cv_graph_zero_copy {
    CV_GRAPH_ZERO_COPY_AUTO = 0,
    CV_GRAPH_ZERO_COPY_ON,
    CV_GRAPH_ZERO_COPY_OFF,
} cv_graph_zero_copy;

typedef struct cv_graph_bake_desc {
    uint32_t width;                /* columns of the X axis ALL_DEVICES passes split, > 0 */
    uint32_t tile;                 /* window starts are multiples of it; 0 = 8 */
    const cv_partition *partition; /* NULL: the graph's balancer splits the width */
    cv_graph_zero_copy zero_copy;
    /* Every transfer synchronous on the host, as before rings existed (for
     * comparisons; programs read CORVID_TRANSFER_ASYNC=0 into it:
     * apps/common/env_graph.h). false: asynchronous where the pair allows. */
    bool sync_transfers;
} cv_graph_bake_desc;

/* Bakes the graph for this frame's partition. The structure (validation,
 * culling, order, steps, transients and their aliasing, barriers, command
 * lists) is baked again only when a construction call changed the graph
 * since (a pass, declaration, resource, history, output or enabled pass), or
 * the width, the tile, the devices that get columns or zero_copy changed;
 * otherwise only the partition step runs (windows and copy plans).
 * sync_transfers and the partition itself may change freely. */
cv_result cv_graph_bake(cv_graph *g, const cv_graph_bake_desc *desc);

/* What a bake decided, for tests and tools (valid until the next bake). */
typedef struct cv_graph_stats {
    uint32_t passes, culled, steps, transfers, copies; /* copies: device-to-device copies of all transfers */
    uint32_t barriers;
    uint32_t transients, physical; /* transient resources, and the resources holding them */
    uint32_t rings;                /* asynchronous transfer rings the graph holds: made by the bake for each device
                       pair it copies between (where the pair allows rings), not during a frame */
    uint32_t zero_copy;            /* transfers that are GPU-side waits on shared memory (counted in transfers, not
                                      in copies) */
    uint32_t structure_bakes;      /* bakes of this graph so far that baked the structure (the others ran only the
                                      partition step) */
} cv_graph_stats;
cv_result cv_graph_get_stats(const cv_graph *g, cv_graph_stats *out);
/* The partition of the last bake. */
cv_result cv_graph_get_partition(const cv_graph *g, cv_partition *out);
/* Whether a pass survived culling. */
bool cv_graph_pass_kept(const cv_graph *g, cv_graph_pass p);
/* The physical resource index a transient was given (-1 if it has none). */
int32_t cv_graph_physical_of(const cv_graph *g, cv_graph_resource r);

typedef struct cv_graph_timing {
    char name[CV_LABEL_MAX]; /* pass name, or "transfer '<resource>'" */
    uint32_t device;         /* device index (a transfer: its source) */
    double ms;               /* GPU time; a transfer: host time (asynchronous: issuing it only) */
    uint64_t bytes;          /* a transfer: bytes moved between devices */
    double host_ms;          /* when it began on the host's CLOCK_MONOTONIC (cv_pass_timing.host_ms);
                                a transfer: when the graph began it; 0: the device cannot say */
} cv_graph_timing;

/* Records, submits, transfers and waits; one timing per pass instance and per
 * transfer, in step order (*count is the number there were; at most capacity
 * are written). */
cv_result cv_graph_execute(cv_graph *g, cv_graph_timing *timings, uint32_t capacity, uint32_t *count);
/* cv_graph_execute without the wait: records, submits and runs the transfers
 * (asynchronous where the pair allows, else synchronous on the host) in step
 * order, then returns with the last submissions still running. tickets[d] is
 * the last ticket of the frame on device d (0: none); waiting for it covers
 * the frame on that device (devices run submissions in order). For pipelining
 * frames (keeping several in flight to hide latency); each frame records into
 * its own set of lists (CV_GRAPH_FRAMES_KEPT sets, used in turn), which
 * submissions in flight allow. */
cv_result cv_graph_submit(cv_graph *g, uint64_t tickets[CV_MAX_DEVICES]);
/* The id of the frame the last execute or submit evaluated (1, 2, ...; 0: none). */
uint64_t cv_graph_frame_id(const cv_graph *g);
/* For a frame cv_graph_submit evaluated: waits until it finished (its
 * tickets; usually done already when it is a few frames old), writes its
 * timings as cv_graph_execute does and feeds the balancer with them (the
 * partition that frame used). Once per frame, while it is among the last
 * CV_GRAPH_FRAMES_KEPT evaluated; CV_ERROR_BAD_STATE otherwise, saying why.
 *
 *     cv_graph_submit(g, tickets);
 *     uint64_t id = cv_graph_frame_id(g);
 *     ... submit frames id + 1 .. id + 3 ...
 *     cv_graph_collect(g, id, timings, CV_GRAPH_MAX_STEPS, &n);   // the balancer learns from frame id */
cv_result cv_graph_collect(cv_graph *g, uint64_t frame, cv_graph_timing *timings, uint32_t capacity, uint32_t *count);

/* The baked graph as stable text (same graph, same bytes) and as Graphviz dot. */
cv_result cv_graph_dump_text(const cv_graph *g, FILE *f);
cv_result cv_graph_dump_dot(const cv_graph *g, FILE *f);

const char *cv_graph_access_name(cv_graph_access a);

#endif
