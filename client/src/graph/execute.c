/* Render graph evaluation (graph.h): every pass instance is recorded on a
 * worker thread into its own list, then the steps run in order: lists are
 * submitted to their devices (which run submissions in order) and each
 * transfer moves its columns once its source's work is done: through the
 * pair's asynchronous ring (transfer.h) where the pair has one, queued on
 * both devices with GPU-side waits and no host wait; otherwise synchronously.
 * What a frame ran is kept (graph_frame, one per list set) so its timings can
 * be read, and the balancer fed, once it finished (cv_graph_collect). */
#include <pthread.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

#include "corvid/clock.h"
#include "corvid/transfer.h"
#include "device_internal.h"
#include "graph_internal.h"

#define MAX_RECORD_THREADS 8u
#define INSTANCES_PER_THREAD 4u

typedef struct recorder {
    cv_graph *g;
    uint32_t *step_of; /* per instance: its step */
    atomic_uint next;  /* the next instance to record */
} recorder;

static void record_instance(cv_graph *g, const graph_step *st, const graph_instance *inst) {
    const graph_pass *pass = &g->passes[st->pass];
    cv_command_list *l;
    if (cv_cmdlist_begin(g->ctx, g->lists[inst->list], &l) != CV_OK)
        return; /* the list is not ended: submit reports it */
    graph_record_ctx rc = { .graph = g, .pass = st->pass, .device = inst->device };
    cv_graph_pass_context pc = { .name = pass->name,
                                 .queue = pass->queue,
                                 .x = inst->window.x,
                                 .width = inst->window.width,
                                 .full_width = g->baked.width,
                                 .history_valid = g->frame > g->history_epoch,
                                 .instance = &rc };
    cv_cmd_begin_marker(l, pass->queue, &(cv_begin_marker_args){ .label = pass->name });
    for (uint32_t i = 0; i < inst->barrier_count; i++) {
        const graph_barrier *b = &g->baked.barriers[inst->barrier_first + i];
        cv_cmd_barrier(l, pass->queue, &(cv_barrier_args){ .resource = graph_handle_of(g, b->resource, b->history) });
    }
    pass->record(&pc, l, pass->user);
    cv_cmd_end_marker(l, pass->queue, &(cv_end_marker_args){ 0 });
    cv_command_list_end(l);
}

static void *record_worker(void *arg) {
    recorder *r = arg;
    const graph_baked *b = &r->g->baked;
    for (uint32_t i; (i = atomic_fetch_add(&r->next, 1)) < b->instance_count;)
        record_instance(r->g, &b->steps[r->step_of[i]], &b->instances[i]);
    return NULL;
}

/* Records every instance, on up to MAX_RECORD_THREADS threads (the caller is one). */
static cv_result record_all(cv_graph *g) {
    const graph_baked *b = &g->baked;
    recorder r = { .g = g, .step_of = malloc((b->instance_count + 1) * sizeof(uint32_t)) };
    if (!r.step_of)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "graph: execute");
    atomic_init(&r.next, 0);
    for (uint32_t s = 0; s < b->step_count; s++)
        for (uint32_t i = 0; i < b->steps[s].instance_count; i++)
            r.step_of[b->steps[s].instance_first + i] = s;
    pthread_t threads[MAX_RECORD_THREADS];
    /* A thread per INSTANCES_PER_THREAD lists: recording a list is cheap, and a
     * thread started for one list costs more than it saves (on a busy machine
     * the join waits for the scheduler). */
    uint32_t started = 0, want = (b->instance_count + INSTANCES_PER_THREAD - 1) / INSTANCES_PER_THREAD;
    want = want < MAX_RECORD_THREADS ? want : MAX_RECORD_THREADS;
    while (started + 1 < want && pthread_create(&threads[started], NULL, record_worker, &r) == 0)
        started++;
    record_worker(&r);
    for (uint32_t t = 0; t < started; t++)
        pthread_join(threads[t], NULL);
    free(r.step_of);
    for (uint32_t s = 0; s < b->step_count; s++)
        for (uint32_t i = 0; i < b->steps[s].instance_count; i++) {
            const graph_instance *inst = &b->instances[b->steps[s].instance_first + i];
            cv_command_list *l;
            cv_result res = cv_cmdlist_get(g->ctx, g->lists[inst->list], &l);
            if (res == CV_OK && (l->recording || !l->ended_ok))
                return cv_error(l->error != CV_OK ? l->error : CV_ERROR_BAD_STATE,
                                "graph: pass '%s' on device %u: %s", g->passes[b->steps[s].pass].name, inst->device,
                                l->error != CV_OK ? cv_command_list_error(l) : "its list was not recorded");
        }
    return CV_OK;
}

