/* The registry of named pipelines.
 *
 * Clients never send shader code: they create a cv_pipeline by name and the
 * device builds it from its own SPIR-V (compiled from shaders/ at build time).
 * The registry says what each pipeline expects (kind, workgroup size, push
 * constant bytes, binding layout, render target formats) so that every backend,
 * the mock included, validates commands against the same facts.
 *
 * The table itself is shaders/registry.def. */
#ifndef CORVID_PIPELINE_REGISTRY_H
#define CORVID_PIPELINE_REGISTRY_H

#include "corvid/types.h"

typedef enum cv_pipeline_kind {
    CV_PIPELINE_COMPUTE = 0,
    CV_PIPELINE_GRAPHICS = 1,
} cv_pipeline_kind;

typedef enum cv_binding_kind {
    CV_BINDING_STORAGE_BUFFER = 0,  /* 'b' */
    CV_BINDING_UNIFORM_BUFFER = 1,  /* 'u' */
    CV_BINDING_STORAGE_TEXTURE = 2, /* 'i' */
    CV_BINDING_SAMPLED_TEXTURE = 3, /* 't': texture + sampler */
} cv_binding_kind;

typedef struct cv_pipeline_info {
    const char *name;
    cv_pipeline_kind kind;
    uint32_t local_size[3];      /* compute only */
    uint32_t push_constant_size; /* bytes a command must supply, exactly */
    uint32_t binding_count;
    cv_binding_kind bindings[CV_MAX_BINDINGS];
    uint32_t color_count; /* graphics only */
    cv_format color_formats[CV_MAX_COLOR_TARGETS];
    cv_format depth_format;     /* graphics only; UNDEFINED = no depth */
    const char *compute_shader; /* file names in shaders/, extension included; NULL where unused */
    const char *vertex_shader;
    const char *fragment_shader;
} cv_pipeline_info;

/* NULL if no pipeline has that name. */
const cv_pipeline_info *cv_pipeline_registry_find(const char *name);
uint32_t cv_pipeline_registry_count(void);
const cv_pipeline_info *cv_pipeline_registry_at(uint32_t index);
const char *cv_binding_kind_name(cv_binding_kind k);

#endif
