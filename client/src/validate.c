/* Validation of a command list against one device's resources.
 *
 * Runs before any backend compiles a list, so the mock, Vulkan and proxy
 * devices reject exactly the same lists with the same codes: handles loaded and
 * of the right kind, copies and bindings in bounds and aligned, formats and
 * usages matching, pipelines matching the command and the registry layout.
 * Every message names the command index, the command, the field and the limit. */
#include <stdio.h>
#include <string.h>

#include "device_internal.h"

/* Storage/uniform buffer binding offsets must be multiples of this on every
 * device we run on (the strictest minStorageBufferOffsetAlignment seen). */
#define CV_BINDING_OFFSET_ALIGNMENT 256u
#define CV_MAX_UNIFORM_RANGE 65536u

typedef struct validator {
    cv_device *dev;
    const cv_command_list *list;
    uint32_t index; /* current command */
    const cv_command *cmd;
    /* current render pass targets */
    const cv_device_resource *color[CV_MAX_COLOR_TARGETS];
    const cv_device_resource *depth;
} validator;

__attribute__((format(printf, 3, 4))) static cv_result fail(const validator *v, cv_result code, const char *fmt,
                                                            ...) {
    char detail[CV_ERROR_MESSAGE_MAX];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(detail, sizeof(detail), fmt, ap);
    va_end(ap);
    return cv_error(code, "device '%s': command %u (%s): %s", v->dev->label, v->index, cv_command_name(v->cmd->type),
                    detail);
}

/* *out is always written (NULL on failure): callers chain `if (r == CV_OK) r = need(...)`
 * and the compiler cannot prove that a failure code is never CV_OK. */
static cv_result need(const validator *v, uint64_t id, cv_handle_type type, const char *field,
                      const cv_device_resource **out) {
    cv_device_resource *s = NULL;
    cv_result code = cv_device_require(v->dev, id, type, field, &s);
    *out = code == CV_OK ? s : NULL;
    if (code != CV_OK)
        return fail(v, code, "%s", cv_last_error()); /* fail() formats into its own buffer first */
    return CV_OK;
}

static bool range_ok(uint64_t offset, uint64_t size, uint64_t total) {
    return offset <= total && size <= total - offset;
}

static cv_result buffer_range(const validator *v, const cv_device_resource *b, const char *field, uint64_t offset,
                              uint64_t size) {
    if (!range_ok(offset, size, b->desc.buffer.size))
        return fail(v, CV_ERROR_OUT_OF_RANGE, "%s: %llu bytes at offset %llu exceed buffer '%s' of %llu bytes", field,
                    (unsigned long long)size, (unsigned long long)offset, b->desc.buffer.label,
                    (unsigned long long)b->desc.buffer.size);
    return CV_OK;
}

static cv_result texture_rect(const validator *v, const cv_device_resource *t, const char *field, uint32_t x,
                              uint32_t y, uint32_t w, uint32_t h) {
    const cv_texture_desc *d = &t->desc.texture;
    if (w == 0 || h == 0)
        return fail(v, CV_ERROR_OUT_OF_RANGE, "%s: empty region %ux%u", field, w, h);
    if (!range_ok(x, w, d->width) || !range_ok(y, h, d->height))
        return fail(v, CV_ERROR_OUT_OF_RANGE, "%s: region %ux%u at (%u,%u) exceeds texture '%s' of %ux%u", field, w,
                    h, x, y, d->label, d->width, d->height);
    return CV_OK;
}