cv_result graph_transfer_async(bool *async) {
    const char *text = getenv("CORVID_TRANSFER_ASYNC");
    *async = !text || !text[0] || strcmp(text, "1") == 0;
    if (*async || strcmp(text, "0") == 0)
        return CV_OK;
    return cv_error(CV_ERROR_INVALID_ARGUMENT,
                    "graph: CORVID_TRANSFER_ASYNC='%.32s' is not 0 (synchronous transfers) or 1 (the default)", text);
}

/* The pair's ring if it can take asynchronous transfers on the path in
 * force (NULL: move synchronously). A ring made for another path is
 * replaced. Slots are sized from the first copy (a quarter more, for the
 * balancer's shifts; GRAPH_RING_SLOT_MIN..MAX); a larger copy takes several. */
cv_transfer_ring *graph_pair_ring(cv_graph *g, uint32_t s, uint32_t d, uint64_t bytes) {
    cv_device *src = g->devices[s], *dst = g->devices[d];
    bool async = false; /* a bad value was refused by the bake; then synchronous */
    if (graph_transfer_async(&async) != CV_OK || !async || !cv_device_link_async(src) || !cv_device_link_async(dst))
        return NULL;
    cv_transfer_path path;
    if (cv_transfer_choose_path(src, dst, &path) != CV_OK || path == CV_TRANSFER_STAGED)
        return NULL; /* (a forced path the pair cannot take: the synchronous call reports it) */
    cv_transfer_ring *ring = g->rings[s][d];
    if (ring && cv_transfer_ring_path(ring) == path)
        return ring;
    cv_transfer_ring_destroy(ring);
    g->rings[s][d] = NULL;
    uint64_t slot = bytes + bytes / 4;
    slot = slot < GRAPH_RING_SLOT_MIN ? GRAPH_RING_SLOT_MIN : slot > GRAPH_RING_SLOT_MAX ? GRAPH_RING_SLOT_MAX : slot;
    slot = (slot + 255) / 256 * 256;
    if (cv_transfer_ring_create(src, dst, slot, GRAPH_RING_SLOTS, &ring) != CV_OK)
        return NULL; /* (e.g. out of device memory: the synchronous path still works) */
    g->rings[s][d] = ring;
    return ring;
}

uint64_t graph_copy_bytes(const cv_graph *g, const graph_step *st, const cv_mgpu_copy *cp) {
    const graph_resource *r = &g->resources[st->resource];
    return r->type == CV_HANDLE_TEXTURE
               ? (uint64_t)cp->columns.width * r->texture.height * cv_format_bytes(r->texture.format)
               : r->buffer.size;
}

