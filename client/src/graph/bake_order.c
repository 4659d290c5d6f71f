/* The bake's analysis of the passes (graph.h): declarations checked, the
 * write each read sees, the order the passes run in and the passes culled.
 * The structure's first steps (bake.c), redone only when the graph changes. */
#include <stdlib.h>

#include "bake.h"

const graph_resource *bake_resource_of(const cv_graph *g, uint32_t id) {
    return &g->resources[(id & ~GRAPH_HISTORY_BIT) - 1];
}

static bool pass_writes(const graph_pass *p, uint32_t id) {
    if (p->disabled)
        return false; /* baked as if it were not there */
    for (uint32_t a = 0; a < p->access_count; a++)
        if (p->accesses[a].write && p->accesses[a].id == id)
            return true;
    return false;
}

/* The last pass before p (or the first after `after`) that writes id; -1 if none. */
static int32_t writer_before(const cv_graph *g, uint32_t id, int32_t p) {
    for (int32_t q = p - 1; q >= 0; q--)
        if (pass_writes(&g->passes[q], id))
            return q;
    return -1;
}

int32_t bake_writer_after(const cv_graph *g, uint32_t id, int32_t after) {
    for (uint32_t q = (uint32_t)(after + 1); q < g->pass_count; q++)
        if (pass_writes(&g->passes[q], id))
            return (int32_t)q;
    return -1;
}

static bool same_desc(const graph_resource *a, const graph_resource *b) {
    if (a->type != b->type)
        return false;
    if (a->type == CV_HANDLE_TEXTURE)
        return a->texture.width == b->texture.width && a->texture.height == b->texture.height &&
               a->texture.format == b->texture.format;
    return a->buffer.size == b->buffer.size;
}

/* Every declaration names a resource of the graph, in a way its type allows;
 * no pass writes a resource twice without reading it between; copy passes
 * copy between like resources. */
cv_result bake_validate(const cv_graph *g) {
    for (uint32_t p = 0; p < g->pass_count; p++) {
        const graph_pass *pass = &g->passes[p];
        for (uint32_t a = 0; a < pass->access_count; a++) {
            const graph_access *acc = &pass->accesses[a];
            bool history;
            const graph_resource *r = graph_lookup(g, acc->id, &history);
            if (!r)
                return cv_error(CV_ERROR_NOT_FOUND, "graph: pass '%s': %s of unknown resource #%u", pass->name,
                                cv_graph_access_name(acc->access), acc->id & ~GRAPH_HISTORY_BIT);
            if (history && acc->write)
                return cv_error(CV_ERROR_INVALID_ARGUMENT,
                                "graph: pass '%s': writes the history of '%s', which is "
                                "read-only",
                                pass->name, r->name);
            bool texture_only = acc->access == CV_GRAPH_COLOR_TARGET || acc->access == CV_GRAPH_DEPTH_TARGET ||
                                acc->access == CV_GRAPH_SAMPLED;
            if (texture_only && r->type != CV_HANDLE_TEXTURE)
                return cv_error(CV_ERROR_WRONG_HANDLE_TYPE, "graph: pass '%s': '%s' is a buffer, not a %s",
                                pass->name, r->name, cv_graph_access_name(acc->access));
            if (!acc->write)
                continue;
            for (int32_t b = (int32_t)a - 1; b >= 0; b--) {
                const graph_access *prev = &pass->accesses[b];
                if (prev->id != acc->id)
                    continue;
                if (prev->write)
                    return cv_error(CV_ERROR_INVALID_ARGUMENT,
                                    "graph: pass '%s': writes '%s' twice (%s, then %s) "
                                    "with no read between",
                                    pass->name, r->name, cv_graph_access_name(prev->access),
                                    cv_graph_access_name(acc->access));
                break;
            }
        }
        if (pass->record == graph_record_copy) {
            bool h1, h2;
            const graph_resource *src = graph_lookup(g, pass->copy_src, &h1),
                                 *dst = graph_lookup(g, pass->copy_dst, &h2);
            if (src && dst && !same_desc(src, dst))
                return cv_error(CV_ERROR_FORMAT_MISMATCH,
                                "graph: pass '%s': copies '%s' to '%s', which differ in "
                                "size or format",
                                pass->name, src->name, dst->name);
        }
    }
    return CV_OK;
}

/* Which write each read sees, and the edges: a read needs the write it sees
 * and runs before the next write of that resource (write-after-read); a write
 * runs after, and keeps, the write before it (write-after-write). */
