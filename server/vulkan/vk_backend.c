/* The Vulkan backend table: the core's backend interface (backend.h) mapped
 * onto the modules of this folder, plus the device queries of vulkan.h. */
#include <string.h>

#include "vk_compile.h"
#include "vk_device.h"
#include "vk_host_transfer.h"
#include "vk_link.h"
#include "vk_pipelines.h"
#include "vk_indirect.h"
#include "vk_submit.h"
#include "vk_trace.h"

/* Every entry runs inside vk_layer_enter/leave (vk_instance.h: the validation
 * layer's map, which a device created or destroyed on another thread may be
 * changing); wait and completed do it in vk_host_wait and vk_host_counter,
 * device_create and device_destroy in vk_device.c. */
#define IN_LAYER(bd, call) \
    do { \
        vk_layer_enter((bd)->instance); \
        call; \
        vk_layer_leave((bd)->instance); \
    } while (0)

static cv_result create_object(cv_backend_device *bd, const cv_resource_desc *desc, const cv_pipeline_info *pipeline,
                               void **out) {
    switch (desc->type) {
    case CV_HANDLE_BUFFER: return vk_buffer_create(bd, &desc->buffer, (vk_buffer **)out);
    case CV_HANDLE_TEXTURE: return vk_texture_create(bd, &desc->texture, (vk_texture **)out);
    case CV_HANDLE_SAMPLER: return vk_sampler_create(bd, &desc->sampler, (vk_sampler **)out);
    case CV_HANDLE_PIPELINE: return vk_pipeline_create(bd, pipeline, (vk_pipeline **)out);
    case CV_HANDLE_ACCEL: return vk_accel_create(bd, &desc->accel, (vk_accel **)out);
    default:
        return cv_error(CV_ERROR_WRONG_HANDLE_TYPE, "vulkan: cannot create a device object for a %s handle",
                        cv_handle_type_name(desc->type));
    }
}

static cv_result resource_create(cv_backend_device *bd, uint64_t id, const cv_resource_desc *desc,
                                 const cv_pipeline_info *pipeline, void **out) {
    (void)id;
    cv_result r;
    IN_LAYER(bd, r = create_object(bd, desc, pipeline, out));
    return r;
}

static void destroy_object(cv_backend_device *bd, cv_handle_type type, void *obj) {
    switch (type) {
    case CV_HANDLE_BUFFER: vk_buffer_destroy(bd, obj); break;
    case CV_HANDLE_TEXTURE: vk_texture_destroy(bd, obj); break;
    case CV_HANDLE_SAMPLER: vk_sampler_destroy(bd, obj); break;
    case CV_HANDLE_PIPELINE: vk_pipeline_destroy(bd, obj); break;
    case CV_HANDLE_ACCEL: vk_accel_destroy(bd, obj); break;
    default: break;
    }
}

static void resource_destroy(cv_backend_device *bd, cv_handle_type type, void *obj) {
    IN_LAYER(bd, destroy_object(bd, type, obj));
}

static cv_result buffer_write(cv_backend_device *bd, void *buf, uint64_t offset, uint64_t size, const void *data) {
    cv_result r;
    IN_LAYER(bd, r = vk_host_buffer_write(bd, buf, offset, size, data));
    return r;
}

static cv_result buffer_read(cv_backend_device *bd, void *buf, uint64_t offset, uint64_t size, void *out) {
    cv_result r;
    IN_LAYER(bd, r = vk_host_buffer_read(bd, buf, offset, size, out));
    return r;
}

static cv_result texture_write(cv_backend_device *bd, void *tex, const cv_texture_desc *desc, cv_rect rect,
                               const void *data) {
    (void)desc;
    cv_result r;
    IN_LAYER(bd, r = vk_host_texture_write(bd, tex, rect, data));
    return r;
}

static cv_result texture_read(cv_backend_device *bd, void *tex, const cv_texture_desc *desc, cv_rect rect,
                              void *out) {
    (void)desc;
    cv_result r;
    IN_LAYER(bd, r = vk_host_texture_read(bd, tex, rect, out));
    return r;
}

static cv_result accel_write(cv_backend_device *bd, void *accel, const cv_accel_desc *desc, const void *nodes,
                             const void *triangles) {
    (void)desc;
    cv_result r;
    IN_LAYER(bd, r = vk_accel_write(bd, accel, nodes, triangles));
    return r;
}

static cv_result list_compile(cv_backend_device *bd, cv_device *dev, const cv_command_list *list, void **out) {
    cv_result r;
    IN_LAYER(bd, r = vk_compile_list(bd, dev, list, (vk_compiled **)out));
    return r;
}

static void list_release(cv_backend_device *bd, void *compiled) { IN_LAYER(bd, vk_compiled_release(bd, compiled)); }

static cv_result submit(cv_backend_device *bd, void *compiled, uint64_t ticket) {
    cv_result r;
    IN_LAYER(bd, r = vk_submit(bd, compiled, ticket));
    return r;
}

