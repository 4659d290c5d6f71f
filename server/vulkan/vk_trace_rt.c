/* The driver's ray-tracing path: extension entry points, acceleration
 * structure builds, the ray-tracing pipeline and its shader binding table (see
 * vk_trace_rt.h). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "corvid/shaders.h"
#include "vk_host_transfer.h"
#include "vk_immediate.h"
#include "vk_pipelines.h"
#include "vk_trace_rt.h"

const char *const vk_rt_extensions[VK_RT_EXTENSION_COUNT] = {
    VK_KHR_ACCELERATION_STRUCTURE_EXTENSION_NAME,
    VK_KHR_RAY_TRACING_PIPELINE_EXTENSION_NAME,
    VK_KHR_DEFERRED_HOST_OPERATIONS_EXTENSION_NAME,
};

struct vk_rt {
    PFN_vkCreateAccelerationStructureKHR create_structure;
    PFN_vkDestroyAccelerationStructureKHR destroy_structure;
    PFN_vkGetAccelerationStructureBuildSizesKHR build_sizes;
    PFN_vkCmdBuildAccelerationStructuresKHR cmd_build;
    PFN_vkGetAccelerationStructureDeviceAddressKHR structure_address;
    PFN_vkCreateRayTracingPipelinesKHR create_pipelines;
    PFN_vkGetRayTracingShaderGroupHandlesKHR group_handles;
    PFN_vkCmdTraceRaysKHR cmd_trace;
    VkPhysicalDeviceRayTracingPipelinePropertiesKHR pipeline_props;
    VkPhysicalDeviceAccelerationStructurePropertiesKHR structure_props;

    VkPipelineLayout layout;
    VkPipeline pipeline;
    vk_buffer *sbt;
    VkStridedDeviceAddressRegionKHR raygen, miss, hit, callable;
    vk_pipeline *expand; /* trace_rt_vertices.comp, built on the first build */
};

struct vk_rt_accel {
    uint32_t triangle_count;
    vk_buffer *blas_storage, *tlas_storage;
    VkAccelerationStructureKHR blas, tlas;
    VkDeviceAddress blas_address, tlas_address;
    VkDeviceSize scratch_bytes; /* enough for either build */
    char label[CV_LABEL_MAX];
};

/* Push constants of trace_rt.rgen and of trace_rt_vertices.comp. */
typedef struct rt_push {
    VkDeviceAddress tlas, triangles, rays, hits;
    uint32_t count, flags, width, pad;
} rt_push;

typedef struct expand_push {
    VkDeviceAddress triangles, vertices;
    uint32_t count, pad;
} expand_push;

static const cv_pipeline_info expand_info = {
    .name = "vulkan.trace_rt_vertices",
    .kind = CV_PIPELINE_COMPUTE,
    .local_size = { VK_TRACE_GROUP_SIZE, 1, 1 },
    .push_constant_size = sizeof(expand_push),
    .compute_shader = "trace_rt_vertices.comp",
};

#define RT_STAGES (VK_SHADER_STAGE_RAYGEN_BIT_KHR)
#define VERTEX_BYTES (3u * sizeof(float))

static VkDeviceSize align_up(VkDeviceSize v, VkDeviceSize a) { return (v + a - 1) / a * a; }

/* ---- support ------------------------------------------------------------------ */

bool vk_rt_offered(VkPhysicalDevice physical) {
    uint32_t count = 0;
    if (vkEnumerateDeviceExtensionProperties(physical, NULL, &count, NULL) != VK_SUCCESS || count == 0)
        return false;
    VkExtensionProperties *exts = calloc(count, sizeof(*exts));
    if (!exts || vkEnumerateDeviceExtensionProperties(physical, NULL, &count, exts) < 0) {
        free(exts);
        return false;
    }
    uint32_t found = 0;
    for (uint32_t e = 0; e < VK_RT_EXTENSION_COUNT; e++)
        for (uint32_t i = 0; i < count; i++)
            if (strcmp(exts[i].extensionName, vk_rt_extensions[e]) == 0) {
                found++;
                break;
            }
    free(exts);
    if (found != VK_RT_EXTENSION_COUNT)
        return false;
    VkPhysicalDeviceRayTracingPipelineFeaturesKHR pipeline = {
        .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_RAY_TRACING_PIPELINE_FEATURES_KHR
    };
    VkPhysicalDeviceAccelerationStructureFeaturesKHR structures = {
        .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_ACCELERATION_STRUCTURE_FEATURES_KHR, .pNext = &pipeline
    };
    VkPhysicalDeviceFeatures2 features = { .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2,
                                           .pNext = &structures };
    vkGetPhysicalDeviceFeatures2(physical, &features);
    return structures.accelerationStructure && pipeline.rayTracingPipeline;
}