/* Pipeline of a dispatch/draw: right kind, bindings and push constants as the registry says. */
static cv_result check_pipeline_use(validator *v, cv_pipeline p, cv_pipeline_kind kind, cv_span bindings,
                                    cv_span push, const cv_device_resource **out) {
    *out = NULL;
    const cv_device_resource *pr;
    cv_result r = need(v, p.id, CV_HANDLE_PIPELINE, "pipeline", &pr);
    if (r != CV_OK)
        return r;
    const cv_pipeline_info *info = pr->pipeline;
    if (info->kind != kind)
        return fail(v, CV_ERROR_INVALID_ARGUMENT, "pipeline '%s' is a %s pipeline", info->name,
                    info->kind == CV_PIPELINE_COMPUTE ? "compute" : "graphics");
    if (push.size != info->push_constant_size)
        return fail(v, CV_ERROR_INVALID_ARGUMENT, "pipeline '%s' takes %u bytes of push constants, got %u",
                    info->name, info->push_constant_size, push.size);
    if (bindings.size != info->binding_count)
        return fail(v, CV_ERROR_BINDING_MISMATCH, "pipeline '%s' has %u bindings, got %u", info->name,
                    info->binding_count, bindings.size);
    const cv_binding *b = cv_list_bindings(v->list, bindings);
    for (uint32_t i = 0; i < bindings.size; i++) {
        cv_binding_kind want = info->bindings[i];
        bool wants_buffer = want == CV_BINDING_STORAGE_BUFFER || want == CV_BINDING_UNIFORM_BUFFER;
        char field[48];
        snprintf(field, sizeof(field), "binding %u", i);
        if (cv_handle_type_of(b[i].resource.id) != (wants_buffer ? CV_HANDLE_BUFFER : CV_HANDLE_TEXTURE))
            return fail(v, CV_ERROR_BINDING_MISMATCH, "%s of pipeline '%s' is a %s, got a %s handle", field,
                        info->name, cv_binding_kind_name(want),
                        cv_handle_type_name(cv_handle_type_of(b[i].resource.id)));
        const cv_device_resource *res;
        r = need(v, b[i].resource.id, wants_buffer ? CV_HANDLE_BUFFER : CV_HANDLE_TEXTURE, field, &res);
        if (r != CV_OK)
            return r;
        if (wants_buffer) {
            uint32_t usage = want == CV_BINDING_STORAGE_BUFFER ? CV_BUFFER_USAGE_STORAGE : CV_BUFFER_USAGE_UNIFORM;
            if (!(res->desc.buffer.usage & usage))
                return fail(v, CV_ERROR_USAGE_MISMATCH, "%s: buffer '%s' lacks %s usage", field,
                            res->desc.buffer.label, cv_binding_kind_name(want));
            if (b[i].offset % CV_BINDING_OFFSET_ALIGNMENT)
                return fail(v, CV_ERROR_INVALID_ARGUMENT, "%s: offset %llu is not a multiple of %u", field,
                            (unsigned long long)b[i].offset, CV_BINDING_OFFSET_ALIGNMENT);
            if (b[i].offset >= res->desc.buffer.size)
                return fail(v, CV_ERROR_OUT_OF_RANGE, "%s: offset %llu is past the end of buffer '%s' (%llu bytes)",
                            field, (unsigned long long)b[i].offset, res->desc.buffer.label,
                            (unsigned long long)res->desc.buffer.size);
            uint64_t range = b[i].range ? b[i].range : res->desc.buffer.size - b[i].offset;
            r = buffer_range(v, res, field, b[i].offset, range);
            if (r != CV_OK)
                return r;
            if (want == CV_BINDING_UNIFORM_BUFFER && range > CV_MAX_UNIFORM_RANGE)
                return fail(v, CV_ERROR_LIMIT_EXCEEDED, "%s: uniform range %llu exceeds %u bytes", field,
                            (unsigned long long)range, CV_MAX_UNIFORM_RANGE);
            if (range > v->dev->info.max_storage_buffer_range)
                return fail(v, CV_ERROR_LIMIT_EXCEEDED, "%s: range %llu exceeds the device's %llu bytes", field,
                            (unsigned long long)range, (unsigned long long)v->dev->info.max_storage_buffer_range);
        } else {
            const cv_texture_desc *td = &res->desc.texture;
            bool storage = want == CV_BINDING_STORAGE_TEXTURE;
            uint32_t usage = storage ? CV_TEXTURE_USAGE_STORAGE : CV_TEXTURE_USAGE_SAMPLED;
            if (!(td->usage & usage))
                return fail(v, CV_ERROR_USAGE_MISMATCH, "%s: texture '%s' lacks %s usage", field, td->label,
                            storage ? "storage" : "sampled");
            if (!storage) {
                const cv_device_resource *sampler;
                r = need(v, b[i].sampler.id, CV_HANDLE_SAMPLER, "sampled texture's sampler", &sampler);
                if (r != CV_OK)
                    return r;
            }
            for (int c = 0; c < CV_MAX_COLOR_TARGETS; c++)
                if (v->color[c] && v->color[c] == res)
                    return fail(v, CV_ERROR_INVALID_ARGUMENT, "%s: texture '%s' is also a render target of this pass",
                                field, td->label);
        }
    }
    *out = pr;
    return CV_OK;
}

