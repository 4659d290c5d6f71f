/* Render graph evaluation (graph.h): every pass instance is recorded on a
 * worker thread into its own list, then the steps run in order: lists are
 * submitted to their devices (which run submissions in order) and each
 * transfer moves its columns once its source's work is done. */
#include <pthread.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "corvid/transfer.h"
#include "graph_internal.h"

#define MAX_RECORD_THREADS 8u
#define INSTANCES_PER_THREAD 4u

static double now_ms(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec * 1e3 + ts.tv_nsec / 1e6;
}

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

static cv_result run_transfer(cv_graph *g, const graph_step *st, double *ms, uint64_t *bytes) {
    const graph_resource *r = &g->resources[st->resource];
    cv_handle h = graph_handle_of(g, st->resource, false);
    double start = now_ms();
    cv_result res = CV_OK;
    *bytes = 0;
    for (uint32_t c = 0; c < st->plan.count && res == CV_OK; c++) {
        const cv_mgpu_copy *cp = &st->plan.copies[c];
        cv_device *src = g->devices[cp->src_device], *dst = g->devices[cp->dst_device];
        cv_transfer_stats ts = { 0 };
        if (r->type == CV_HANDLE_TEXTURE) {
            cv_rect rect = { cp->columns.x, 0, cp->columns.width, r->texture.height };
            res = cv_transfer_texture(src, (cv_texture){ h.id }, rect, dst, (cv_texture){ h.id }, rect.x, 0, &ts);
        } else {
            bool whole = cp->columns.x == 0 && cp->columns.width == g->baked.width;
            uint64_t offset = whole ? 0 : cp->columns.x * r->column_bytes;
            uint64_t size = whole ? r->buffer.size : cp->columns.width * r->column_bytes;
            res = cv_transfer_buffer(src, (cv_buffer){ h.id }, offset, dst, (cv_buffer){ h.id }, offset, size, &ts);
        }
        *bytes += ts.bytes;
        if (res != CV_OK)
            res = cv_error(res, "graph: transfer of '%s' after pass '%s' (device %u -> %u): %s", r->name,
                           g->passes[st->pass].name, cp->src_device, cp->dst_device, cv_last_error());
    }
    *ms = now_ms() - start;
    return res;
}

static double instance_ms(cv_graph *g, const graph_instance *inst, const char *name, uint64_t ticket) {
    cv_pass_timing t[4];
    uint32_t n = 0;
    if (cv_device_timings(g->devices[inst->device], ticket, t, 4, &n) != CV_OK)
        return 0.0;
    for (uint32_t i = 0; i < n && i < 4; i++)
        if (strcmp(t[i].label, name) == 0)
            return t[i].duration_ms;
    return 0.0;
}

static void put_timing(cv_graph_timing *out, uint32_t capacity, uint32_t *count, const char *name, uint32_t device,
                       double ms, uint64_t bytes) {
    if (out && *count < capacity) {
        out[*count] = (cv_graph_timing){ .device = device, .ms = ms, .bytes = bytes };
        /* Pass names fit (graph.c checks them); transfer names may be cut. */
        snprintf(out[*count].name, sizeof(out[*count].name), "%.*s", (int)sizeof(out[*count].name) - 1, name);
    }
    (*count)++;
}

/* Both evaluations: with `wait`, waits, reads timings and feeds the balancer;
 * without, returns each device's last ticket in last[] once all is submitted. */