cv_result vk_rt_create(cv_backend_device *bd, vk_rt **out) {
    vk_rt *rt = calloc(1, sizeof(*rt));
    if (!rt)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "vulkan: ray-tracing path of device '%s'", bd->label);
#define RT_LOAD(member, name) rt->member = (PFN_##name)vkGetDeviceProcAddr(bd->device, #name)
    RT_LOAD(create_structure, vkCreateAccelerationStructureKHR);
    RT_LOAD(destroy_structure, vkDestroyAccelerationStructureKHR);
    RT_LOAD(build_sizes, vkGetAccelerationStructureBuildSizesKHR);
    RT_LOAD(cmd_build, vkCmdBuildAccelerationStructuresKHR);
    RT_LOAD(structure_address, vkGetAccelerationStructureDeviceAddressKHR);
    RT_LOAD(create_pipelines, vkCreateRayTracingPipelinesKHR);
    RT_LOAD(group_handles, vkGetRayTracingShaderGroupHandlesKHR);
    RT_LOAD(cmd_trace, vkCmdTraceRaysKHR);
#undef RT_LOAD
    if (!rt->create_structure || !rt->destroy_structure || !rt->build_sizes || !rt->cmd_build ||
        !rt->structure_address || !rt->create_pipelines || !rt->group_handles || !rt->cmd_trace) {
        free(rt);
        return cv_error(CV_ERROR_UNSUPPORTED, "vulkan: '%s' lacks ray-tracing entry points it advertises",
                        bd->adapter.info.name);
    }
    rt->structure_props.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_ACCELERATION_STRUCTURE_PROPERTIES_KHR;
    rt->pipeline_props = (VkPhysicalDeviceRayTracingPipelinePropertiesKHR){
        .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_RAY_TRACING_PIPELINE_PROPERTIES_KHR, .pNext = &rt->structure_props
    };
    VkPhysicalDeviceProperties2 props = { .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2,
                                          .pNext = &rt->pipeline_props };
    vkGetPhysicalDeviceProperties2(bd->adapter.physical, &props);
    rt->pipeline_props.pNext = NULL;
    *out = rt;
    return CV_OK;
}

void vk_rt_destroy(cv_backend_device *bd, vk_rt *rt) {
    if (!rt)
        return;
    if (rt->expand)
        vk_pipeline_release(bd, rt->expand);
    if (rt->sbt)
        vk_buffer_destroy(bd, rt->sbt);
    vkDestroyPipeline(bd->device, rt->pipeline, NULL);
    vkDestroyPipelineLayout(bd->device, rt->layout, NULL);
    free(rt);
}

/* ---- buffers ------------------------------------------------------------------- */

/* A buffer of the path's own (counted in the device's stats like any buffer),
 * with a device address aligned to `alignment`. */
static cv_result rt_buffer(cv_backend_device *bd, VkDeviceSize size, VkBufferUsageFlags usage, VkDeviceSize alignment,
                           const char *label, vk_buffer **out) {
    return vk_buffer_create_raw(bd, size, usage | VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT, alignment, label, out);
}

/* ---- pipeline and shader binding table ----------------------------------------- */

static cv_result shader_module(cv_backend_device *bd, const char *file, VkShaderModule *out) {
    size_t size = 0;
    const uint32_t *words = cv_shader_spirv(file, &size);
    if (!words)
        return cv_error(CV_ERROR_NOT_FOUND, "vulkan: shader '%s' is not among the embedded shaders", file);
    VkShaderModuleCreateInfo info = { .sType = VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO,
                                      .codeSize = size,
                                      .pCode = words };
    VkResult vr = vkCreateShaderModule(bd->device, &info, NULL, out);
    return vr == VK_SUCCESS ? CV_OK : vk_fail(vr, "vkCreateShaderModule '%s'", file);
}