static cv_result check_dispatch(validator *v, const cv_dispatch_cmd *c) {
    const cv_device_resource *p;
    cv_result r = check_pipeline_use(v, c->pipeline, CV_PIPELINE_COMPUTE, c->bindings, c->push, &p);
    if (r != CV_OK)
        return r;
    uint32_t g[3] = { c->groups_x, c->groups_y, c->groups_z };
    for (int i = 0; i < 3; i++)
        if (g[i] == 0 || g[i] > v->dev->info.max_dispatch[i])
            return fail(v, CV_ERROR_OUT_OF_RANGE, "group count %c = %u outside 1..%u", "xyz"[i], g[i],
                        v -> dev -> info.max_dispatch[i]);
    return CV_OK;
}

static cv_result check_dispatch_indirect(validator *v, const cv_dispatch_indirect_cmd *c) {
    const cv_device_resource *p, *args;
    cv_result r = check_pipeline_use(v, c->pipeline, CV_PIPELINE_COMPUTE, c->bindings, c->push, &p);
    if (r == CV_OK)
        r = need(v, c->args.id, CV_HANDLE_BUFFER, "args", &args);
    if (r != CV_OK)
        return r;
    if (!(args->desc.buffer.usage & CV_BUFFER_USAGE_INDIRECT))
        return fail(v, CV_ERROR_USAGE_MISMATCH, "args: buffer '%s' lacks indirect usage", args->desc.buffer.label);
    if (c->args_offset % 4)
        return fail(v, CV_ERROR_INVALID_ARGUMENT, "args_offset %llu is not a multiple of 4",
                    (unsigned long long)c->args_offset);
    return buffer_range(v, args, "args", c->args_offset, 12);
}

static cv_result check_begin_render_pass(validator *v, const cv_begin_render_pass_cmd *c) {
    const cv_texture tex[CV_MAX_COLOR_TARGETS] = { c->color0, c->color1 };
    memset(v->color, 0, sizeof(v->color));
    v->depth = NULL;
    cv_result r = need(v, c->color0.id, CV_HANDLE_TEXTURE, "color0", &v->color[0]);
    if (r == CV_OK && c->color1.id)
        r = need(v, c->color1.id, CV_HANDLE_TEXTURE, "color1", &v->color[1]);
    if (r == CV_OK && c->depth.id)
        r = need(v, c->depth.id, CV_HANDLE_TEXTURE, "depth", &v->depth);
    if (r != CV_OK)
        return r;
    const cv_texture_desc *first = &v->color[0]->desc.texture;
    for (int i = 0; i < CV_MAX_COLOR_TARGETS; i++) {
        if (!v->color[i])
            continue;
        const cv_texture_desc *d = &v->color[i]->desc.texture;
        if (!(d->usage & CV_TEXTURE_USAGE_COLOR_TARGET))
            return fail(v, CV_ERROR_USAGE_MISMATCH, "color%d: texture '%s' lacks color target usage", i, d->label);
        if (d->width != first->width || d->height != first->height)
            return fail(v, CV_ERROR_FORMAT_MISMATCH, "color%d: %ux%u differs from color0's %ux%u", i, d->width,
                        d->height, first->width, first->height);
        if (i > 0 && tex[i].id == tex[0].id)
            return fail(v, CV_ERROR_INVALID_ARGUMENT, "color%d is the same texture as color0", i);
    }
    if (v->depth) {
        const cv_texture_desc *d = &v->depth->desc.texture;
        if (!(d->usage & CV_TEXTURE_USAGE_DEPTH_TARGET))
            return fail(v, CV_ERROR_USAGE_MISMATCH, "depth: texture '%s' lacks depth target usage", d->label);
        if (d->width != first->width || d->height != first->height)
            return fail(v, CV_ERROR_FORMAT_MISMATCH, "depth: %ux%u differs from color0's %ux%u", d->width, d->height,
                        first->width, first->height);
    }
    return CV_OK;
}