static cv_result evaluate(cv_graph *g, bool wait, cv_graph_timing *timings, uint32_t capacity, uint32_t *count,
                          uint64_t *last) {
    if (!g || !g->baked.valid)
        return cv_error(CV_ERROR_BAD_STATE, "cv_graph_%s: the graph is not baked", wait ? "execute" : "submit");
    graph_baked *b = &g->baked;
    uint64_t *tickets = calloc(b->instance_count + 1, sizeof(uint64_t));
    double *transfer_ms = calloc(b->step_count + 1, sizeof(double));
    uint64_t *transfer_bytes = calloc(b->step_count + 1, sizeof(uint64_t));
    if (!tickets || !transfer_ms || !transfer_bytes) {
        free(tickets);
        free(transfer_ms);
        free(transfer_bytes);
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "graph: execute");
    }
    /* Record in parallel. */
    cv_result res = record_all(g);
    /* Submit in step order; a transfer waits only for its source's work. */
    for (uint32_t s = 0; s < b->step_count && res == CV_OK; s++) {
        const graph_step *st = &b->steps[s];
        if (st->transfer) {
            res = run_transfer(g, st, &transfer_ms[s], &transfer_bytes[s]);
            continue;
        }
        for (uint32_t i = 0; i < st->instance_count && res == CV_OK; i++) {
            const graph_instance *inst = &b->instances[st->instance_first + i];
            res = cv_device_submit(g->devices[inst->device], g->lists[inst->list], &tickets[st->instance_first + i]);
            if (res != CV_OK)
                res = cv_error(res, "graph: pass '%s' on device %u: %s", g->passes[st->pass].name, inst->device,
                               cv_last_error());
        }
    }
    if (!wait) { /* cv_graph_submit: the last tickets; after a failure, wait as below */
        for (uint32_t d = 0; d < CV_MAX_DEVICES; d++)
            last[d] = 0;
        for (uint32_t i = 0; i < b->instance_count && res == CV_OK; i++)
            if (tickets[i] > last[b->instances[i].device])
                last[b->instances[i].device] = tickets[i];
    }
    /* Wait for everything submitted, even after a failure. */
    for (uint32_t i = 0; i < b->instance_count && (wait || res != CV_OK); i++)
        if (tickets[i]) {
            cv_result w = cv_device_wait(g->devices[b->instances[i].device], tickets[i], UINT64_MAX);
            res = res == CV_OK ? w : res;
        }
    /* Timings, and the balancer's feedback from the ALL_DEVICES passes. */
    double ms[CV_MAX_DEVICES] = { 0 };
    bool balanced_pass = false;
    uint32_t n = 0;
    for (uint32_t s = 0; s < b->step_count && res == CV_OK && wait; s++) {
        const graph_step *st = &b->steps[s];
        const graph_pass *pass = &g->passes[st->pass];
        if (st->transfer) {
            char name[CV_LABEL_MAX + 16];
            snprintf(name, sizeof(name), "transfer '%s'", g->resources[st->resource].name);
            put_timing(timings, capacity, &n, name, st->plan.copies[0].src_device, transfer_ms[s], transfer_bytes[s]);
            continue;
        }
        for (uint32_t i = 0; i < st->instance_count; i++) {
            const graph_instance *inst = &b->instances[st->instance_first + i];
            double t = instance_ms(g, inst, pass->name, tickets[st->instance_first + i]);
            put_timing(timings, capacity, &n, pass->name, inst->device, t, 0);
            if (pass->policy == CV_MGPU_ALL_DEVICES) {
                ms[inst->device] += t > 0.0 ? t : 1e-6;
                balanced_pass = true;
            }
        }
    }
    if (res == CV_OK && b->balanced && balanced_pass && g->device_count > 1)
        res = cv_balancer_update(&g->balancer, &b->partition, ms);
    if (res == CV_OK) {
        g->frame++;
        if (count)
            *count = n;
    }
    free(tickets);
    free(transfer_ms);
    free(transfer_bytes);
    return res;
}

cv_result cv_graph_execute(cv_graph *g, cv_graph_timing *timings, uint32_t capacity, uint32_t *count) {
    return evaluate(g, true, timings, capacity, count, NULL);
}

cv_result cv_graph_submit(cv_graph *g, uint64_t tickets[CV_MAX_DEVICES]) {
    if (!tickets)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_graph_submit: NULL tickets");
    return evaluate(g, false, NULL, 0, NULL, tickets);
}