void graph_make_rings(cv_graph *g) {
    const graph_baked *b = &g->baked;
    uint64_t most[CV_MAX_DEVICES][CV_MAX_DEVICES] = { { 0 } };
    for (uint32_t i = 0; i < b->step_count; i++) {
        const graph_step *st = &b->steps[i];
        for (uint32_t c = 0; st->transfer && !st->zero_copy && c < st->plan.count; c++) {
            const cv_mgpu_copy *cp = &st->plan.copies[c];
            uint64_t n = graph_copy_bytes(g, st, cp);
            if (n > most[cp->src_device][cp->dst_device])
                most[cp->src_device][cp->dst_device] = n;
        }
    }
    for (uint32_t s = 0; s < g->device_count; s++)
        for (uint32_t d = 0; d < g->device_count; d++)
            if (most[s][d] && !g->rings[s][d])
                (void)graph_pair_ring(g, s, d, most[s][d]); /* NULL: made (or refused) at the first transfer */
}

/* Moves a transfer step's copies; last[d] rises to the tickets of asynchronous copies. */
static cv_result run_transfer(cv_graph *g, const graph_step *st, double *start_ms, double *ms, uint64_t *bytes,
                              uint64_t *last) {
    const graph_resource *r = &g->resources[st->resource];
    cv_handle h = graph_handle_of(g, st->resource, false);
    double start = cv_now_ms();
    *start_ms = start;
    cv_result res = CV_OK;
    *bytes = 0;
    for (uint32_t c = 0; c < st->plan.count && res == CV_OK; c++) {
        const cv_mgpu_copy *cp = &st->plan.copies[c];
        cv_device *src = g->devices[cp->src_device], *dst = g->devices[cp->dst_device];
        cv_transfer_ring *ring = graph_pair_ring(g, cp->src_device, cp->dst_device, graph_copy_bytes(g, st, cp));
        cv_transfer_stats ts = { 0 };
        cv_transfer_async ta = { 0 };
        if (r->type == CV_HANDLE_TEXTURE) {
            cv_rect rect = { cp->columns.x, 0, cp->columns.width, r->texture.height };
            res = ring ? cv_transfer_texture_async(ring, (cv_texture){ h.id }, rect, (cv_texture){ h.id }, rect.x, 0,
                                                   &ta)
                       : cv_transfer_texture(src, (cv_texture){ h.id }, rect, dst, (cv_texture){ h.id }, rect.x, 0,
                                             &ts);
        } else {
            bool whole = cp->columns.x == 0 && cp->columns.width == g->baked.width;
            uint64_t offset = whole ? 0 : cp->columns.x * r->column_bytes;
            uint64_t size = whole ? r->buffer.size : cp->columns.width * r->column_bytes;
            res = ring ? cv_transfer_buffer_async(ring, (cv_buffer){ h.id }, offset, (cv_buffer){ h.id }, offset,
                                                  size, &ta)
                       : cv_transfer_buffer(src, (cv_buffer){ h.id }, offset, dst, (cv_buffer){ h.id }, offset, size,
                                            &ts);
        }
        *bytes += ring ? ta.bytes : ts.bytes;
        if (ring && res == CV_OK) {
            last[cp->src_device] = ta.src_ticket > last[cp->src_device] ? ta.src_ticket : last[cp->src_device];
            last[cp->dst_device] = ta.dst_ticket > last[cp->dst_device] ? ta.dst_ticket : last[cp->dst_device];
        }
        if (res != CV_OK)
            res = cv_error(res, "graph: transfer of '%s' after pass '%s' (device %u -> %u): %s", r->name,
                           g->passes[st->pass].name, cp->src_device, cp->dst_device, cv_last_error());
    }
    *ms = cv_now_ms() - start;
    return res;
}

/* The pass's GPU time (0: none measured) and its start on the host's clock (0: unknown). */
static double instance_ms(cv_graph *g, uint32_t device, const char *name, uint64_t ticket, double *host_ms) {
    cv_pass_timing t[4];
    uint32_t n = 0;
    *host_ms = 0.0;
    if (cv_device_timings(g->devices[device], ticket, t, 4, &n) != CV_OK)
        return 0.0;
    for (uint32_t i = 0; i < n && i < 4; i++)
        if (strcmp(t[i].label, name) == 0) {
            *host_ms = t[i].host_ms;
            return t[i].duration_ms;
        }
    return 0.0;
}