/* A graphics pipeline's target formats must equal the pass's targets. */
static cv_result check_targets(validator *v, const cv_device_resource *p) {
    const cv_pipeline_info *info = p->pipeline;
    for (int i = 0; i < CV_MAX_COLOR_TARGETS; i++) {
        cv_format have = v->color[i] ? v->color[i]->desc.texture.format : CV_FORMAT_UNDEFINED;
        if (have != info->color_formats[i])
            return fail(v, CV_ERROR_FORMAT_MISMATCH, "pipeline '%s' writes color%d as %s, the pass has %s",
                        info->name, i, cv_format_name(info->color_formats[i]), cv_format_name(have));
    }
    cv_format depth = v->depth ? v->depth->desc.texture.format : CV_FORMAT_UNDEFINED;
    if (depth != info->depth_format)
        return fail(v, CV_ERROR_FORMAT_MISMATCH, "pipeline '%s' uses depth %s, the pass has %s", info->name,
                    cv_format_name(info->depth_format), cv_format_name(depth));
    return CV_OK;
}

/* first + count must not pass 2^32: the shader's vertex or instance index would wrap to 0. */
static cv_result count_fits(const validator *v, const char *first_name, uint32_t first, const char *count_name,
                            uint32_t count) {
    if (count > UINT32_MAX - first)
        return fail(v, CV_ERROR_OUT_OF_RANGE, "%s %u + %s %u pass 2^32", first_name, first, count_name, count);
    return CV_OK;
}

static cv_result check_draw(validator *v, const cv_draw_cmd *c) {
    const cv_device_resource *p;
    cv_result r = check_pipeline_use(v, c->pipeline, CV_PIPELINE_GRAPHICS, c->bindings, c->push, &p);
    if (r == CV_OK)
        r = check_targets(v, p);
    if (r == CV_OK && (c->vertex_count == 0 || c->instance_count == 0))
        r = fail(v, CV_ERROR_INVALID_ARGUMENT, "empty draw (%u vertices, %u instances)", c->vertex_count,
                 c->instance_count);
    if (r == CV_OK)
        r = count_fits(v, "first_vertex", c->first_vertex, "vertex_count", c->vertex_count);
    if (r == CV_OK)
        r = count_fits(v, "first_instance", c->first_instance, "instance_count", c->instance_count);
    return r;
}

static cv_result check_draw_indexed(validator *v, const cv_draw_indexed_cmd *c) {
    const cv_device_resource *p, *ib;
    cv_result r = check_pipeline_use(v, c->pipeline, CV_PIPELINE_GRAPHICS, c->bindings, c->push, &p);
    if (r == CV_OK)
        r = check_targets(v, p);
    if (r == CV_OK)
        r = need(v, c->index_buffer.id, CV_HANDLE_BUFFER, "index_buffer", &ib);
    if (r != CV_OK)
        return r;
    if (!(ib->desc.buffer.usage & CV_BUFFER_USAGE_INDEX))
        return fail(v, CV_ERROR_USAGE_MISMATCH, "index_buffer: buffer '%s' lacks index usage", ib->desc.buffer.label);
    if (c->index_offset % 4)
        return fail(v, CV_ERROR_INVALID_ARGUMENT, "index_offset %llu is not a multiple of 4",
                    (unsigned long long)c->index_offset);
    if (c->index_count == 0 || c->instance_count == 0)
        return fail(v, CV_ERROR_INVALID_ARGUMENT, "empty draw (%u indices, %u instances)", c->index_count,
                    c->instance_count);
    r = count_fits(v, "first_instance", c->first_instance, "instance_count", c->instance_count);
    if (r != CV_OK)
        return r;
    /* The indices read are [index_offset + 4 * first_index, + 4 * index_count). The sum can
     * pass 2^64 (a wire list can carry any offset), so it is checked, not computed blindly. */
    uint64_t start;
    if (__builtin_add_overflow(c->index_offset, 4ull * c->first_index, &start))
        return fail(v, CV_ERROR_OUT_OF_RANGE, "index_buffer: index_offset %llu + 4 * first_index %u passes 2^64",
                    (unsigned long long)c->index_offset, c->first_index);
    return buffer_range(v, ib, "index_buffer", start, 4ull * c->index_count);
}

