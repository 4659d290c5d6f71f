/* The application context: handle pools, resource descriptions, command lists
 * and the set of attached devices (see context.h), known only by the ops they
 * registered (context_internal.h). */
#include "context_internal.h"

#include "corvid/handle_pool.h"

#include <pthread.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

typedef struct context_member {
    void *self;
    const cv_context_member_ops *ops;
} context_member;

struct cv_context {
    pthread_mutex_t lock;
    uint32_t tag; /* in every handle it makes (handle.h) */
    /* Slot data: a cv_resource_desc for described types, a cv_command_list for cmdlists. */
    cv_handle_pool pools[CV_HANDLE_TYPE_COUNT];
    context_member *members;
    uint32_t member_count, member_capacity;
};

/* Context tags: a set of the tags in use, not a bare counter, so two live contexts never
 * share one; the cursor moves on, so a destroyed context's tag comes back as
 * late as possible and its old handles read as foreign meanwhile. 0 is never a
 * tag, so a handle with no tag is recognisably malformed.
 * process-wide: a tag's one purpose is to tell apart the contexts that live in
 * one process (a node holds one per client session): each handle carries its
 * context's tag and every lookup compares it. */
static pthread_mutex_t tags_lock = PTHREAD_MUTEX_INITIALIZER;
static bool tag_used[CV_HANDLE_TAG_MAX + 1];
static uint32_t tag_cursor;

static cv_result tag_acquire(uint32_t *out) {
    pthread_mutex_lock(&tags_lock);
    uint32_t tag = 0;
    for (uint32_t i = 0; i < CV_HANDLE_TAG_MAX && !tag; i++) {
        uint32_t candidate = (tag_cursor + i) % CV_HANDLE_TAG_MAX + 1;
        if (!tag_used[candidate])
            tag = candidate;
    }
    if (tag) {
        tag_used[tag] = true;
        tag_cursor = tag;
    }
    pthread_mutex_unlock(&tags_lock);
    if (!tag)
        return cv_error(CV_ERROR_LIMIT_EXCEEDED,
                        "cv_context_create: %u contexts are alive, the most one process "
                        "can hold (CV_MAX_CONTEXTS)",
                        CV_MAX_CONTEXTS);
    *out = tag;
    return CV_OK;
}

static void tag_release(uint32_t tag) {
    pthread_mutex_lock(&tags_lock);
    tag_used[tag] = false;
    pthread_mutex_unlock(&tags_lock);
}

/* process-wide: the contexts alive in the process, for leak checks
 * (cv_live_contexts, CHECK_NOTHING_LIVE in the tests); atomic because contexts
 * come and go on any thread. */
static atomic_uint live_contexts;

static bool is_described(cv_handle_type t) {
    return t == CV_HANDLE_BUFFER || t == CV_HANDLE_TEXTURE || t == CV_HANDLE_SAMPLER || t == CV_HANDLE_PIPELINE ||
           t == CV_HANDLE_ACCEL;
}

static bool valid_type(cv_handle_type t) { return t > CV_HANDLE_NONE && t < CV_HANDLE_TYPE_COUNT; }

/* The context's description of slot `index` of a described type. */
static cv_resource_desc *desc_of(cv_context *ctx, cv_handle_type type, uint32_t index) {
    return cv_handle_pool_data(&ctx->pools[type], index);
}

/* The command list behind slot `index` of the cmdlist pool. */
static cv_command_list *list_of(cv_context *ctx, uint32_t index) {
    return cv_handle_pool_data(&ctx->pools[CV_HANDLE_CMDLIST], index);
}