cv_result bake_find_dependencies(const cv_graph *g, bake_state *s) {
    uint32_t n = s->n, accesses = 0;
    s->access_base = calloc(n + 1, sizeof(uint32_t));
    for (uint32_t p = 0; p < n && s->access_base; p++)
        accesses += g->passes[p].access_count, s->access_base[p + 1] = accesses;
    s->seen = malloc((accesses + 1) * sizeof(int32_t));
    s->dep = calloc((size_t)n * n + 1, 1);
    if (!s->access_base || !s->seen || !s->dep)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "graph: bake");
    for (uint32_t p = 0; p < n; p++) {
        const graph_pass *pass = &g->passes[p];
        for (uint32_t a = 0; a < pass->access_count; a++) {
            const graph_access *acc = &pass->accesses[a];
            int32_t *seen = &s->seen[s->access_base[p] + a];
            *seen = -1;
            if (pass->disabled || (acc->id & GRAPH_HISTORY_BIT))
                continue; /* last frame's contents: no edge this frame */
            const graph_resource *r = bake_resource_of(g, acc->id);
            int32_t w = writer_before(g, acc->id, (int32_t)p);
            if (acc->write) {
                if (w >= 0)
                    s->dep[(uint32_t)w * n + p] |= BAKE_ORDER | BAKE_NEEDS;
                continue;
            }
            if (w < 0 && !r->imported) {
                if (pass_writes(pass, acc->id))
                    return cv_error(CV_ERROR_BAD_STATE,
                                    "graph: pass '%s': reads '%s', a transient no pass writes "
                                    "before it",
                                    pass->name, r->name);
                w = bake_writer_after(g, acc->id, (int32_t)p);
                if (w < 0)
                    return cv_error(CV_ERROR_BAD_STATE, "graph: pass '%s': reads '%s', a transient no pass writes",
                                    pass->name, r->name);
            }
            *seen = w;
            if (w >= 0)
                s->dep[(uint32_t)w * n + p] |= BAKE_ORDER | BAKE_NEEDS;
            int32_t next = bake_writer_after(g, acc->id, w);
            if (next >= 0 && (uint32_t)next != p)
                s->dep[p * n + (uint32_t)next] |= BAKE_ORDER;
        }
    }
    return CV_OK;
}

/* Kahn's algorithm, always taking the earliest-declared ready pass, so the
 * order is stable; what is left over lies on or behind a cycle, which the
 * message spells out. */
cv_result bake_order(const cv_graph *g, bake_state *s) {
    uint32_t n = s->n;
    uint32_t *indegree = calloc(n + 1, sizeof(uint32_t));
    bool *placed = calloc(n + 1, sizeof(bool));
    s->order = malloc((n + 1) * sizeof(uint32_t));
    if (!indegree || !placed || !s->order) {
        free(indegree);
        free(placed);
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "graph: bake");
    }
    for (uint32_t a = 0; a < n; a++)
        for (uint32_t b = 0; b < n; b++)
            indegree[b] += a != b && (s->dep[a * n + b] & BAKE_ORDER);
    uint32_t count = 0;
    for (; count < n; count++) {
        uint32_t p = 0;
        while (p < n && (placed[p] || indegree[p]))
            p++;
        if (p == n)
            break;
        placed[p] = true;
        s->order[count] = p;
        for (uint32_t b = 0; b < n; b++)
            indegree[b] -= b != p && (s->dep[p * n + b] & BAKE_ORDER);
    }
    cv_result res = CV_OK;
    if (count < n) {
        /* Walk back through unplaced predecessors until a pass repeats. */
        uint32_t *path = malloc((n + 1) * sizeof(uint32_t)), len = 0;
        uint32_t u = 0;
        while (placed[u])
            u++;
        for (bool repeat = false; path && !repeat;) {
            path[len++] = u;
            uint32_t v = 0;
            while (v < n && (placed[v] || v == u || !(s->dep[v * n + u] & BAKE_ORDER)))
                v++;
            u = v;
            for (uint32_t i = 0; i < len && !repeat; i++)
                repeat = path[i] == u;
        }
        char text[CV_ERROR_MESSAGE_MAX / 2];
        size_t at = 0;
        text[0] = 0;
        if (path) {
            uint32_t j = 0;
            while (path[j] != u)
                j++;
            at += (size_t)snprintf(text, sizeof(text), "'%s'", g->passes[u].name);
            for (uint32_t i = len; i-- > j && at < sizeof(text);)
                at += (size_t)snprintf(text + at, sizeof(text) - at, " -> '%s'", g->passes[path[i]].name);
        }
        free(path);
        res = cv_error(CV_ERROR_INVALID_ARGUMENT, "graph: cycle through passes %s", text);
    }
    free(indegree);
    free(placed);
    return res;
}

static bool resource_reaches_output(const cv_graph *g, uint32_t index) {
    const graph_resource *r = &g->resources[index];
    if (r->output)
        return true;
    if (!r->history)
        return false;
    for (uint32_t p = 0; p < g->pass_count; p++)
        for (uint32_t a = 0; a < g->passes[p].access_count && !g->passes[p].disabled; a++)
            if (g->passes[p].accesses[a].id == ((index + 1) | GRAPH_HISTORY_BIT))
                return true; /* next frame reads it */
    return false;
}

/* Keeps the passes that write an output (or a resource whose history is read)
 * and, walking back, every pass whose data a kept pass needs. */
cv_result bake_cull(const cv_graph *g, const bake_state *s, graph_baked *b) {
    uint32_t n = s->n;
    b->kept = calloc(n + 1, sizeof(bool));
    uint32_t *work = malloc((n + 1) * sizeof(uint32_t)), top = 0;
    if (!b->kept || !work) {
        free(work);
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "graph: bake");
    }
    for (uint32_t p = 0; p < n; p++)
        for (uint32_t a = 0; a < g->passes[p].access_count && !b->kept[p] && !g->passes[p].disabled; a++) {
            const graph_access *acc = &g->passes[p].accesses[a];
            if (acc->write && resource_reaches_output(g, (acc->id & ~GRAPH_HISTORY_BIT) - 1)) {
                b->kept[p] = true;
                work[top++] = p;
            }
        }
    while (top) {
        uint32_t p = work[--top];
        for (uint32_t q = 0; q < n; q++)
            if (!b->kept[q] && q != p && (s->dep[q * n + p] & BAKE_NEEDS)) {
                b->kept[q] = true;
                work[top++] = q;
            }
    }
    free(work);
    for (uint32_t p = 0; p < n; p++)
        b->stats.culled += !b->kept[p];
    b->stats.passes = n - b->stats.culled;
    return CV_OK;
}