static cv_result check_copy_buffer(validator *v, const cv_copy_buffer_cmd *c) {
    const cv_device_resource *src, *dst;
    cv_result r = need(v, c->src.id, CV_HANDLE_BUFFER, "src", &src);
    if (r == CV_OK)
        r = need(v, c->dst.id, CV_HANDLE_BUFFER, "dst", &dst);
    if (r != CV_OK)
        return r;
    if (c->size == 0)
        return fail(v, CV_ERROR_INVALID_ARGUMENT, "copy of 0 bytes");
    r = buffer_range(v, src, "src", c->src_offset, c->size);
    if (r == CV_OK)
        r = buffer_range(v, dst, "dst", c->dst_offset, c->size);
    /* Both ranges are inside their buffers by now, so these sums cannot wrap. */
    if (r == CV_OK && c->src.id == c->dst.id && c->src_offset < c->dst_offset + c->size &&
        c->dst_offset < c->src_offset + c->size)
        r = fail(v, CV_ERROR_INVALID_ARGUMENT, "source and destination ranges overlap in buffer '%s'",
                 src->desc.buffer.label);
    return r;
}

static cv_result check_copy_texture(validator *v, const cv_copy_texture_cmd *c) {
    const cv_device_resource *src, *dst;
    cv_result r = need(v, c->src.id, CV_HANDLE_TEXTURE, "src", &src);
    if (r == CV_OK)
        r = need(v, c->dst.id, CV_HANDLE_TEXTURE, "dst", &dst);
    if (r != CV_OK)
        return r;
    if (src->desc.texture.format != dst->desc.texture.format)
        return fail(v, CV_ERROR_FORMAT_MISMATCH, "src '%s' is %s, dst '%s' is %s", src->desc.texture.label,
                    cv_format_name(src->desc.texture.format), dst->desc.texture.label,
                    cv_format_name(dst->desc.texture.format));
    r = texture_rect(v, src, "src", c->src_x, c->src_y, c->width, c->height);
    if (r == CV_OK)
        r = texture_rect(v, dst, "dst", c->dst_x, c->dst_y, c->width, c->height);
    /* Both regions are inside textures of at most CV_MAX_TEXTURE_DIM by now: no wrap. */
    if (r == CV_OK && c->src.id == c->dst.id && c->src_x < c->dst_x + c->width && c->dst_x < c->src_x + c->width &&
        c->src_y < c->dst_y + c->height && c->dst_y < c->src_y + c->height)
        r = fail(v, CV_ERROR_INVALID_ARGUMENT, "source and destination regions overlap in texture '%s'",
                 src->desc.texture.label);
    return r;
}

static cv_result check_buffer_texture_copy(validator *v, uint64_t buffer_id, uint64_t offset, uint64_t texture_id,
                                           uint32_t x, uint32_t y, uint32_t w, uint32_t h, bool to_texture) {
    const cv_device_resource *buf, *tex;
    cv_result r = need(v, buffer_id, CV_HANDLE_BUFFER, to_texture ? "src" : "dst", &buf);
    if (r == CV_OK)
        r = need(v, texture_id, CV_HANDLE_TEXTURE, to_texture ? "dst" : "src", &tex);
    if (r == CV_OK)
        r = texture_rect(v, tex, to_texture ? "dst" : "src", x, y, w, h);
    if (r != CV_OK)
        return r;
    uint32_t texel = cv_format_bytes(tex->desc.texture.format);
    uint32_t align = texel % 4 ? texel * 4 : texel;
    if (offset % align)
        return fail(v, CV_ERROR_INVALID_ARGUMENT, "buffer offset %llu is not a multiple of %u",
                    (unsigned long long)offset, align);
    /* w and h are at most CV_MAX_TEXTURE_DIM (2^14) and texel 16 bytes: the product fits easily. */
    return buffer_range(v, buf, to_texture ? "src" : "dst", offset, (uint64_t)w * h * texel);
}