static cv_result create_pipeline(cv_backend_device *bd, vk_rt *rt) {
    VkPushConstantRange push = { .stageFlags = RT_STAGES, .offset = 0, .size = sizeof(rt_push) };
    VkPipelineLayoutCreateInfo layout_info = { .sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO,
                                               .pushConstantRangeCount = 1,
                                               .pPushConstantRanges = &push };
    VkResult vr = vkCreatePipelineLayout(bd->device, &layout_info, NULL, &rt->layout);
    if (vr != VK_SUCCESS)
        return vk_fail(vr, "vkCreatePipelineLayout (ray-tracing path)");

    static const char *const files[3] = { "trace_rt.rgen", "trace_rt.rmiss", "trace_rt.rchit" };
    static const VkShaderStageFlagBits stage_bits[3] = { VK_SHADER_STAGE_RAYGEN_BIT_KHR, VK_SHADER_STAGE_MISS_BIT_KHR,
                                                         VK_SHADER_STAGE_CLOSEST_HIT_BIT_KHR };
    VkShaderModule modules[3] = { VK_NULL_HANDLE, VK_NULL_HANDLE, VK_NULL_HANDLE };
    cv_result r = CV_OK;
    for (int i = 0; i < 3 && r == CV_OK; i++)
        r = shader_module(bd, files[i], &modules[i]);
    if (r == CV_OK) {
        VkPipelineShaderStageCreateInfo stages[3];
        for (int i = 0; i < 3; i++)
            stages[i] = (VkPipelineShaderStageCreateInfo){
                .sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO,
                .stage = stage_bits[i],
                .module = modules[i],
                .pName = "main"
            };
        VkRayTracingShaderGroupCreateInfoKHR groups[3];
        for (uint32_t i = 0; i < 3; i++)
            groups[i] = (VkRayTracingShaderGroupCreateInfoKHR){
                .sType = VK_STRUCTURE_TYPE_RAY_TRACING_SHADER_GROUP_CREATE_INFO_KHR,
                .type = i < 2 ? VK_RAY_TRACING_SHADER_GROUP_TYPE_GENERAL_KHR
                              : VK_RAY_TRACING_SHADER_GROUP_TYPE_TRIANGLES_HIT_GROUP_KHR,
                .generalShader = i < 2 ? i : VK_SHADER_UNUSED_KHR,
                .closestHitShader = i < 2 ? VK_SHADER_UNUSED_KHR : i,
                .anyHitShader = VK_SHADER_UNUSED_KHR,
                .intersectionShader = VK_SHADER_UNUSED_KHR,
            };
        VkRayTracingPipelineCreateInfoKHR info = {
            .sType = VK_STRUCTURE_TYPE_RAY_TRACING_PIPELINE_CREATE_INFO_KHR,
            .stageCount = 3,
            .pStages = stages,
            .groupCount = 3,
            .pGroups = groups,
            .maxPipelineRayRecursionDepth = 1,
            .layout = rt->layout,
        };
        vr = rt->create_pipelines(bd->device, VK_NULL_HANDLE, VK_NULL_HANDLE, 1, &info, NULL, &rt->pipeline);
        if (vr != VK_SUCCESS)
            r = vk_fail(vr, "vkCreateRayTracingPipelinesKHR (trace_rays on '%s')", bd->adapter.info.name);
    }
    for (int i = 0; i < 3; i++)
        vkDestroyShaderModule(bd->device, modules[i], NULL);
    return r;
}

/* One record per group (raygen, miss, hit), each region starting on the base
 * alignment; raygen's stride equals its size as the API requires. */