cv_result cv_context_create(const cv_context_desc *desc, cv_context **out) {
    if (!out)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_context_create: out is NULL");
    cv_context_desc d = desc ? *desc : (cv_context_desc){ 0 };
    const struct {
        const char *field;
        uint32_t asked, fallback;
    } sizes[CV_HANDLE_TYPE_COUNT] = {
        [CV_HANDLE_BUFFER] = { "max_buffers", d.max_buffers, 65536 },
        [CV_HANDLE_TEXTURE] = { "max_textures", d.max_textures, 65536 },
        [CV_HANDLE_SAMPLER] = { "max_samplers", d.max_samplers, 4096 },
        [CV_HANDLE_PIPELINE] = { "max_pipelines", d.max_pipelines, 4096 },
        [CV_HANDLE_CMDLIST] = { "max_cmdlists", d.max_cmdlists, 4096 },
        [CV_HANDLE_ACCEL] = { "max_accels", d.max_accels, 4096 },
    };
    for (int t = CV_HANDLE_BUFFER; t < CV_HANDLE_TYPE_COUNT; t++)
        if (sizes[t].asked > CV_MAX_POOL_HANDLES)
            return cv_error(CV_ERROR_LIMIT_EXCEEDED,
                            "cv_context_create: %s = %u exceeds the limit of %u "
                            "(CV_MAX_POOL_HANDLES)",
                            sizes[t].field, sizes[t].asked, CV_MAX_POOL_HANDLES);
    cv_context *ctx = calloc(1, sizeof(*ctx));
    if (!ctx)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "cv_context_create: context");
    cv_result r = tag_acquire(&ctx->tag);
    if (r != CV_OK) {
        free(ctx);
        return r;
    }
    pthread_mutex_init(&ctx->lock, NULL);
    for (int t = CV_HANDLE_BUFFER; t < CV_HANDLE_TYPE_COUNT && r == CV_OK; t++) {
        size_t data = t == CV_HANDLE_CMDLIST ? sizeof(cv_command_list) : sizeof(cv_resource_desc);
        r = cv_handle_pool_init(&ctx->pools[t], (cv_handle_type)t, ctx->tag,
                                sizes[t].asked ? sizes[t].asked : sizes[t].fallback, data);
    }
    atomic_fetch_add(&live_contexts, 1); /* cv_context_destroy below takes it off again */
    if (r != CV_OK) {
        cv_context_destroy(ctx);
        return r;
    }
    *out = ctx;
    return CV_OK;
}

void cv_context_destroy(cv_context *ctx) {
    if (!ctx)
        return;
    /* Members detach themselves; take them one at a time without holding the lock. */
    for (;;) {
        pthread_mutex_lock(&ctx->lock);
        context_member m = ctx->member_count ? ctx->members[ctx->member_count - 1] : (context_member){ 0 };
        pthread_mutex_unlock(&ctx->lock);
        if (!m.self)
            break;
        m.ops->destroy(m.self);
    }
    for (uint32_t i = 0; i < ctx->pools[CV_HANDLE_CMDLIST].used; i++)
        cv_command_list_finish(list_of(ctx, i));
    for (int t = 0; t < CV_HANDLE_TYPE_COUNT; t++)
        if (ctx->pools[t].capacity)
            cv_handle_pool_finish(&ctx->pools[t]);
    free(ctx->members);
    pthread_mutex_destroy(&ctx->lock);
    tag_release(ctx->tag);
    free(ctx);
    atomic_fetch_sub(&live_contexts, 1);
}

/* Allocates a handle of `type` and stores its description under the lock. */
static cv_result create_described(cv_context *ctx, const cv_resource_desc *desc, uint64_t *out) {
    pthread_mutex_lock(&ctx->lock);
    uint64_t id;
    cv_result r = cv_handle_pool_alloc(&ctx->pools[desc->type], &id);
    if (r == CV_OK) {
        *desc_of(ctx, desc->type, cv_handle_index(id)) = *desc;
        *out = id;
    }
    pthread_mutex_unlock(&ctx->lock);
    return r;
}

static bool label_ok(const char *label) { return memchr(label, '\0', CV_LABEL_MAX) != NULL; }

