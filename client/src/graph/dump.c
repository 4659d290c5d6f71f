/* Render graph dumps (graph.h): the baked graph as text, stable and diffable
 * (indices and names only, no handles or pointers), and as Graphviz dot. */
#include <inttypes.h>

#include "graph_internal.h"

static void describe(FILE *f, const graph_resource *r) {
    if (r->type == CV_HANDLE_TEXTURE)
        fprintf(f, "texture %ux%u %s", r->texture.width, r->texture.height, cv_format_name(r->texture.format));
    else
        fprintf(f, "buffer %" PRIu64 " bytes", r->buffer.size);
}

static void access_list(FILE *f, const cv_graph *g, const graph_pass *pass, bool write) {
    const char *sep = write ? "      writes " : "      reads ";
    for (uint32_t a = 0; a < pass->access_count; a++) {
        const graph_access *acc = &pass->accesses[a];
        if (acc->write != write)
            continue;
        const graph_resource *r = &g->resources[(acc->id & ~GRAPH_HISTORY_BIT) - 1];
        fprintf(f, "%s'%s'%s (%s)", sep, r->name, acc->id & GRAPH_HISTORY_BIT ? " history" : "",
                cv_graph_access_name(acc->access));
        sep = ", ";
    }
    if (sep[0] == ',')
        fputc('\n', f);
}

cv_result cv_graph_dump_text(const cv_graph *g, FILE *f) {
    if (!g || !f || !g->baked.valid)
        return cv_error(CV_ERROR_BAD_STATE, "cv_graph_dump_text: the graph is not baked");
    const graph_baked *b = &g->baked;
    fprintf(f, "graph: %u devices, width %u, tile %u\n", g->device_count, b->width, b->partition.tile);
    fprintf(f, "partition:");
    for (uint32_t d = 0; d < g->device_count; d++)
        fprintf(f, " dev%u [%u,%u)", d, b->partition.ranges[d].x,
                b->partition.ranges[d].x + b->partition.ranges[d].width);
    fprintf(f, "\nresources:\n");
    for (uint32_t r = 0; r < g->resource_count; r++) {
        const graph_resource *res = &g->resources[r];
        fprintf(f, "  #%u '%s' ", r + 1, res->name);
        describe(f, res);
        if (res->imported)
            fprintf(f, ", imported");
        else if (res->history)
            fprintf(f, ", with history");
        else if (b->physical[r] >= 0)
            fprintf(f, ", physical %d, steps %u-%u", b->physical[r], b->first[r], b->last[r]);
        else
            fprintf(f, ", unused");
        fprintf(f, "%s\n", res->output ? ", output" : "");
    }
    fprintf(f, "culled:");
    for (uint32_t p = 0; p < b->stats.passes + b->stats.culled; p++)
        if (!b->kept[p])
            fprintf(f, " '%s'", g->passes[p].name);
    fprintf(f, "\nsteps:\n");
    for (uint32_t s = 0; s < b->step_count; s++) {
        const graph_step *st = &b->steps[s];
        const graph_pass *pass = &g->passes[st->pass];
        if (st->transfer) {
            fprintf(f, "  %u transfer '%s' after '%s': %s:", s, g->resources[st->resource].name, pass->name,
                    cv_mgpu_transfer_name(st->rule));
            for (uint32_t c = 0; c < st->plan.count; c++) {
                const cv_mgpu_copy *cp = &st->plan.copies[c];
                fprintf(f, " dev%u->dev%u [%u,%u)", cp->src_device, cp->dst_device, cp->columns.x,
                        cp->columns.x + cp->columns.width);
            }
            if (st->zero_copy)
                fprintf(f, " (zero-copy: shared memory, GPU-side waits)");
            fputc('\n', f);
            continue;
        }
        fprintf(f, "  %u pass '%s' %s %s\n", s, pass->name, cv_queue_type_name(pass->queue),
                cv_mgpu_policy_name(pass->policy));
        access_list(f, g, pass, false);
        access_list(f, g, pass, true);
        for (uint32_t i = 0; i < st->instance_count; i++) {
            const graph_instance *inst = &b->instances[st->instance_first + i];
            fprintf(f, "      dev%u [%u,%u)", inst->device, inst->window.x, inst->window.x + inst->window.width);
            for (uint32_t k = 0; k < inst->barrier_count; k++) {
                const graph_barrier *br = &b->barriers[inst->barrier_first + k];
                fprintf(f, "%s '%s'%s %s->%s", k ? "," : " barriers", g->resources[br->resource].name,
                        br->history ? " history" : "", br->after_write ? "write" : "read",
                        br->before_write ? "write" : "read");
            }
            fputc('\n', f);
        }
    }
    fprintf(f, "physical:\n");
    for (uint32_t i = 0; i < g->pool_count; i++) {
        const char *sep = "";
        for (uint32_t r = 0; r < g->resource_count; r++)
            if (b->physical[r] == (int32_t)i) {
                if (!*sep) {
                    fprintf(f, "  %u ", i);
                    describe(f, &g->resources[r]);
                    fputc(':', f);
                }
                fprintf(f, "%s '%s' steps %u-%u", sep, g->resources[r].name, b->first[r], b->last[r]);
                sep = ",";
            }
        if (*sep)
            fputc('\n', f);
    }
    const cv_graph_stats *st = &b->stats;
    fprintf(f,
            "stats: %u passes, %u culled, %u steps, %u transfers, %u copies, %u barriers, %u transients in %u "
            "physical\n",
            st->passes, st->culled, st->steps, st->transfers, st->copies, st->barriers, st->transients, st->physical);
    if (st->zero_copy)
        fprintf(f, "zero-copy: %u transfers\n", st->zero_copy);
    return ferror(f) ? cv_error(CV_ERROR_IO, "cv_graph_dump_text: write failed") : CV_OK;
}