static cv_result create_sbt(cv_backend_device *bd, vk_rt *rt) {
    const VkPhysicalDeviceRayTracingPipelinePropertiesKHR *p = &rt->pipeline_props;
    uint32_t handle = p->shaderGroupHandleSize;
    VkDeviceSize record = align_up(handle, p->shaderGroupHandleAlignment);
    VkDeviceSize region = align_up(record, p->shaderGroupBaseAlignment);
    uint8_t handles[3 * 64];
    if (handle > 64)
        return cv_error(CV_ERROR_UNSUPPORTED, "vulkan: shader group handles of %u bytes on '%s'", handle,
                        bd->adapter.info.name);
    VkResult vr = rt->group_handles(bd->device, rt->pipeline, 0, 3, 3 * (size_t)handle, handles);
    if (vr != VK_SUCCESS)
        return vk_fail(vr, "vkGetRayTracingShaderGroupHandlesKHR");
    uint8_t *table = calloc(3, (size_t)region);
    if (!table)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "vulkan: shader binding table");
    for (int i = 0; i < 3; i++)
        memcpy(table + (size_t)region * i, handles + (size_t)handle * i, handle);
    cv_result r = rt_buffer(bd, 3 * region,
                            VK_BUFFER_USAGE_SHADER_BINDING_TABLE_BIT_KHR | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                            p->shaderGroupBaseAlignment, "trace shader binding table", &rt->sbt);
    if (r == CV_OK)
        r = vk_host_buffer_write(bd, rt->sbt, 0, 3 * region, table);
    free(table);
    if (r != CV_OK)
        return r;
    VkDeviceAddress base = rt->sbt->address;
    rt->raygen = (VkStridedDeviceAddressRegionKHR){ base, region, region };
    rt->miss = (VkStridedDeviceAddressRegionKHR){ base + region, record, record };
    rt->hit = (VkStridedDeviceAddressRegionKHR){ base + 2 * region, record, record };
    rt->callable = (VkStridedDeviceAddressRegionKHR){ 0, 0, 0 };
    return CV_OK;
}

cv_result vk_rt_prepare(cv_backend_device *bd, vk_rt *rt) {
    if (rt->sbt)
        return CV_OK;
    cv_result r = rt->pipeline ? CV_OK : create_pipeline(bd, rt);
    return r == CV_OK ? create_sbt(bd, rt) : r;
}

/* ---- acceleration structures --------------------------------------------------- */

static VkAccelerationStructureGeometryKHR triangle_geometry(VkDeviceAddress vertices, uint32_t count) {
    return (VkAccelerationStructureGeometryKHR){
        .sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_GEOMETRY_KHR,
        .geometryType = VK_GEOMETRY_TYPE_TRIANGLES_KHR,
        .geometry.triangles = {
            .sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_GEOMETRY_TRIANGLES_DATA_KHR,
            .vertexFormat = VK_FORMAT_R32G32B32_SFLOAT,
            .vertexData.deviceAddress = vertices,
            .vertexStride = VERTEX_BYTES,
            .maxVertex = 3 * count - 1,
            .indexType = VK_INDEX_TYPE_NONE_KHR,
        },
        .flags = VK_GEOMETRY_OPAQUE_BIT_KHR,
    };
}

static VkAccelerationStructureGeometryKHR instance_geometry(VkDeviceAddress instances) {
    return (VkAccelerationStructureGeometryKHR){
        .sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_GEOMETRY_KHR,
        .geometryType = VK_GEOMETRY_TYPE_INSTANCES_KHR,
        .geometry.instances = { .sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_GEOMETRY_INSTANCES_DATA_KHR,
                                .data.deviceAddress = instances },
        .flags = VK_GEOMETRY_OPAQUE_BIT_KHR,
    };
}

static VkAccelerationStructureBuildGeometryInfoKHR build_info(VkAccelerationStructureTypeKHR type,
                                                              const VkAccelerationStructureGeometryKHR *geometry) {
    return (VkAccelerationStructureBuildGeometryInfoKHR){
        .sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_BUILD_GEOMETRY_INFO_KHR,
        .type = type,
        .flags = VK_BUILD_ACCELERATION_STRUCTURE_PREFER_FAST_TRACE_BIT_KHR,
        .mode = VK_BUILD_ACCELERATION_STRUCTURE_MODE_BUILD_KHR,
        .geometryCount = 1,
        .pGeometries = geometry,
    };
}