static cv_result check_clear_buffer(validator *v, const cv_clear_buffer_cmd *c) {
    const cv_device_resource *b;
    cv_result r = need(v, c->buffer.id, CV_HANDLE_BUFFER, "buffer", &b);
    if (r != CV_OK)
        return r;
    if (c->size == 0 || c->size % 4 || c->offset % 4)
        return fail(v, CV_ERROR_INVALID_ARGUMENT, "offset %llu and size %llu must be non-zero multiples of 4",
                    (unsigned long long)c->offset, (unsigned long long)c->size);
    return buffer_range(v, b, "buffer", c->offset, c->size);
}

static cv_result check_clear_texture(validator *v, const cv_clear_texture_cmd *c) {
    const cv_device_resource *t;
    cv_result r = need(v, c->texture.id, CV_HANDLE_TEXTURE, "texture", &t);
    if (r == CV_OK && cv_format_is_depth(t->desc.texture.format))
        r = fail(v, CV_ERROR_FORMAT_MISMATCH, "texture '%s' has a depth format; clear it in a render pass",
                 t->desc.texture.label);
    return r;
}

static cv_result check_update_buffer(validator *v, const cv_update_buffer_cmd *c) {
    const cv_device_resource *b;
    cv_result r = need(v, c->buffer.id, CV_HANDLE_BUFFER, "buffer", &b);
    if (r != CV_OK)
        return r;
    if (c->data.size == 0 || c->data.size % 4 || c->offset % 4)
        return fail(v, CV_ERROR_INVALID_ARGUMENT, "offset %llu and size %u must be non-zero multiples of 4",
                    (unsigned long long)c->offset, c->data.size);
    return buffer_range(v, b, "buffer", c->offset, c->data.size);
}

static cv_result check_barrier(validator *v, const cv_barrier_cmd *c) {
    if (!c->resource.id)
        return CV_OK;
    cv_handle_type t = cv_handle_type_of(c->resource.id);
    if (t != CV_HANDLE_BUFFER && t != CV_HANDLE_TEXTURE)
        return fail(v, CV_ERROR_WRONG_HANDLE_TYPE, "resource: a barrier needs a buffer or texture, got a %s handle",
                    cv_handle_type_name(t));
    const cv_device_resource *res;
    return need(v, c->resource.id, t, "resource", &res);
}

static cv_result check_trace_rays(validator *v, const cv_trace_rays_cmd *c) {
    const cv_device_resource *accel, *rays, *hits;
    cv_result r = need(v, c->accel.id, CV_HANDLE_ACCEL, "accel", &accel);
    if (r == CV_OK)
        r = need(v, c->rays.id, CV_HANDLE_BUFFER, "rays", &rays);
    if (r == CV_OK)
        r = need(v, c->hits.id, CV_HANDLE_BUFFER, "hits", &hits);
    if (r != CV_OK)
        return r;
    if (!accel->ready)
        return fail(v, CV_ERROR_BAD_STATE, "accel '%s' has no data yet (cv_device_write_accel)",
                    accel->desc.accel.label);
    if (c->count == 0 || c->count > CV_MAX_TRACE_RAYS)
        return fail(v, CV_ERROR_OUT_OF_RANGE, "count %u outside 1..%u", c->count, CV_MAX_TRACE_RAYS);
    if (c->rays_offset % CV_BINDING_OFFSET_ALIGNMENT || c->hits_offset % CV_BINDING_OFFSET_ALIGNMENT)
        return fail(v, CV_ERROR_INVALID_ARGUMENT, "rays_offset %llu and hits_offset %llu must be multiples of %u",
                    (unsigned long long)c->rays_offset, (unsigned long long)c->hits_offset,
                    CV_BINDING_OFFSET_ALIGNMENT);
    if (!(rays->desc.buffer.usage & CV_BUFFER_USAGE_STORAGE) || !(hits->desc.buffer.usage & CV_BUFFER_USAGE_STORAGE))
        return fail(v, CV_ERROR_USAGE_MISMATCH, "rays and hits buffers need storage usage");
    if (c->rays.id == c->hits.id)
        return fail(v, CV_ERROR_INVALID_ARGUMENT, "rays and hits are the same buffer '%s'", rays->desc.buffer.label);
    r = buffer_range(v, rays, "rays", c->rays_offset, (uint64_t)c->count * CV_RAY_BYTES);
    if (r == CV_OK)
        r = buffer_range(v, hits, "hits", c->hits_offset, (uint64_t)c->count * CV_HIT_BYTES);
    return r;
}