/* Passes and transfers are nodes (transfers as diamonds); an edge joins the
 * step that last wrote a resource to each later step that uses it. */
cv_result cv_graph_dump_dot(const cv_graph *g, FILE *f) {
    if (!g || !f || !g->baked.valid)
        return cv_error(CV_ERROR_BAD_STATE, "cv_graph_dump_dot: the graph is not baked");
    const graph_baked *b = &g->baked;
    fprintf(f, "digraph corvid_graph {\n  rankdir=LR;\n  node [fontname=\"sans\"];\n");
    for (uint32_t s = 0; s < b->step_count; s++) {
        const graph_step *st = &b->steps[s];
        if (st->transfer)
            fprintf(f, "  s%u [shape=diamond, label=\"%s%s\\n'%s'\"];\n", s, cv_mgpu_transfer_name(st->rule),
                    st->zero_copy ? " (zero-copy)" : "", g->resources[st->resource].name);
        else
            fprintf(f, "  s%u [shape=box, label=\"%s\\n%s, %u device%s\"];\n", s, g->passes[st->pass].name,
                    cv_mgpu_policy_name(g->passes[st->pass].policy), st->instance_count,
                    st->instance_count == 1 ? "" : "s");
    }
    for (uint32_t s = 0; s < b->step_count; s++) {
        const graph_step *st = &b->steps[s];
        const graph_pass *pass = &g->passes[st->pass];
        uint32_t uses = st->transfer ? 1 : pass->access_count;
        for (uint32_t a = 0; a < uses; a++) {
            uint32_t id = st->transfer ? st->resource + 1 : pass->accesses[a].id;
            if (id & GRAPH_HISTORY_BIT)
                continue;
            /* The latest earlier step writing it (a transfer writes its resource). */
            for (uint32_t w = s; w-- > 0;) {
                const graph_step *ws = &b->steps[w];
                bool writes = ws->transfer ? ws->resource + 1 == id : false;
                for (uint32_t c = 0; !ws->transfer && c < g->passes[ws->pass].access_count; c++)
                    writes |= g->passes[ws->pass].accesses[c].write && g->passes[ws->pass].accesses[c].id == id;
                if (writes) {
                    fprintf(f, "  s%u -> s%u [label=\"%s\"];\n", w, s, g->resources[id - 1].name);
                    break;
                }
            }
        }
    }
    fprintf(f, "}\n");
    return ferror(f) ? cv_error(CV_ERROR_IO, "cv_graph_dump_dot: write failed") : CV_OK;
}