/* Creates one structure of `type` in a buffer of its own; returns its build scratch size. */
static cv_result create_structure(cv_backend_device *bd, vk_rt *rt, vk_rt_accel *a,
                                  VkAccelerationStructureTypeKHR type, uint32_t primitives, vk_buffer **storage,
                                  VkAccelerationStructureKHR *out, VkDeviceAddress *address, VkDeviceSize *scratch) {
    bool bottom = type == VK_ACCELERATION_STRUCTURE_TYPE_BOTTOM_LEVEL_KHR;
    VkAccelerationStructureGeometryKHR geometry = bottom ? triangle_geometry(0, primitives) : instance_geometry(0);
    VkAccelerationStructureBuildGeometryInfoKHR info = build_info(type, &geometry);
    VkAccelerationStructureBuildSizesInfoKHR sizes = {
        .sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_BUILD_SIZES_INFO_KHR
    };
    rt->build_sizes(bd->device, VK_ACCELERATION_STRUCTURE_BUILD_TYPE_DEVICE_KHR, &info, &primitives, &sizes);
    char label[CV_LABEL_MAX];
    snprintf(label, sizeof(label), "%.36s %s", a->label, bottom ? "blas" : "tlas");
    cv_result r = rt_buffer(bd, sizes.accelerationStructureSize,
                            VK_BUFFER_USAGE_ACCELERATION_STRUCTURE_STORAGE_BIT_KHR, 256, label, storage);
    if (r != CV_OK)
        return r;
    VkAccelerationStructureCreateInfoKHR create = {
        .sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_CREATE_INFO_KHR,
        .buffer = (*storage)->buffer,
        .size = sizes.accelerationStructureSize,
        .type = type,
    };
    VkResult vr = rt->create_structure(bd->device, &create, NULL, out);
    if (vr != VK_SUCCESS)
        return vk_fail(vr, "vkCreateAccelerationStructureKHR '%s' (%llu bytes)", label,
                       (unsigned long long)sizes.accelerationStructureSize);
    VkAccelerationStructureDeviceAddressInfoKHR where = {
        .sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_DEVICE_ADDRESS_INFO_KHR, .accelerationStructure = *out
    };
    *address = rt->structure_address(bd->device, &where);
    *scratch = sizes.buildScratchSize;
    return CV_OK;
}

cv_result vk_rt_accel_create(cv_backend_device *bd, vk_rt *rt, uint32_t triangle_count, const char *label,
                             vk_rt_accel **out) {
    if (triangle_count > rt->structure_props.maxPrimitiveCount)
        return cv_error(CV_ERROR_LIMIT_EXCEEDED,
                        "accel '%s': %u triangles exceed the %llu of a ray-tracing "
                        "acceleration structure on '%s'",
                        label, triangle_count, (unsigned long long)rt->structure_props.maxPrimitiveCount,
                        bd->adapter.info.name);
    vk_rt_accel *a = calloc(1, sizeof(*a));
    if (!a)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "vulkan: ray-tracing structures of accel '%s'", label);
    a->triangle_count = triangle_count;
    snprintf(a->label, sizeof(a->label), "%s", label);
    VkDeviceSize blas_scratch = 0, tlas_scratch = 0;
    cv_result r = create_structure(bd, rt, a, VK_ACCELERATION_STRUCTURE_TYPE_BOTTOM_LEVEL_KHR, triangle_count,
                                   &a->blas_storage, &a->blas, &a->blas_address, &blas_scratch);
    if (r == CV_OK)
        r = create_structure(bd, rt, a, VK_ACCELERATION_STRUCTURE_TYPE_TOP_LEVEL_KHR, 1, &a->tlas_storage, &a->tlas,
                             &a->tlas_address, &tlas_scratch);
    if (r != CV_OK) {
        vk_rt_accel_destroy(bd, rt, a);
        return r;
    }
    a->scratch_bytes = blas_scratch > tlas_scratch ? blas_scratch : tlas_scratch;
    *out = a;
    return CV_OK;
}

void vk_rt_accel_destroy(cv_backend_device *bd, vk_rt *rt, vk_rt_accel *a) {
    rt->destroy_structure(bd->device, a->tlas, NULL);
    rt->destroy_structure(bd->device, a->blas, NULL);
    if (a->tlas_storage)
        vk_buffer_destroy(bd, a->tlas_storage);
    if (a->blas_storage)
        vk_buffer_destroy(bd, a->blas_storage);
    free(a);
}

