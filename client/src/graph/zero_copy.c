/* Zero-copy gathers (graph.h, cv_graph_zero_copy): which gathered textures
 * the devices share, how a shared pool entry is loaded (on the primary, then
 * as aliases of it: cv_device_load_alias), and the GPU-side waits that order
 * the devices' use of the shared texels in place of copies:
 *   - a gather: the primary waits for each secondary's instance of the
 *     writing pass (not for its later passes, which a copy on its queue would
 *     have followed);
 *   - a secondary's pass that touches a shared entry first waits for the
 *     primary's last use of it (the previous frame's reads, or another
 *     transient of the same entry), so it never overwrites texels the primary
 *     still reads. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "graph_internal.h"

bool graph_physical_shared(const graph_physical *p) {
    return p->type == CV_HANDLE_TEXTURE && (p->texture.usage & CV_TEXTURE_USAGE_SHARED);
}

/* Whether every secondary can alias the primary's memory; if not, why. */
static bool devices_can(const cv_graph *g, char *why, size_t cap) {
    for (uint32_t d = 1; d < g->device_count; d++) {
        char w[160];
        if (!cv_device_can_alias(g->devices[d], g->devices[0], w, sizeof(w))) {
            snprintf(why, cap, "devices '%s' and '%s' cannot share memory: %s", cv_device_label(g->devices[d]),
                     cv_device_label(g->devices[0]), w);
            return false;
        }
    }
    return true;
}

/* A texture without history (a transient, or imported and created with
 * CV_TEXTURE_USAGE_SHARED), every transfer of it a gather, no ALL_DEVICES
 * pass touching it after its last gather. */
static bool qualifies(const cv_graph *g, const graph_baked *b, uint32_t r) {
    const graph_resource *res = &g->resources[r];
    if (res->type != CV_HANDLE_TEXTURE || res->history ||
        (res->imported && !(res->texture.usage & CV_TEXTURE_USAGE_SHARED)))
        return false;
    int64_t last_gather = -1;
    for (uint32_t i = 0; i < b->step_count; i++) {
        const graph_step *st = &b->steps[i];
        if (!st->transfer || st->resource != r)
            continue;
        if (st->rule != CV_MGPU_ISOLATED_TO_ISOLATED)
            return false;
        last_gather = i;
    }
    for (uint32_t i = (uint32_t)(last_gather + 1); last_gather >= 0 && i < b->step_count; i++) {
        const graph_step *st = &b->steps[i];
        if (!st->transfer && g->passes[st->pass].policy == CV_MGPU_ALL_DEVICES &&
            graph_pass_touches(&g->passes[st->pass], r))
            return false;
    }
    return last_gather >= 0;
}

cv_result graph_choose_zero_copy(cv_graph *g, cv_graph_zero_copy mode, graph_baked *b) {
    b->shared = calloc(g->resource_count + 1, sizeof(bool));
    if (!b->shared)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "graph: bake");
    if (mode == CV_GRAPH_ZERO_COPY_OFF || g->device_count < 2)
        return CV_OK;
    bool any = false;
    for (uint32_t r = 0; r < g->resource_count && !any; r++)
        any = qualifies(g, b, r);
    if (!any)
        return CV_OK;
    char why[256];
    b->zero_copy_required = mode == CV_GRAPH_ZERO_COPY_ON;
    if (mode == CV_GRAPH_ZERO_COPY_AUTO) {
        cv_transfer_path path;
        if (cv_transfer_mode(&path) != CV_OK || path != CV_TRANSFER_AUTO || !devices_can(g, why, sizeof(why)))
            return CV_OK; /* a forced path stays in force; a bad one is reported by the transfers */
    } else if (!devices_can(g, why, sizeof(why))) {
        return cv_error(CV_ERROR_UNSUPPORTED,
                        "graph: zero-copy gathers are required (cv_graph_bake_desc.zero_copy is ON) "
                        "but %s",
                        why);
    }
    for (uint32_t r = 0; r < g->resource_count; r++)
        b->shared[r] = qualifies(g, b, r);
    for (uint32_t i = 0; i < b->step_count; i++) {
        graph_step *st = &b->steps[i];
        if (st->transfer && b->shared[st->resource]) {
            st->zero_copy = true;
            b->stats.copies -= st->plan.count;
            b->stats.zero_copy++;
        }
    }
    return CV_OK;
}

void graph_unshare(graph_baked *b, uint32_t r) {
    b->shared[r] = false;
    for (uint32_t i = 0; i < b->step_count; i++) {
        graph_step *st = &b->steps[i];
        if (st->transfer && st->resource == r && st->zero_copy) {
            st->zero_copy = false;
            b->stats.copies += st->plan.count;
            b->stats.zero_copy--;
        }
    }
}