cv_result cv_buffer_create(cv_context *ctx, const cv_buffer_desc *desc, cv_buffer *out) {
    if (!ctx || !desc || !out)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_buffer_create: NULL argument");
    if (desc->size == 0)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "buffer '%.*s': size is 0", CV_LABEL_MAX, desc->label);
    if (desc->usage & ~(uint32_t)CV_BUFFER_USAGE_ALL)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "buffer '%.*s': unknown usage bits 0x%x", CV_LABEL_MAX,
                        desc->label, desc->usage);
    if (!label_ok(desc->label))
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "buffer label is not NUL-terminated");
    cv_resource_desc d = { .type = CV_HANDLE_BUFFER, .buffer = *desc };
    if (d.buffer.usage == 0)
        d.buffer.usage = CV_BUFFER_USAGE_STORAGE;
    return create_described(ctx, &d, &out->id);
}

cv_result cv_texture_create(cv_context *ctx, const cv_texture_desc *desc, cv_texture *out) {
    if (!ctx || !desc || !out)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_texture_create: NULL argument");
    if (!label_ok(desc->label))
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "texture label is not NUL-terminated");
    if (desc->width == 0 || desc->height == 0 || desc->width > CV_MAX_TEXTURE_DIM ||
        desc->height > CV_MAX_TEXTURE_DIM)
        return cv_error(CV_ERROR_OUT_OF_RANGE, "texture '%s': size %ux%u outside 1..%u", desc->label, desc->width,
                        desc->height, CV_MAX_TEXTURE_DIM);
    if (desc->format == CV_FORMAT_UNDEFINED || (unsigned)desc->format >= CV_FORMAT_COUNT)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "texture '%s': invalid format %d", desc->label, (int)desc->format);
    if (desc->usage & ~(uint32_t)CV_TEXTURE_USAGE_ALL)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "texture '%s': unknown usage bits 0x%x", desc->label, desc->usage);
    cv_resource_desc d = { .type = CV_HANDLE_TEXTURE, .texture = *desc };
    bool depth = cv_format_is_depth(desc->format);
    if (d.texture.usage == 0)
        d.texture.usage = depth ? CV_TEXTURE_USAGE_DEPTH_TARGET | CV_TEXTURE_USAGE_SAMPLED
                                : CV_TEXTURE_USAGE_SAMPLED | CV_TEXTURE_USAGE_STORAGE;
    if (depth && (d.texture.usage & (CV_TEXTURE_USAGE_STORAGE | CV_TEXTURE_USAGE_COLOR_TARGET)))
        return cv_error(CV_ERROR_USAGE_MISMATCH, "texture '%s': a depth format cannot be a storage or color target",
                        desc->label);
    if (!depth && (d.texture.usage & CV_TEXTURE_USAGE_DEPTH_TARGET))
        return cv_error(CV_ERROR_USAGE_MISMATCH, "texture '%s': depth target usage needs a depth format (got %s)",
                        desc->label, cv_format_name(desc->format));
    return create_described(ctx, &d, &out->id);
}

cv_result cv_sampler_create(cv_context *ctx, const cv_sampler_desc *desc, cv_sampler *out) {
    if (!ctx || !desc || !out)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_sampler_create: NULL argument");
    if ((unsigned)desc->filter > CV_FILTER_NEAREST || (unsigned)desc->address > CV_ADDRESS_REPEAT ||
        !label_ok(desc->label))
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "sampler: invalid filter %d or address mode %d", (int)desc->filter,
                        (int)desc->address);
    cv_resource_desc d = { .type = CV_HANDLE_SAMPLER, .sampler = *desc };
    return create_described(ctx, &d, &out->id);
}

cv_result cv_pipeline_create(cv_context *ctx, const char *name, cv_pipeline *out) {
    if (!ctx || !name || !out)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_pipeline_create: NULL argument");
    if (strlen(name) >= CV_LABEL_MAX || !cv_pipeline_registry_find(name))
        return cv_error(CV_ERROR_UNKNOWN_PIPELINE, "no pipeline named '%.64s' in the registry", name);
    cv_resource_desc d = { .type = CV_HANDLE_PIPELINE };
    strcpy(d.pipeline.name, name);
    return create_described(ctx, &d, &out->id);
}