static void memory_barrier(VkCommandBuffer cmd, VkPipelineStageFlags2 src_stage, VkAccessFlags2 src_access,
                           VkPipelineStageFlags2 dst_stage, VkAccessFlags2 dst_access) {
    VkMemoryBarrier2 barrier = { .sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER_2,
                                 .srcStageMask = src_stage,
                                 .srcAccessMask = src_access,
                                 .dstStageMask = dst_stage,
                                 .dstAccessMask = dst_access };
    VkDependencyInfo dep = { .sType = VK_STRUCTURE_TYPE_DEPENDENCY_INFO,
                             .memoryBarrierCount = 1,
                             .pMemoryBarriers = &barrier };
    vkCmdPipelineBarrier2(cmd, &dep);
}

/* The build's temporary buffers: expanded vertices, the one instance, scratch. */
typedef struct build_inputs {
    vk_buffer *vertices, *instances, *scratch;
} build_inputs;

static void release_inputs(cv_backend_device *bd, build_inputs *in) {
    vk_buffer *all[3] = { in->vertices, in->instances, in->scratch };
    for (int i = 0; i < 3; i++)
        if (all[i])
            vk_buffer_destroy(bd, all[i]);
}

static cv_result make_inputs(cv_backend_device *bd, vk_rt *rt, const vk_rt_accel *a, build_inputs *in) {
    cv_result r = rt_buffer(bd, (VkDeviceSize)a->triangle_count * 3 * VERTEX_BYTES,
                            VK_BUFFER_USAGE_STORAGE_BUFFER_BIT |
                                VK_BUFFER_USAGE_ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_BIT_KHR,
                            16, "trace blas vertices", &in->vertices);
    if (r == CV_OK)
        r = rt_buffer(bd, sizeof(VkAccelerationStructureInstanceKHR),
                      VK_BUFFER_USAGE_ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_BIT_KHR |
                          VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                      16, "trace tlas instance", &in->instances);
    if (r == CV_OK)
        r = rt_buffer(bd, a->scratch_bytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                      rt->structure_props.minAccelerationStructureScratchOffsetAlignment, "trace build scratch",
                      &in->scratch);
    if (r != CV_OK)
        return r;
    /* The identity instance of the BLAS; facing is left as Vulkan decides it,
     * which is bvh_gpu.h's rule (det > 0, counter-clockwise seen from the ray
     * in a right-handed frame, is the front). */
    VkAccelerationStructureInstanceKHR instance = {
        .transform = { .matrix = { { 1, 0, 0, 0 }, { 0, 1, 0, 0 }, { 0, 0, 1, 0 } } },
        .mask = 0xFF,
        .accelerationStructureReference = a->blas_address,
    };
    return vk_host_buffer_write(bd, in->instances, 0, sizeof(instance), &instance);
}

static cv_result ensure_expand(cv_backend_device *bd, vk_rt *rt) {
    return rt->expand ? CV_OK : vk_pipeline_build(bd, &expand_info, &rt->expand);
}

