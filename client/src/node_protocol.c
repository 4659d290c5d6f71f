/* Conversions between Corvid's structs and node.proto messages (node_protocol.h). */
#include "corvid/node_protocol.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

void cv_node_desc_to_msg(uint64_t id, const cv_resource_desc *desc, Corvid__CreateResource *msg,
                         cv_node_desc_storage *st) {
    corvid__create_resource__init(msg);
    memset(st, 0, sizeof(*st));
    msg->id = id;
    msg->label = st->label;
    if (!desc) {
        msg->desc_case = CORVID__CREATE_RESOURCE__DESC_CMDLIST;
        msg->cmdlist = true;
        return;
    }
    switch (desc->type) {
    case CV_HANDLE_BUFFER:
        corvid__buffer_desc__init(&st->buffer);
        st->buffer.size = desc->buffer.size;
        st->buffer.usage = desc->buffer.usage;
        memcpy(st->label, desc->buffer.label, CV_LABEL_MAX - 1);
        msg->desc_case = CORVID__CREATE_RESOURCE__DESC_BUFFER;
        msg->buffer = &st->buffer;
        break;
    case CV_HANDLE_TEXTURE:
        corvid__texture_desc__init(&st->texture);
        st->texture.width = desc->texture.width;
        st->texture.height = desc->texture.height;
        st->texture.format = (uint32_t)desc->texture.format;
        st->texture.usage = desc->texture.usage;
        memcpy(st->label, desc->texture.label, CV_LABEL_MAX - 1);
        msg->desc_case = CORVID__CREATE_RESOURCE__DESC_TEXTURE;
        msg->texture = &st->texture;
        break;
    case CV_HANDLE_SAMPLER:
        corvid__sampler_desc__init(&st->sampler);
        st->sampler.filter = (uint32_t)desc->sampler.filter;
        st->sampler.address = (uint32_t)desc->sampler.address;
        memcpy(st->label, desc->sampler.label, CV_LABEL_MAX - 1);
        msg->desc_case = CORVID__CREATE_RESOURCE__DESC_SAMPLER;
        msg->sampler = &st->sampler;
        break;
    case CV_HANDLE_PIPELINE:
        corvid__pipeline_desc__init(&st->pipeline_desc);
        memcpy(st->pipeline, desc->pipeline.name, CV_LABEL_MAX - 1);
        st->pipeline_desc.name = st->pipeline;
        msg->desc_case = CORVID__CREATE_RESOURCE__DESC_PIPELINE;
        msg->pipeline = &st->pipeline_desc;
        break;
    case CV_HANDLE_ACCEL:
        corvid__accel_desc__init(&st->accel);
        st->accel.triangle_count = desc->accel.triangle_count;
        st->accel.node_count = desc->accel.node_count;
        memcpy(st->label, desc->accel.label, CV_LABEL_MAX - 1);
        msg->desc_case = CORVID__CREATE_RESOURCE__DESC_ACCEL;
        msg->accel = &st->accel;
        break;
    default: break;
    }
}

/* Copies a message string into a fixed field, refusing what does not fit. */
static cv_result copy_text(char *dst, const char *src, const char *field) {
    size_t n = src ? strlen(src) : 0;
    if (n >= CV_LABEL_MAX)
        return cv_error(CV_ERROR_MALFORMED, "%s: %zu bytes, at most %u allowed", field, n, CV_LABEL_MAX - 1);
    memcpy(dst, src ? src : "", n + 1);
    return CV_OK;
}