static cv_result check_command(validator *v) {
    const cv_command *c = v->cmd;
    switch (c->type) {
    case CV_CMD_DISPATCH: return check_dispatch(v, &c->u.dispatch);
    case CV_CMD_DISPATCH_INDIRECT: return check_dispatch_indirect(v, &c->u.dispatch_indirect);
    case CV_CMD_BEGIN_RENDER_PASS: return check_begin_render_pass(v, &c->u.begin_render_pass);
    case CV_CMD_END_RENDER_PASS:
        memset(v->color, 0, sizeof(v->color));
        v->depth = NULL;
        return CV_OK;
    case CV_CMD_DRAW: return check_draw(v, &c->u.draw);
    case CV_CMD_DRAW_INDEXED: return check_draw_indexed(v, &c->u.draw_indexed);
    case CV_CMD_COPY_BUFFER: return check_copy_buffer(v, &c->u.copy_buffer);
    case CV_CMD_COPY_TEXTURE: return check_copy_texture(v, &c->u.copy_texture);
    case CV_CMD_COPY_BUFFER_TO_TEXTURE: {
        const cv_copy_buffer_to_texture_cmd *x = &c->u.copy_buffer_to_texture;
        return check_buffer_texture_copy(v, x->src.id, x->src_offset, x->dst.id, x->dst_x, x->dst_y, x->width,
                                         x->height, true);
    }
    case CV_CMD_COPY_TEXTURE_TO_BUFFER: {
        const cv_copy_texture_to_buffer_cmd *x = &c->u.copy_texture_to_buffer;
        return check_buffer_texture_copy(v, x->dst.id, x->dst_offset, x->src.id, x->src_x, x->src_y, x->width,
                                         x->height, false);
    }
    case CV_CMD_CLEAR_BUFFER: return check_clear_buffer(v, &c->u.clear_buffer);
    case CV_CMD_CLEAR_TEXTURE: return check_clear_texture(v, &c->u.clear_texture);
    case CV_CMD_UPDATE_BUFFER: return check_update_buffer(v, &c->u.update_buffer);
    case CV_CMD_BARRIER: return check_barrier(v, &c->u.barrier);
    case CV_CMD_TIMESTAMP:
    case CV_CMD_BEGIN_MARKER:
    case CV_CMD_END_MARKER: return CV_OK;
    case CV_CMD_TRACE_RAYS: return check_trace_rays(v, &c->u.trace_rays);
    default: return fail(v, CV_ERROR_MALFORMED, "unknown command type %d", (int)c->type);
    }
}

cv_result cv_validate_list(cv_device *dev, const cv_command_list *list) {
    validator v = { .dev = dev, .list = list };
    for (v.index = 0; v.index < list->count; v.index++) {
        v.cmd = &list->commands[v.index];
        cv_result r = check_command(&v);
        if (r != CV_OK)
            return r;
    }
    return CV_OK;
}

bool cv_indirect_counts_fit(const uint32_t counts[3], const uint32_t max[3]) {
    return counts[0] <= max[0] && counts[1] <= max[1] && counts[2] <= max[2];
}

cv_result cv_indirect_refusal(const char *device, uint64_t ticket, uint32_t command, const uint32_t counts[3],
                              const uint32_t max[3]) {
    return cv_error(CV_ERROR_OUT_OF_RANGE,
                    "device '%s': ticket %llu: command %u (dispatch_indirect): group counts (%u, %u, %u) in the "
                    "argument buffer exceed the device's limits (%u, %u, %u): the dispatch was skipped",
                    device, (unsigned long long)ticket, command, counts[0], counts[1], counts[2], max[0], max[1],
                    max[2]);
}
