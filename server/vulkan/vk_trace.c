/* Acceleration structures and the traversal pipeline (see vk_trace.h).
 *
 * Rays are traced by shaders/trace_rays.comp, the node2 traversal of
 * scene/src/trace_cpu.c on the GPU. The pipeline is the backend's own, so it
 * is described here rather than in the application-facing registry. */
#include <stdio.h>
#include <stdlib.h>

#include "vk_host_transfer.h"
#include "vk_trace.h"

static const cv_pipeline_info trace_info = {
    .name = "vulkan.trace_rays",
    .kind = CV_PIPELINE_COMPUTE,
    .local_size = { VK_TRACE_GROUP_SIZE, 1, 1 },
    .push_constant_size = sizeof(vk_trace_push),
    .binding_count = 4,
    .bindings = { CV_BINDING_STORAGE_BUFFER, CV_BINDING_STORAGE_BUFFER, CV_BINDING_STORAGE_BUFFER,
                  CV_BINDING_STORAGE_BUFFER },
    .compute_shader = "trace_rays.comp",
};

static cv_result array_buffer(cv_backend_device *bd, const cv_accel_desc *desc, uint64_t bytes, const char *part,
                              vk_buffer **out) {
    if (bytes > bd->limits.maxStorageBufferRange)
        return cv_error(CV_ERROR_LIMIT_EXCEEDED, "accel '%s': %llu bytes of %s exceed the %u-byte storage buffer "
                        "range of '%s'", desc->label, (unsigned long long)bytes, part,
                        bd->limits.maxStorageBufferRange, bd->adapter.info.name);
    cv_buffer_desc buffer = { .size = bytes, .usage = CV_BUFFER_USAGE_STORAGE };
    snprintf(buffer.label, sizeof(buffer.label), "%.30s %s", desc->label, part);
    return vk_buffer_create(bd, &buffer, out);
}

cv_result vk_accel_create(cv_backend_device *bd, const cv_accel_desc *desc, vk_accel **out) {
    vk_accel *a = calloc(1, sizeof(*a));
    if (!a)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "vulkan: accel '%s'", desc->label);
    a->node_count = desc->node_count;
    a->triangle_count = desc->triangle_count;
    cv_result r = array_buffer(bd, desc, (uint64_t)desc->node_count * CV_ACCEL_NODE_BYTES, "nodes", &a->nodes);
    if (r == CV_OK)
        r = array_buffer(bd, desc, (uint64_t)desc->triangle_count * CV_ACCEL_TRIANGLE_BYTES, "triangles",
                         &a->triangles);
    if (r != CV_OK) {
        vk_accel_destroy(bd, a);
        return r;
    }
    *out = a;
    return CV_OK;
}

void vk_accel_destroy(cv_backend_device *bd, vk_accel *a) {
    if (a->nodes)
        vk_buffer_destroy(bd, a->nodes);
    if (a->triangles)
        vk_buffer_destroy(bd, a->triangles);
    free(a);
}

cv_result vk_accel_write(cv_backend_device *bd, vk_accel *a, const void *nodes, const void *triangles) {
    cv_result r = vk_host_buffer_write(bd, a->nodes, 0, a->nodes->size, nodes);
    return r == CV_OK ? vk_host_buffer_write(bd, a->triangles, 0, a->triangles->size, triangles) : r;
}

cv_result vk_trace_pipeline(cv_backend_device *bd, const vk_pipeline **out) {
    if (!bd->trace_pipeline) {
        cv_result r = vk_pipeline_build(bd, &trace_info, &bd->trace_pipeline);
        if (r != CV_OK)
            return r;
    }
    *out = bd->trace_pipeline;
    return CV_OK;
}

void vk_trace_finish(cv_backend_device *bd) {
    if (bd->trace_pipeline)
        vk_pipeline_release(bd, bd->trace_pipeline);
    bd->trace_pipeline = NULL;
}
