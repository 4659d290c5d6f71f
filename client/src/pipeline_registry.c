/* The pipeline registry (shaders/registry.def), parsed once into cv_pipeline_info. */
#include "corvid/pipeline_registry.h"

#include <pthread.h>
#include <string.h>

#define COMPUTE CV_PIPELINE_COMPUTE
#define GRAPHICS CV_PIPELINE_GRAPHICS

typedef struct registry_entry {
    const char *name;
    cv_pipeline_kind kind;
    uint32_t lx, ly, lz, push;
    const char *bindings;
    cv_format color0, color1, depth;
    const char *cs, *vs, *fs;
} registry_entry;

static const registry_entry entries[] = {
#define CV_PIPELINE(name, kind, lx, ly, lz, push, bindings, c0, c1, d, cs, vs, fs) \
    { name, kind, lx, ly, lz, push, bindings, CV_FORMAT_##c0, CV_FORMAT_##c1, CV_FORMAT_##d, cs, vs, fs },
#include "registry.def"
#undef CV_PIPELINE
};
#define ENTRY_COUNT (sizeof(entries) / sizeof(entries[0]))

/* process-wide: the registry's table, derived once from the constant entries
 * above and never changed after; every context and device reads the same one. */
static cv_pipeline_info infos[ENTRY_COUNT];
static pthread_once_t once = PTHREAD_ONCE_INIT;

static cv_binding_kind binding_from_letter(char c) {
    switch (c) {
    case 'u': return CV_BINDING_UNIFORM_BUFFER;
    case 'i': return CV_BINDING_STORAGE_TEXTURE;
    case 't': return CV_BINDING_SAMPLED_TEXTURE;
    default: return CV_BINDING_STORAGE_BUFFER;
    }
}

static void build(void) {
    for (size_t i = 0; i < ENTRY_COUNT; i++) {
        const registry_entry *e = &entries[i];
        cv_pipeline_info *p = &infos[i];
        p->name = e->name;
        p->kind = e->kind;
        p->local_size[0] = e->lx;
        p->local_size[1] = e->ly;
        p->local_size[2] = e->lz;
        p->push_constant_size = e->push;
        p->binding_count = (uint32_t)strlen(e->bindings);
        for (uint32_t b = 0; b < p->binding_count && b < CV_MAX_BINDINGS; b++)
            p->bindings[b] = binding_from_letter(e->bindings[b]);
        p->color_count = (e->color0 != CV_FORMAT_UNDEFINED) + (e->color1 != CV_FORMAT_UNDEFINED);
        p->color_formats[0] = e->color0;
        p->color_formats[1] = e->color1;
        p->depth_format = e->depth;
        p->compute_shader = e->cs;
        p->vertex_shader = e->vs;
        p->fragment_shader = e->fs;
    }
}

const cv_pipeline_info *cv_pipeline_registry_find(const char *name) {
    if (!name)
        return NULL;
    pthread_once(&once, build);
    for (size_t i = 0; i < ENTRY_COUNT; i++)
        if (strcmp(infos[i].name, name) == 0)
            return &infos[i];
    return NULL;
}

uint32_t cv_pipeline_registry_count(void) { return (uint32_t)ENTRY_COUNT; }

const cv_pipeline_info *cv_pipeline_registry_at(uint32_t index) {
    pthread_once(&once, build);
    return index < ENTRY_COUNT ? &infos[index] : NULL;
}

const char *cv_binding_kind_name(cv_binding_kind k) {
    switch (k) {
    case CV_BINDING_STORAGE_BUFFER: return "storage buffer";
    case CV_BINDING_UNIFORM_BUFFER: return "uniform buffer";
    case CV_BINDING_STORAGE_TEXTURE: return "storage texture";
    case CV_BINDING_SAMPLED_TEXTURE: return "sampled texture";
    }
    return "unknown binding";
}