static cv_result timings(cv_backend_device *bd, void *compiled, cv_pass_timing *out, uint32_t capacity,
                         uint32_t *count) {
    cv_result r;
    IN_LAYER(bd, r = vk_timestamps_read(bd, &((vk_compiled *)compiled)->timestamps, out, capacity, count));
    return r;
}

static cv_result resource_alias(cv_backend_device *bd, uint64_t id, const cv_resource_desc *desc,
                                cv_backend_device *src_bd, void *src_obj, void **out) {
    (void)id;
    cv_result r;
    IN_LAYER(bd, r = vk_texture_alias(bd, &desc->texture, src_bd, src_obj, (vk_texture **)out));
    return r;
}

/* vk_indirect_report runs outside the device lock, after a wait (vk_indirect.h). */
static cv_result refused(cv_backend_device *bd, uint64_t ticket) {
    cv_result r;
    IN_LAYER(bd, r = vk_indirect_report(bd, ticket));
    return r;
}

static void link_caps(cv_backend_device *bd, cv_link_caps *out) { IN_LAYER(bd, vk_link_caps(bd, out)); }

static cv_result link_staging(cv_backend_device *bd, cv_staging_desc *desc, void **out) {
    cv_result r;
    IN_LAYER(bd, r = vk_link_staging(bd, desc, out));
    return r;
}

static cv_result link_copy(cv_backend_device *bd, void *staging, uint64_t staging_offset, cv_handle_type type,
                           void *obj, uint64_t offset, uint64_t size, cv_rect rect, bool to_staging) {
    cv_result r;
    IN_LAYER(bd, r = vk_link_copy(bd, staging, staging_offset, type, obj, offset, size, rect, to_staging));
    return r;
}

static cv_result link_copy_async(cv_backend_device *bd, void *staging, uint64_t staging_offset, cv_handle_type type,
                                 void *obj, uint64_t offset, uint64_t size, cv_rect rect, bool to_staging,
                                 const cv_link_wait *wait, uint64_t ticket) {
    cv_result r;
    IN_LAYER(bd, r = vk_link_copy_async(bd, staging, staging_offset, type, obj, offset, size, rect, to_staging, wait,
                                        ticket));
    return r;
}

static void link_release(cv_backend_device *bd, void *staging) { IN_LAYER(bd, vk_link_release(bd, staging)); }

static cv_result link_copy_device(cv_backend_device *bd, cv_backend_device *dst_bd, cv_handle_type type,
                                  void *src_obj, void *dst_obj, const cv_link_region *region, uint64_t dst_wait,
                                  uint64_t ticket, uint64_t dst_ticket) {
    cv_result r;
    IN_LAYER(bd, r = vk_link_copy_device(bd, dst_bd, type, src_obj, dst_obj, region, dst_wait, ticket, dst_ticket));
    return r;
}

static cv_result link_wait(cv_backend_device *bd, const cv_link_wait *wait, uint64_t ticket) {
    cv_result r;
    IN_LAYER(bd, r = vk_link_wait(bd, wait, ticket));
    return r;
}

static const cv_backend vulkan_backend = {
    .name = "vulkan",
    .device_create = vk_device_create,
    .device_destroy = vk_device_destroy,
    .resource_create = resource_create,
    .resource_destroy = resource_destroy,
    .buffer_write = buffer_write,
    .buffer_read = buffer_read,
    .texture_write = texture_write,
    .texture_read = texture_read,
    .accel_write = accel_write,
    .list_compile = list_compile,
    .list_release = list_release,
    .submit = submit,
    .wait = vk_wait,
    .completed = vk_completed,
    .timings = timings,
    .refused = refused,
    .link_caps = link_caps,
    .link_staging = link_staging,
    .link_copy = link_copy,
    .link_copy_async = link_copy_async,
    .link_release = link_release,
    .link_copy_device = link_copy_device,
    .resource_alias = resource_alias,
    .link_wait = link_wait,
};

const cv_backend *cv_vulkan_backend(void) { return &vulkan_backend; }

cv_result cv_vulkan_get_memory_stats(cv_device *dev, cv_vulkan_memory_stats *out) {
    if (!dev || !out)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_vulkan_get_memory_stats: NULL argument");
    if (strcmp(cv_device_get_info(dev)->backend, vulkan_backend.name) != 0)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_vulkan_get_memory_stats: device '%s' is a %s device",
                        cv_device_label(dev), cv_device_get_info(dev)->backend);
    cv_backend_device *bd = cv_device_backend_data(dev);
    vk_memory_stats(&bd->memory, out);
    out->buffers = atomic_load(&bd->buffers);
    out->images = atomic_load(&bd->images);
    out->samplers = atomic_load(&bd->samplers);
    out->pipelines = atomic_load(&bd->pipelines);
    out->zeroed_bytes = atomic_load(&bd->zeroed_bytes);
    out->zero_ms = (double)atomic_load(&bd->zero_ns) / 1e6;
    return CV_OK;
}