cv_result graph_load_shared(cv_graph *g, cv_handle h, graph_device_mask mask, bool shared) {
    cv_result res = CV_OK;
    if (shared && cv_device_is_alias(g->devices[0], h)) {
        /* The primary holds an alias (it was a secondary of an earlier device
         * set): the memory must be its own to be shared again. Every device's
         * representation is made anew; a gather target's texels are rewritten
         * every frame. */
        for (uint32_t d = 0; d < g->device_count && res == CV_OK; d++)
            if (cv_device_has(g->devices[d], h))
                res = cv_device_unload(g->devices[d], h);
    }
    if (res == CV_OK && (shared || (mask & 1)))
        if (!cv_device_has(g->devices[0], h))
            res = cv_device_load(g->devices[0], h);
    for (uint32_t d = 1; d < g->device_count && res == CV_OK; d++) {
        cv_device *dev = g->devices[d];
        bool has = cv_device_has(dev, h);
        if (has && cv_device_is_alias(dev, h) != shared) { /* the other kind, from an earlier bake */
            res = cv_device_unload(dev, h);
            has = false;
        }
        if (res == CV_OK && !has && (mask >> d & 1))
            res = shared ? cv_device_load_alias(dev, h, g->devices[0]) : cv_device_load(dev, h);
    }
    return res;
}

/* Where the primary's last use of shared resource r is kept. */
static uint64_t *primary_ticket_of(cv_graph *g, uint32_t r) {
    const graph_baked *b = &g->baked;
    return b->physical[r] >= 0 ? &g->pool[b->physical[r]].primary_ticket : &g->resources[r].primary_ticket;
}

/* The ticket of pass `pass`'s instance on `device` in frame fr (0: none). */
static uint64_t instance_ticket(const graph_frame *fr, uint32_t pass, uint32_t device) {
    for (uint32_t i = fr->count; i-- > 0;)
        if (!fr->entries[i].transfer && fr->entries[i].pass == pass && fr->entries[i].device == device)
            return fr->entries[i].ticket;
    return 0;
}

cv_result graph_zero_copy_handover(cv_graph *g, const graph_step *st, const graph_frame *fr, uint64_t *last) {
    for (uint32_t c = 0; c < st->plan.count; c++) {
        const cv_mgpu_copy *cp = &st->plan.copies[c];
        uint64_t written = instance_ticket(fr, st->pass, cp->src_device), ticket = 0;
        if (!written || cp->src_device == cp->dst_device)
            continue;
        cv_result res = cv_device_gpu_wait(g->devices[cp->dst_device], g->devices[cp->src_device], written, &ticket);
        if (res != CV_OK)
            return cv_error(res, "graph: zero-copy gather of '%s' after pass '%s' (device %u -> %u): %s",
                            g->resources[st->resource].name, g->passes[st->pass].name, cp->src_device, cp->dst_device,
                            cv_last_error());
        if (ticket > last[cp->dst_device])
            last[cp->dst_device] = ticket;
    }
    return CV_OK;
}

cv_result graph_zero_copy_before(cv_graph *g, const graph_step *st, uint32_t device, uint64_t *last) {
    const graph_baked *b = &g->baked;
    if (device == 0 || !b->shared)
        return CV_OK;
    const graph_pass *pass = &g->passes[st->pass];
    uint64_t need = 0;
    uint32_t which = 0;
    for (uint32_t a = 0; a < pass->access_count; a++) {
        uint32_t id = pass->accesses[a].id, r = (id & ~GRAPH_HISTORY_BIT) - 1;
        if ((id & GRAPH_HISTORY_BIT) || !b->shared[r])
            continue;
        uint64_t t = *primary_ticket_of(g, r);
        if (t > need) {
            need = t;
            which = r;
        }
    }
    if (need <= g->primary_waited[device])
        return CV_OK;
    uint64_t ticket = 0;
    cv_result res = cv_device_gpu_wait(g->devices[device], g->devices[0], need, &ticket);
    if (res != CV_OK)
        return cv_error(res, "waiting for the primary's last use of shared '%s': %s", g->resources[which].name,
                        cv_last_error());
    g->primary_waited[device] = need;
    if (ticket > last[device])
        last[device] = ticket;
    return CV_OK;
}

void graph_zero_copy_after(cv_graph *g, const graph_step *st, uint64_t primary_ticket) {
    const graph_baked *b = &g->baked;
    if (!primary_ticket || !b->shared)
        return;
    const graph_pass *pass = &g->passes[st->pass];
    for (uint32_t a = 0; a < pass->access_count; a++) {
        uint32_t id = pass->accesses[a].id, r = (id & ~GRAPH_HISTORY_BIT) - 1;
        if (!(id & GRAPH_HISTORY_BIT) && b->shared[r])
            *primary_ticket_of(g, r) = primary_ticket;
    }
}