static void put_timing(cv_graph_timing *out, uint32_t capacity, uint32_t *count, const char *name, uint32_t device,
                       double host_ms, double ms, uint64_t bytes) {
    if (out && *count < capacity) {
        out[*count] = (cv_graph_timing){ .device = device, .host_ms = host_ms, .ms = ms, .bytes = bytes };
        /* Pass names fit (graph.c checks them); transfer names may be cut. */
        snprintf(out[*count].name, sizeof(out[*count].name), "%.*s", (int)sizeof(out[*count].name) - 1, name);
    }
    (*count)++;
}

static cv_result frame_add(graph_frame *fr, graph_entry e) {
    if (fr->count == fr->capacity) {
        uint32_t cap = fr->capacity ? fr->capacity * 2 : 32;
        graph_entry *grown = realloc(fr->entries, cap * sizeof(*grown));
        if (!grown)
            return cv_error(CV_ERROR_OUT_OF_MEMORY, "graph: frame record of %u entries", cap);
        fr->entries = grown;
        fr->capacity = cap;
    }
    fr->entries[fr->count++] = e;
    return CV_OK;
}

/* Waits for frame fr, reads its timings and feeds the balancer (fr->partition). */
static cv_result collect(cv_graph *g, graph_frame *fr, cv_graph_timing *timings, uint32_t capacity, uint32_t *count) {
    cv_result res = CV_OK;
    for (uint32_t d = 0; d < g->device_count; d++)
        if (fr->last[d]) {
            cv_result w = cv_device_wait(g->devices[d], fr->last[d], UINT64_MAX);
            res = res == CV_OK ? w : res;
        }
    double ms[CV_MAX_DEVICES] = { 0 };
    bool balanced_pass = false;
    uint32_t n = 0;
    for (uint32_t i = 0; i < fr->count && res == CV_OK; i++) {
        const graph_entry *e = &fr->entries[i];
        const graph_pass *pass = &g->passes[e->pass];
        if (e->transfer) {
            char name[CV_LABEL_MAX + 16];
            snprintf(name, sizeof(name), "transfer '%s'", g->resources[e->resource].name);
            put_timing(timings, capacity, &n, name, e->device, e->host_ms, e->ms, e->bytes);
            continue;
        }
        double host_ms = 0.0;
        double t = instance_ms(g, e->device, pass->name, e->ticket, &host_ms);
        put_timing(timings, capacity, &n, pass->name, e->device, host_ms, t, 0);
        if (pass->policy == CV_MGPU_ALL_DEVICES) {
            ms[e->device] += t > 0.0 ? t : 1e-6;
            balanced_pass = true;
        }
    }
    if (res == CV_OK && fr->balanced && balanced_pass && g->device_count > 1)
        res = cv_balancer_update(&g->balancer, &fr->partition, ms);
    if (res == CV_OK) {
        fr->collected = true;
        if (count)
            *count = n;
    }
    return res;
}

