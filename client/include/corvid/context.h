/* The application context: owner of every handle.
 *
 * The application creates resources here and gets typed handles back; the
 * context keeps each resource's description. Devices attached to the context
 * (device.h) each load their own representation of a handle on demand. Destroying
 * a handle unloads it from every attached device (objects still in use by
 * submitted work are released when that work has finished) and frees the slot,
 * bumping its generation so the old handle reads as stale everywhere.
 *
 * Thread-safe: all calls may be made from any thread. */
#ifndef CORVID_CONTEXT_H
#define CORVID_CONTEXT_H

#include "corvid/command_list.h"
#include "corvid/handle.h"
#include "corvid/pipeline_registry.h"
#include "corvid/result.h"
#include "corvid/types.h"

typedef struct cv_context cv_context;

/* Contexts alive at once in one process: each has its own context tag, which
 * every handle carries (handle.h), and the tag has 12 bits (0 is no tag). */
#define CV_MAX_CONTEXTS 4095u

/* The most handles of one type a context may hold: the 24 index bits of a
 * handle (handle.h). A pool takes memory only as its handles are created, so a
 * context may ask for the maximum at no cost up front. */
#define CV_MAX_POOL_HANDLES (1u << 24)

typedef struct cv_context_desc {
    /* The most handles of each type; 0 = default (buffers and textures 65536, others 4096).
     * Above CV_MAX_POOL_HANDLES, cv_context_create fails with CV_ERROR_LIMIT_EXCEEDED. */
    uint32_t max_buffers, max_textures, max_samplers, max_pipelines, max_cmdlists, max_accels;
} cv_context_desc;

/* A resource description of any type. */
typedef struct cv_resource_desc {
    cv_handle_type type;
    union {
        cv_buffer_desc buffer;
        cv_texture_desc texture;
        cv_sampler_desc sampler;
        cv_pipeline_desc pipeline;
        cv_accel_desc accel;
    };
} cv_resource_desc;

/* CV_ERROR_LIMIT_EXCEEDED when CV_MAX_CONTEXTS contexts are alive. */
cv_result cv_context_create(const cv_context_desc *desc, cv_context **out);
/* Destroys every device still attached, then every resource. */
void cv_context_destroy(cv_context *ctx);

cv_result cv_buffer_create(cv_context *ctx, const cv_buffer_desc *desc, cv_buffer *out);
cv_result cv_texture_create(cv_context *ctx, const cv_texture_desc *desc, cv_texture *out);
cv_result cv_sampler_create(cv_context *ctx, const cv_sampler_desc *desc, cv_sampler *out);
/* Fails with CV_ERROR_UNKNOWN_PIPELINE if the registry has no such name. */
cv_result cv_pipeline_create(cv_context *ctx, const char *name, cv_pipeline *out);
cv_result cv_cmdlist_create(cv_context *ctx, cv_cmdlist *out);
cv_result cv_accel_create(cv_context *ctx, const cv_accel_desc *desc, cv_accel *out);

/* Destroys any handle type. Stale, double and null destroys fail and change nothing. */
cv_result cv_destroy(cv_context *ctx, cv_handle h);
#define cv_buffer_destroy(ctx, h) cv_destroy((ctx), cv_any((cv_buffer)(h)))
#define cv_texture_destroy(ctx, h) cv_destroy((ctx), cv_any((cv_texture)(h)))
#define cv_sampler_destroy(ctx, h) cv_destroy((ctx), cv_any((cv_sampler)(h)))
#define cv_pipeline_destroy(ctx, h) cv_destroy((ctx), cv_any((cv_pipeline)(h)))
#define cv_cmdlist_destroy(ctx, h) cv_destroy((ctx), cv_any((cv_cmdlist)(h)))
#define cv_accel_destroy(ctx, h) cv_destroy((ctx), cv_any((cv_accel)(h)))

/* CV_OK if h is live; otherwise why not (invalid, another context's, stale, ...). */
cv_result cv_context_check(cv_context *ctx, cv_handle h);
/* Copies the description of a live buffer/texture/sampler/pipeline/accel handle. */
cv_result cv_context_describe(cv_context *ctx, cv_handle h, cv_resource_desc *out);
/* Number of live handles of a type (for leak checks). */
uint32_t cv_context_live_count(cv_context *ctx, cv_handle_type type);

/* Contexts and devices alive in this process, for leak checks: a test that
 * ends with both at zero destroyed everything it created (a context's handles
 * and loaded representations go with it). */
uint32_t cv_live_contexts(void);
uint32_t cv_live_devices(void);

/* Starts (re)recording a command list. The returned recorder belongs to the
 * calling thread until cv_command_list_end(); record with the cv_cmd_* calls. */
cv_result cv_cmdlist_begin(cv_context *ctx, cv_cmdlist h, cv_command_list **out);
/* The recorded list behind a handle (for backends and encoders). */
cv_result cv_cmdlist_get(cv_context *ctx, cv_cmdlist h, cv_command_list **out);

#endif