cv_result cv_node_desc_from_msg(const Corvid__CreateResource *msg, cv_resource_desc *out) {
    cv_resource_desc d;
    memset(&d, 0, sizeof(d));
    cv_handle_type want = CV_HANDLE_NONE;
    char label[CV_LABEL_MAX];
    cv_result r = copy_text(label, msg->label, "create.label");
    if (r != CV_OK)
        return r;
    switch (msg->desc_case) {
    case CORVID__CREATE_RESOURCE__DESC_BUFFER:
        want = CV_HANDLE_BUFFER;
        d.buffer.size = msg->buffer->size;
        d.buffer.usage = msg->buffer->usage;
        memcpy(d.buffer.label, label, sizeof(label));
        break;
    case CORVID__CREATE_RESOURCE__DESC_TEXTURE:
        want = CV_HANDLE_TEXTURE;
        if (msg->texture->format >= CV_FORMAT_COUNT)
            return cv_error(CV_ERROR_MALFORMED, "create.texture.format: %u is no format (0..%d)",
                            msg->texture->format, CV_FORMAT_COUNT - 1);
        d.texture.width = msg->texture->width;
        d.texture.height = msg->texture->height;
        d.texture.format = (cv_format)msg->texture->format;
        d.texture.usage = msg->texture->usage;
        memcpy(d.texture.label, label, sizeof(label));
        break;
    case CORVID__CREATE_RESOURCE__DESC_SAMPLER:
        want = CV_HANDLE_SAMPLER;
        if (msg->sampler->filter > CV_FILTER_NEAREST || msg->sampler->address > CV_ADDRESS_REPEAT)
            return cv_error(CV_ERROR_MALFORMED, "create.sampler: filter %u / address %u out of range",
                            msg->sampler->filter, msg->sampler->address);
        d.sampler.filter = (cv_filter)msg->sampler->filter;
        d.sampler.address = (cv_address_mode)msg->sampler->address;
        memcpy(d.sampler.label, label, sizeof(label));
        break;
    case CORVID__CREATE_RESOURCE__DESC_PIPELINE:
        want = CV_HANDLE_PIPELINE;
        r = copy_text(d.pipeline.name, msg->pipeline->name, "create.pipeline.name");
        if (r != CV_OK)
            return r;
        break;
    case CORVID__CREATE_RESOURCE__DESC_ACCEL:
        want = CV_HANDLE_ACCEL;
        d.accel.triangle_count = msg->accel->triangle_count;
        d.accel.node_count = msg->accel->node_count;
        memcpy(d.accel.label, label, sizeof(label));
        break;
    case CORVID__CREATE_RESOURCE__DESC_CMDLIST: want = CV_HANDLE_CMDLIST; break;
    default:
        return cv_error(CV_ERROR_MALFORMED,
                        "create: no description (buffer, texture, sampler, pipeline, accel or "
                        "cmdlist)");
    }
    if (cv_handle_type_of(msg->id) != want)
        return cv_error(CV_ERROR_WRONG_HANDLE_TYPE,
                        "create: handle 0x%016llx is a %s handle but the description "
                        "is of a %s",
                        (unsigned long long)msg->id, cv_handle_type_name(cv_handle_type_of(msg->id)),
                        cv_handle_type_name(want));
    d.type = want;
    *out = d;
    return CV_OK;
}

void cv_node_info_to_msg(const cv_device_info *info, const char *label, Corvid__DeviceInfo *msg,
                         cv_node_info_storage *st) {
    corvid__device_info__init(msg);
    msg->label = (char *)label;
    msg->name = (char *)info->name;
    msg->backend = (char *)info->backend;
    msg->driver = (char *)info->driver;
    msg->vendor_id = info->vendor_id;
    msg->device_id = info->device_id;
    msg->ray_tracing_pipeline = info->ray_tracing_pipeline;
    msg->trace_path = (char *)info->trace_path;
    msg->gpu_timestamps = info->gpu_timestamps;
    msg->max_storage_buffer_range = info->max_storage_buffer_range;
    memcpy(st->max_dispatch, info->max_dispatch, sizeof(st->max_dispatch));
    msg->n_max_dispatch = 3;
    msg->max_dispatch = st->max_dispatch;
    msg->separate_compute_queue = info->separate_compute_queue;
    msg->separate_copy_queue = info->separate_copy_queue;
}

static void copy_bounded(char *dst, size_t cap, const char *src) {
    size_t n = src ? strnlen(src, cap - 1) : 0;
    memcpy(dst, src ? src : "", n);
    dst[n] = '\0';
}

void cv_node_info_from_msg(const Corvid__DeviceInfo *msg, cv_device_info *out) {
    memset(out, 0, sizeof(*out));
    copy_bounded(out->name, sizeof(out->name), msg->name);
    copy_bounded(out->driver, sizeof(out->driver), msg->driver);
    copy_bounded(out->trace_path, sizeof(out->trace_path), msg->trace_path);
    snprintf(out->backend, sizeof(out->backend), "proxy");
    out->vendor_id = msg->vendor_id;
    out->device_id = msg->device_id;
    out->ray_tracing_pipeline = msg->ray_tracing_pipeline;
    out->gpu_timestamps = msg->gpu_timestamps;
    out->max_storage_buffer_range = msg->max_storage_buffer_range;
    for (size_t i = 0; i < 3 && i < msg->n_max_dispatch; i++)
        out->max_dispatch[i] = msg->max_dispatch[i];
    out->separate_compute_queue = msg->separate_compute_queue;
    out->separate_copy_queue = msg->separate_copy_queue;
}