/* Records and submits the frame; with `wait`, then collects it. */
static cv_result evaluate(cv_graph *g, bool wait, cv_graph_timing *timings, uint32_t capacity, uint32_t *count,
                          uint64_t *last) {
    if (!g || !g->baked.valid)
        return cv_error(CV_ERROR_BAD_STATE, "cv_graph_%s: the graph is not baked", wait ? "execute" : "submit");
    graph_baked *b = &g->baked;
    graph_frame *fr = &g->frames[g->frame % CV_GRAPH_FRAMES_KEPT];
    g->lists = g->list_sets[g->frame % CV_GRAPH_FRAMES_KEPT];
    fr->id = 0; /* until this frame is fully submitted */
    fr->collected = false;
    fr->count = 0;
    memset(fr->last, 0, sizeof(fr->last));
    fr->partition = b->partition;
    fr->balanced = b->balanced;
    /* Record in parallel. */
    cv_result res = record_all(g);
    /* Submit in step order; a transfer waits only for its source's work. */
    for (uint32_t s = 0; s < b->step_count && res == CV_OK; s++) {
        const graph_step *st = &b->steps[s];
        if (st->transfer) {
            graph_entry e = {
                .transfer = true, .pass = st->pass, .resource = st->resource, .device = st->plan.copies[0].src_device
            };
            if (st->zero_copy) { /* shared memory: the primary waits on the GPU, no byte moves */
                e.host_ms = cv_now_ms();
                res = graph_zero_copy_handover(g, st, fr, fr->last);
                e.ms = cv_now_ms() - e.host_ms;
            } else {
                res = run_transfer(g, st, &e.host_ms, &e.ms, &e.bytes, fr->last);
            }
            if (res == CV_OK)
                res = frame_add(fr, e);
            continue;
        }
        uint64_t primary_ticket = 0;
        for (uint32_t i = 0; i < st->instance_count && res == CV_OK; i++) {
            const graph_instance *inst = &b->instances[st->instance_first + i];
            graph_entry e = { .pass = st->pass, .device = inst->device };
            res = graph_zero_copy_before(g, st, inst->device, fr->last);
            if (res == CV_OK)
                res = cv_device_submit(g->devices[inst->device], g->lists[inst->list], &e.ticket);
            if (res != CV_OK)
                res = cv_error(res, "graph: pass '%s' on device %u: %s", g->passes[st->pass].name, inst->device,
                               cv_last_error());
            if (res == CV_OK) {
                if (e.ticket > fr->last[inst->device])
                    fr->last[inst->device] = e.ticket;
                primary_ticket = inst->device == 0 ? e.ticket : primary_ticket;
                res = frame_add(fr, e);
            }
        }
        if (res == CV_OK)
            graph_zero_copy_after(g, st, primary_ticket);
    }
    if (res != CV_OK) { /* wait for whatever was submitted */
        for (uint32_t d = 0; d < g->device_count; d++)
            cv_device_wait_idle(g->devices[d]);
        return res;
    }
    g->frame++;
    fr->id = g->frame;
    if (last)
        memcpy(last, fr->last, sizeof(fr->last));
    return wait ? collect(g, fr, timings, capacity, count) : CV_OK;
}

cv_result cv_graph_execute(cv_graph *g, cv_graph_timing *timings, uint32_t capacity, uint32_t *count) {
    return evaluate(g, true, timings, capacity, count, NULL);
}

cv_result cv_graph_submit(cv_graph *g, uint64_t tickets[CV_MAX_DEVICES]) {
    if (!tickets)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_graph_submit: NULL tickets");
    return evaluate(g, false, NULL, 0, NULL, tickets);
}

uint64_t cv_graph_frame_id(const cv_graph *g) { return g ? g->frame : 0; }

cv_result cv_graph_collect(cv_graph *g, uint64_t frame, cv_graph_timing *timings, uint32_t capacity,
                           uint32_t *count) {
    if (!g || frame == 0)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_graph_collect: %s", g ? "frame 0 is no frame" : "NULL graph");
    graph_frame *fr = &g->frames[(frame - 1) % CV_GRAPH_FRAMES_KEPT];
    if (frame > g->frame || fr->id != frame)
        return cv_error(CV_ERROR_BAD_STATE,
                        "cv_graph_collect: frame %llu is %s (the graph keeps the last %u of %llu evaluated)",
                        (unsigned long long)frame, frame > g->frame ? "not evaluated yet" : "no longer kept",
                        CV_GRAPH_FRAMES_KEPT, (unsigned long long)g->frame);
    if (fr->collected)
        return cv_error(CV_ERROR_BAD_STATE, "cv_graph_collect: frame %llu was already collected",
                        (unsigned long long)frame);
    return collect(g, fr, timings, capacity, count);
}
