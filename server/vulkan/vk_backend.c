/* The Vulkan backend table: the core's backend interface (backend.h) mapped
 * onto the modules of this folder, plus the device queries of vulkan.h. */
#include <string.h>

#include "vk_compile.h"
#include "vk_host_transfer.h"
#include "vk_link.h"
#include "vk_pipelines.h"
#include "vk_indirect.h"
#include "vk_submit.h"
#include "vk_trace.h"

static cv_result resource_create(cv_backend_device *bd, uint64_t id, const cv_resource_desc *desc,
                                 const cv_pipeline_info *pipeline, void **out) {
    (void)id;
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

static void resource_destroy(cv_backend_device *bd, cv_handle_type type, void *obj) {
    switch (type) {
    case CV_HANDLE_BUFFER: vk_buffer_destroy(bd, obj); break;
    case CV_HANDLE_TEXTURE: vk_texture_destroy(bd, obj); break;
    case CV_HANDLE_SAMPLER: vk_sampler_destroy(bd, obj); break;
    case CV_HANDLE_PIPELINE: vk_pipeline_destroy(bd, obj); break;
    case CV_HANDLE_ACCEL: vk_accel_destroy(bd, obj); break;
    default: break;
    }
}

static cv_result buffer_write(cv_backend_device *bd, void *buf, uint64_t offset, uint64_t size, const void *data) {
    return vk_host_buffer_write(bd, buf, offset, size, data);
}

static cv_result buffer_read(cv_backend_device *bd, void *buf, uint64_t offset, uint64_t size, void *out) {
    return vk_host_buffer_read(bd, buf, offset, size, out);
}

static cv_result texture_write(cv_backend_device *bd, void *tex, const cv_texture_desc *desc, cv_rect rect,
                               const void *data) {
    (void)desc;
    return vk_host_texture_write(bd, tex, rect, data);
}

static cv_result texture_read(cv_backend_device *bd, void *tex, const cv_texture_desc *desc, cv_rect rect,
                              void *out) {
    (void)desc;
    return vk_host_texture_read(bd, tex, rect, out);
}

static cv_result accel_write(cv_backend_device *bd, void *accel, const cv_accel_desc *desc, const void *nodes,
                             const void *triangles) {
    (void)desc;
    return vk_accel_write(bd, accel, nodes, triangles);
}

static cv_result list_compile(cv_backend_device *bd, cv_device *dev, const cv_command_list *list, void **out) {
    return vk_compile_list(bd, dev, list, (vk_compiled **)out);
}

static void list_release(cv_backend_device *bd, void *compiled) { vk_compiled_release(bd, compiled); }

static cv_result submit(cv_backend_device *bd, void *compiled, uint64_t ticket) {
    return vk_submit(bd, compiled, ticket);
}

static cv_result timings(cv_backend_device *bd, void *compiled, cv_pass_timing *out, uint32_t capacity,
                         uint32_t *count) {
    return vk_timestamps_read(bd, &((vk_compiled *)compiled)->timestamps, out, capacity, count);
}

static cv_result resource_alias(cv_backend_device *bd, uint64_t id, const cv_resource_desc *desc,
                                cv_backend_device *src_bd, void *src_obj, void **out) {
    (void)id;
    return vk_texture_alias(bd, &desc->texture, src_bd, src_obj, (vk_texture **)out);
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
    .refused = vk_indirect_report,
    .link_caps = vk_link_caps,
    .link_staging = vk_link_staging,
    .link_copy = vk_link_copy,
    .link_copy_async = vk_link_copy_async,
    .link_release = vk_link_release,
    .link_copy_device = vk_link_copy_device,
    .resource_alias = resource_alias,
    .link_wait = vk_link_wait,
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
    return CV_OK;
}