cv_result cv_accel_create(cv_context *ctx, const cv_accel_desc *desc, cv_accel *out) {
    if (!ctx || !desc || !out)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_accel_create: NULL argument");
    if (!label_ok(desc->label))
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "acceleration structure label is not NUL-terminated");
    if (desc->triangle_count == 0 || desc->triangle_count > CV_MAX_ACCEL_TRIANGLES || desc->node_count == 0 ||
        desc->node_count > desc->triangle_count)
        return cv_error(CV_ERROR_OUT_OF_RANGE,
                        "acceleration structure '%s': %u triangles and %u nodes (needs "
                        "1..%u triangles and 1..triangles nodes)",
                        desc->label, desc->triangle_count, desc->node_count, CV_MAX_ACCEL_TRIANGLES);
    cv_resource_desc d = { .type = CV_HANDLE_ACCEL, .accel = *desc };
    return create_described(ctx, &d, &out->id);
}

cv_result cv_cmdlist_create(cv_context *ctx, cv_cmdlist *out) {
    if (!ctx || !out)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_cmdlist_create: NULL argument");
    pthread_mutex_lock(&ctx->lock);
    uint64_t id;
    cv_result r = cv_handle_pool_alloc(&ctx->pools[CV_HANDLE_CMDLIST], &id);
    if (r == CV_OK) {
        cv_command_list *list = list_of(ctx, cv_handle_index(id));
        uint32_t version = list->version;
        cv_command_list_finish(list);
        cv_command_list_init(list);
        list->version = version; /* keeps versions unique per slot across reuse */
        list->id = id;
        out->id = id;
    }
    pthread_mutex_unlock(&ctx->lock);
    return r;
}

static cv_result check_locked(cv_context *ctx, uint64_t id) {
    cv_handle_type t = cv_handle_type_of(id);
    if (id == 0)
        return cv_error(CV_ERROR_INVALID_HANDLE, "null handle");
    if (!valid_type(t))
        return cv_error(CV_ERROR_INVALID_HANDLE, "handle 0x%016llx has no valid type tag", (unsigned long long)id);
    return cv_handle_pool_check(&ctx->pools[t], id);
}

cv_result cv_context_check(cv_context *ctx, cv_handle h) {
    if (!ctx)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_context_check: NULL context");
    pthread_mutex_lock(&ctx->lock);
    cv_result r = check_locked(ctx, h.id);
    pthread_mutex_unlock(&ctx->lock);
    return r;
}

cv_result cv_context_describe(cv_context *ctx, cv_handle h, cv_resource_desc *out) {
    if (!ctx || !out)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_context_describe: NULL argument");
    pthread_mutex_lock(&ctx->lock);
    cv_result r = check_locked(ctx, h.id);
    if (r == CV_OK && !is_described(cv_handle_type_of(h.id)))
        r = cv_error(CV_ERROR_WRONG_HANDLE_TYPE, "a %s handle has no resource description",
                     cv_handle_type_name(cv_handle_type_of(h.id)));
    if (r == CV_OK)
        *out = *desc_of(ctx, cv_handle_type_of(h.id), cv_handle_index(h.id));
    pthread_mutex_unlock(&ctx->lock);
    return r;
}

uint32_t cv_context_live_count(cv_context *ctx, cv_handle_type type) {
    if (!ctx || !valid_type(type))
        return 0;
    pthread_mutex_lock(&ctx->lock);
    uint32_t n = ctx->pools[type].live;
    pthread_mutex_unlock(&ctx->lock);
    return n;
}

