/* See import_weld.h. An open-addressing table of vertex indices keyed by the
 * vertex's bytes (FNV-1a): one pass, linear in the vertex count. */
#include "import_weld.h"

#include <stdbool.h>
#include <stdlib.h>
#include <string.h>

typedef struct weld {
    const float *pos, *nrm, *uv;
} weld;

static uint64_t hash_bytes(uint64_t h, const void *data, size_t size) {
    const unsigned char *p = data;
    for (size_t i = 0; i < size; i++)
        h = (h ^ p[i]) * 0x100000001b3ull;
    return h;
}

static uint64_t vertex_hash(const weld *w, uint32_t v) {
    uint64_t h = hash_bytes(0xcbf29ce484222325ull, &w->pos[3 * (size_t)v], 3 * sizeof(float));
    if (w->nrm)
        h = hash_bytes(h, &w->nrm[3 * (size_t)v], 3 * sizeof(float));
    if (w->uv)
        h = hash_bytes(h, &w->uv[2 * (size_t)v], 2 * sizeof(float));
    return h;
}

static bool same_vertex(const weld *w, uint32_t a, uint32_t b) {
    return memcmp(&w->pos[3 * (size_t)a], &w->pos[3 * (size_t)b], 3 * sizeof(float)) == 0 &&
           (!w->nrm || memcmp(&w->nrm[3 * (size_t)a], &w->nrm[3 * (size_t)b], 3 * sizeof(float)) == 0) &&
           (!w->uv || memcmp(&w->uv[2 * (size_t)a], &w->uv[2 * (size_t)b], 2 * sizeof(float)) == 0);
}

/* Moves vertex `from` to slot `to` (to <= from). */
static void move_vertex(float *pos, float *nrm, float *uv, uint32_t from, uint32_t to) {
    memmove(&pos[3 * (size_t)to], &pos[3 * (size_t)from], 3 * sizeof(float));
    if (nrm)
        memmove(&nrm[3 * (size_t)to], &nrm[3 * (size_t)from], 3 * sizeof(float));
    if (uv)
        memmove(&uv[2 * (size_t)to], &uv[2 * (size_t)from], 2 * sizeof(float));
}

uint32_t import_weld(float *pos, float *nrm, float *uv, uint32_t vertex_count, uint32_t *idx, size_t index_count) {
    size_t cap = 16;
    while (cap < 2 * (size_t)vertex_count)
        cap *= 2;
    uint32_t *table = malloc(cap * sizeof *table); /* kept vertex (new index) per slot, UINT32_MAX empty */
    uint32_t *remap = malloc(((size_t)vertex_count + 1) * sizeof *remap); /* old -> new index */
    if (!table || !remap) {
        free(table);
        free(remap);
        return vertex_count;
    }
    memset(table, 0xff, cap * sizeof *table);
    weld w = { pos, nrm, uv };
    uint32_t kept = 0;
    for (uint32_t v = 0; v < vertex_count; v++) {
        size_t slot = (size_t)vertex_hash(&w, v) & (cap - 1);
        while (table[slot] != UINT32_MAX && !same_vertex(&w, table[slot], v))
            slot = (slot + 1) & (cap - 1);
        if (table[slot] == UINT32_MAX) {
            /* Kept vertices move down to their new index; the table holds new
             * indices, whose data is already in place. */
            move_vertex(pos, nrm, uv, v, kept);
            table[slot] = kept++;
        }
        remap[v] = table[slot];
    }
    for (size_t i = 0; i < index_count; i++)
        idx[i] = idx[i] < vertex_count ? remap[idx[i]] : UINT32_MAX; /* out of range stays so: refused later */
    free(table);
    free(remap);
    return kept;
}