cv_result vk_rt_accel_build(cv_backend_device *bd, vk_rt *rt, vk_rt_accel *a, const vk_buffer *triangles) {
    build_inputs in = { 0 };
    cv_result r = ensure_expand(bd, rt);
    if (r == CV_OK)
        r = make_inputs(bd, rt, a, &in);
    VkCommandBuffer cmd = VK_NULL_HANDLE;
    if (r == CV_OK)
        r = vk_immediate_begin(bd, &cmd);
    if (r != CV_OK) {
        release_inputs(bd, &in);
        return r;
    }
    /* Earlier host and transfer writes (the triangles, the instance) before the reads below. */
    memory_barrier(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, VK_ACCESS_2_MEMORY_WRITE_BIT,
                   VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_2_ACCELERATION_STRUCTURE_BUILD_BIT_KHR,
                   VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_READ_BIT);
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, rt->expand->pipeline);
    expand_push push = { triangles->address, in.vertices->address, a->triangle_count, 0 };
    vkCmdPushConstants(cmd, rt->expand->layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(push), &push);
    uint32_t groups = (a->triangle_count + VK_TRACE_GROUP_SIZE - 1) / VK_TRACE_GROUP_SIZE;
    uint32_t max_x = bd->limits.maxComputeWorkGroupCount[0];
    uint32_t x = groups < max_x ? groups : max_x;
    vkCmdDispatch(cmd, x, (groups + x - 1) / x, 1);
    memory_barrier(cmd, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                   VK_PIPELINE_STAGE_2_ACCELERATION_STRUCTURE_BUILD_BIT_KHR, VK_ACCESS_2_SHADER_READ_BIT);

    VkAccelerationStructureGeometryKHR geometry = triangle_geometry(in.vertices->address, a->triangle_count);
    VkAccelerationStructureBuildGeometryInfoKHR info = build_info(VK_ACCELERATION_STRUCTURE_TYPE_BOTTOM_LEVEL_KHR,
                                                                  &geometry);
    info.dstAccelerationStructure = a->blas;
    info.scratchData.deviceAddress = in.scratch->address;
    VkAccelerationStructureBuildRangeInfoKHR range = { .primitiveCount = a->triangle_count };
    const VkAccelerationStructureBuildRangeInfoKHR *ranges = &range;
    rt->cmd_build(cmd, 1, &info, &ranges);
    /* The TLAS build reads the BLAS and reuses the scratch. */
    memory_barrier(cmd, VK_PIPELINE_STAGE_2_ACCELERATION_STRUCTURE_BUILD_BIT_KHR,
                   VK_ACCESS_2_ACCELERATION_STRUCTURE_WRITE_BIT_KHR,
                   VK_PIPELINE_STAGE_2_ACCELERATION_STRUCTURE_BUILD_BIT_KHR,
                   VK_ACCESS_2_ACCELERATION_STRUCTURE_READ_BIT_KHR |
                       VK_ACCESS_2_ACCELERATION_STRUCTURE_WRITE_BIT_KHR);
    geometry = instance_geometry(in.instances->address);
    info = build_info(VK_ACCELERATION_STRUCTURE_TYPE_TOP_LEVEL_KHR, &geometry);
    info.dstAccelerationStructure = a->tlas;
    info.scratchData.deviceAddress = in.scratch->address;
    range.primitiveCount = 1;
    rt->cmd_build(cmd, 1, &info, &ranges);
    r = vk_immediate_end(bd);
    release_inputs(bd, &in);
    return r;
}

/* ---- tracing --------------------------------------------------------------------- */

void vk_rt_record(vk_rt *rt, vk_tracker *tracker, VkCommandBuffer cmd, const vk_trace_job *job,
                  uint64_t triangles_key) {
    const VkPipelineStageFlags2 stage = VK_PIPELINE_STAGE_2_RAY_TRACING_SHADER_BIT_KHR;
    const vk_buffer *triangles = job->accel->triangles;
    vk_tracker_use(tracker, &(vk_use){ .id = triangles_key,
                                       .buffer = triangles->buffer,
                                       .stages = stage,
                                       .reads = VK_ACCESS_2_SHADER_STORAGE_READ_BIT });
    vk_tracker_use(tracker, &(vk_use){ .id = job->rays_key,
                                       .buffer = job->rays->buffer,
                                       .stages = stage,
                                       .reads = VK_ACCESS_2_SHADER_STORAGE_READ_BIT });
    vk_tracker_use(tracker, &(vk_use){ .id = job->hits_key,
                                       .buffer = job->hits->buffer,
                                       .stages = stage,
                                       .writes = VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT });
    vk_tracker_apply(tracker, cmd);

    uint32_t width = job->count < VK_TRACE_LAUNCH_WIDTH ? job->count : VK_TRACE_LAUNCH_WIDTH;
    rt_push push = {
        .tlas = job->accel->rt->tlas_address,
        .triangles = triangles->address,
        .rays = job->rays->address + job->rays_offset,
        .hits = job->hits->address + job->hits_offset,
        .count = job->count,
        .flags = job->flags,
        .width = width,
    };
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_RAY_TRACING_KHR, rt->pipeline);
    vkCmdPushConstants(cmd, rt->layout, RT_STAGES, 0, sizeof(push), &push);
    rt->cmd_trace(cmd, &rt->raygen, &rt->miss, &rt->hit, &rt->callable, width, (job->count + width - 1) / width, 1);
}