cv_result cv_destroy(cv_context *ctx, cv_handle h) {
    if (!ctx)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_destroy: NULL context");
    pthread_mutex_lock(&ctx->lock);
    cv_result r = check_locked(ctx, h.id);
    if (r != CV_OK) {
        pthread_mutex_unlock(&ctx->lock);
        return r;
    }
    cv_handle_type t = cv_handle_type_of(h.id);
    cv_handle_pool_free(&ctx->pools[t], h.id);
    if (t == CV_HANDLE_CMDLIST)
        list_of(ctx, cv_handle_index(h.id))->ended_ok = false;
    uint32_t n = ctx->member_count;
    context_member *members = n ? malloc(n * sizeof(*members)) : NULL;
    if (members)
        memcpy(members, ctx->members, n * sizeof(*members));
    pthread_mutex_unlock(&ctx->lock);
    for (uint32_t i = 0; members && i < n; i++)
        members[i].ops->forget(members[i].self, h.id);
    free(members);
    return CV_OK;
}

cv_result cv_cmdlist_begin(cv_context *ctx, cv_cmdlist h, cv_command_list **out) {
    if (!ctx || !out)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_cmdlist_begin: NULL argument");
    pthread_mutex_lock(&ctx->lock);
    cv_result r = cv_handle_pool_check(&ctx->pools[CV_HANDLE_CMDLIST], h.id);
    if (r == CV_OK) {
        cv_command_list *list = list_of(ctx, cv_handle_index(h.id));
        cv_command_list_begin(list);
        *out = list;
    }
    pthread_mutex_unlock(&ctx->lock);
    return r;
}

cv_result cv_cmdlist_get(cv_context *ctx, cv_cmdlist h, cv_command_list **out) {
    if (!ctx || !out)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_cmdlist_get: NULL argument");
    pthread_mutex_lock(&ctx->lock);
    cv_result r = cv_handle_pool_check(&ctx->pools[CV_HANDLE_CMDLIST], h.id);
    if (r == CV_OK)
        *out = list_of(ctx, cv_handle_index(h.id));
    pthread_mutex_unlock(&ctx->lock);
    return r;
}

cv_result cv_context_executable_list(cv_context *ctx, uint64_t id, cv_command_list **out) {
    pthread_mutex_lock(&ctx->lock);
    cv_result r = cv_handle_pool_check(&ctx->pools[CV_HANDLE_CMDLIST], id);
    if (r == CV_OK) {
        cv_command_list *list = list_of(ctx, cv_handle_index(id));
        if (list->recording)
            r = cv_error(CV_ERROR_BAD_STATE, "command list 0x%016llx is still recording", (unsigned long long)id);
        else if (!list->ended_ok)
            r = cv_error(CV_ERROR_BAD_STATE, "command list 0x%016llx %s%s", (unsigned long long)id,
                         list->error ? "failed recording: " : "was never recorded",
                         list->error ? list->error_message : "");
        else
            *out = list;
    }
    pthread_mutex_unlock(&ctx->lock);
    return r;
}

cv_result cv_context_attach(cv_context *ctx, void *member, const cv_context_member_ops *ops) {
    pthread_mutex_lock(&ctx->lock);
    if (ctx->member_count == ctx->member_capacity) {
        uint32_t cap = ctx->member_capacity ? ctx->member_capacity * 2 : 8;
        context_member *m = realloc(ctx->members, cap * sizeof(*m));
        if (!m) {
            pthread_mutex_unlock(&ctx->lock);
            return cv_error(CV_ERROR_OUT_OF_MEMORY, "attaching device");
        }
        ctx->members = m;
        ctx->member_capacity = cap;
    }
    ctx->members[ctx->member_count++] = (context_member){ member, ops };
    pthread_mutex_unlock(&ctx->lock);
    return CV_OK;
}

void cv_context_detach(cv_context *ctx, void *member) {
    pthread_mutex_lock(&ctx->lock);
    for (uint32_t i = 0; i < ctx->member_count; i++) {
        if (ctx->members[i].self == member) {
            memmove(&ctx->members[i], &ctx->members[i + 1], (ctx->member_count - i - 1) * sizeof(*ctx->members));
            ctx->member_count--;
            break;
        }
    }
    pthread_mutex_unlock(&ctx->lock);
}

uint32_t cv_live_contexts(void) { return atomic_load(&live_contexts); }