void cv_node_encode_params_to_msg(const cv_encode_params *params, Corvid__EncodeParams *msg) {
    corvid__encode_params__init(msg);
    if (!params)
        return;
    msg->quality = params->quality;
    msg->bitrate_kbps = params->bitrate_kbps;
    msg->fps = params->fps;
    msg->keyframe = params->keyframe;
    msg->zstd_level = params->zstd_level;
}

void cv_node_encode_params_from_msg(const Corvid__EncodeParams *msg, cv_encode_params *out) {
    memset(out, 0, sizeof(*out));
    if (!msg)
        return;
    out->quality = msg->quality;
    out->bitrate_kbps = msg->bitrate_kbps;
    out->fps = msg->fps;
    out->keyframe = msg->keyframe;
    out->zstd_level = msg->zstd_level;
}

cv_result cv_node_check_sha(ProtobufCBinaryData b, const char *field) {
    if (b.len != CV_SHA256_BYTES)
        return cv_error(CV_ERROR_MALFORMED, "%s: %zu bytes, a SHA-256 has %u", field, b.len, CV_SHA256_BYTES);
    return CV_OK;
}

cv_result cv_node_check_region(const cv_resource_desc *desc, uint32_t x, uint32_t y, uint32_t width, uint32_t height,
                               uint64_t offset, uint64_t size, const char *what, uint64_t *bytes) {
    *bytes = 0;
    if (desc->type == CV_HANDLE_TEXTURE) {
        const cv_texture_desc *d = &desc->texture;
        if (width == 0 || height == 0 || x > d->width || width > d->width - x || y > d->height ||
            height > d->height - y)
            return cv_error(CV_ERROR_OUT_OF_RANGE, "%s: %ux%u at (%u,%u) of texture '%s' (%ux%u)", what, width,
                            height, x, y, d->label, d->width, d->height);
        *bytes = (uint64_t)width * height * cv_format_bytes(d->format);
    } else if (desc->type == CV_HANDLE_BUFFER) {
        const cv_buffer_desc *d = &desc->buffer;
        if (width || height)
            return cv_error(CV_ERROR_MALFORMED, "%s: a texture rect (%ux%u) for buffer '%s'", what, width, height,
                            d->label);
        if (size == 0 || offset > d->size || size > d->size - offset)
            return cv_error(CV_ERROR_OUT_OF_RANGE, "%s: %llu bytes at offset %llu of buffer '%s' (%llu bytes)", what,
                            (unsigned long long)size, (unsigned long long)offset, d->label,
                            (unsigned long long)d->size);
        *bytes = size;
    } else {
        return cv_error(CV_ERROR_WRONG_HANDLE_TYPE, "%s: needs a texture or a buffer, got a %s", what,
                        cv_handle_type_name(desc->type));
    }
    if (*bytes > CV_NODE_PEER_MAX_BYTES) {
        uint64_t n = *bytes;
        *bytes = 0;
        return cv_error(CV_ERROR_LIMIT_EXCEEDED, "%s: %llu bytes, node-to-node transfers move at most %llu", what,
                        (unsigned long long)n, (unsigned long long)CV_NODE_PEER_MAX_BYTES);
    }
    return CV_OK;
}

#define PACK_BODY(fn_size, fn_pack, m) \
    size_t n = fn_size(m); \
    uint8_t *buf = malloc(n ? n : 1); \
    if (!buf) \
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "node protocol: message of %zu bytes", n); \
    fn_pack(m, buf); \
    *out = buf; \
    *size = n; \
    return CV_OK;

cv_result cv_node_pack_client(const Corvid__ClientMessage *m, uint8_t **out, size_t *size){
    PACK_BODY(corvid__client_message__get_packed_size, corvid__client_message__pack, m)
}

cv_result cv_node_pack_node(const Corvid__NodeMessage *m, uint8_t **out, size_t *size) {
    PACK_BODY(corvid__node_message__get_packed_size, corvid__node_message__pack, m)
}
