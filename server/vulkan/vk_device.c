/* VkDevice creation and teardown: adapter choice from the desc, queue
 * families, enabled features, the ticket semaphore and the device info the
 * core reports. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "vk_device.h"
#include "vk_bridge.h"
#include "vk_cross_wait.h"
#include "vk_immediate.h"
#include "vk_indirect.h"
#include "vk_link.h"
#include "vk_resources.h"
#include "vk_shared.h"
#include "vk_trace.h"
#include "vk_trace_rt.h"

static cv_result pick_adapter(vk_instance *inst, const char *spec, vk_adapter *out) {
    vk_adapter *adapters;
    uint32_t count;
    cv_result r = vk_adapters_enumerate(inst, &adapters, &count);
    if (r != CV_OK)
        return r;
    uint32_t index;
    r = vk_adapters_resolve(adapters, count, spec, &index);
    if (r == CV_OK)
        *out = adapters[index];
    free(adapters);
    return r;
}

/* VK_EXT_calibrated_timestamps with both time domains the timings need: the
 * device's and CLOCK_MONOTONIC (the clock the graph and renderer use). */
static bool calibration_offered(const cv_backend_device *bd) {
    if (!vk_device_offers(bd->adapter.physical, VK_EXT_CALIBRATED_TIMESTAMPS_EXTENSION_NAME))
        return false;
    PFN_vkGetPhysicalDeviceCalibrateableTimeDomainsEXT domains_of =
        (PFN_vkGetPhysicalDeviceCalibrateableTimeDomainsEXT)
            vkGetInstanceProcAddr(bd->instance->instance, "vkGetPhysicalDeviceCalibrateableTimeDomainsEXT");
    VkTimeDomainEXT domains[8];
    uint32_t count = 8;
    if (!domains_of || domains_of(bd->adapter.physical, &count, domains) < 0)
        return false;
    bool device = false, monotonic = false;
    for (uint32_t i = 0; i < count && i < 8; i++) {
        device |= domains[i] == VK_TIME_DOMAIN_DEVICE_EXT;
        monotonic |= domains[i] == VK_TIME_DOMAIN_CLOCK_MONOTONIC_EXT;
    }
    return device && monotonic;
}

/* The queue families of the device's slots and their properties. */
typedef struct device_queues {
    uint32_t families[VK_SLOT_COUNT]; /* per slot; VK_NO_FAMILY: none */
    uint32_t queues[VK_SLOT_COUNT];   /* queues created in the slot's family */
    VkQueueFamilyProperties props[32];
    uint32_t prop_count;
    float priorities[VK_SHARED_MAX_QUEUES];
    VkDeviceQueueCreateInfo infos[VK_SLOT_COUNT];
    uint32_t info_count;
} device_queues;

static void plan_queues(const cv_backend_device *bd, device_queues *q) {
    const vk_adapter *a = &bd->adapter;
    *q = (device_queues){ .families = { a->graphics_family, a->compute_family, a->copy_family } };
    vkGetPhysicalDeviceQueueFamilyProperties(a->physical, &q->prop_count, NULL);
    if (q->prop_count > 32)
        q->prop_count = 32;
    vkGetPhysicalDeviceQueueFamilyProperties(a->physical, &q->prop_count, q->props);
    /* A shared VkDevice has every queue of each family it uses (up to
     * VK_SHARED_MAX_QUEUES), so its instances can spread over them. */
    for (uint32_t i = 0; i < VK_SHARED_MAX_QUEUES; i++)
        q->priorities[i] = 1.0f;
    for (int s = 0; s < VK_SLOT_COUNT; s++) {
        if (q->families[s] == VK_NO_FAMILY)
            continue;
        uint32_t n = q->families[s] < q->prop_count ? q->props[q->families[s]].queueCount : 1;
        q->queues[s] = !bd->vgpu_shared || n < 1 ? 1 : n > VK_SHARED_MAX_QUEUES ? VK_SHARED_MAX_QUEUES : n;
        q->infos[q->info_count++] = (VkDeviceQueueCreateInfo){
            .sType = VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO,
            .queueFamilyIndex = q->families[s],
            .queueCount = q->queues[s],
            .pQueuePriorities = q->priorities,
        };
    }
}

/* The features the device enables: what the adapter has of what kernels may
 * use; required only what the adapter checks made sure of (vk_adapters.h). */
typedef struct device_features {
    VkPhysicalDeviceRayTracingPipelineFeaturesKHR rt_pipeline;
    VkPhysicalDeviceAccelerationStructureFeaturesKHR rt_accel;
    VkPhysicalDeviceVulkan13Features f13;
    VkPhysicalDeviceVulkan12Features f12;
    VkPhysicalDeviceFeatures2 features;
} device_features;

static void plan_features(const cv_backend_device *bd, device_features *f) {
    VkPhysicalDeviceVulkan13Features have13 = { .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_3_FEATURES };
    VkPhysicalDeviceVulkan12Features have12 = { .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES,
                                                .pNext = &have13 };
    VkPhysicalDeviceFeatures2 have = { .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2, .pNext = &have12 };
    vkGetPhysicalDeviceFeatures2(bd->adapter.physical, &have);
    f->rt_pipeline = (VkPhysicalDeviceRayTracingPipelineFeaturesKHR){
        .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_RAY_TRACING_PIPELINE_FEATURES_KHR,
        .rayTracingPipeline = VK_TRUE,
    };
    f->rt_accel = (VkPhysicalDeviceAccelerationStructureFeaturesKHR){
        .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_ACCELERATION_STRUCTURE_FEATURES_KHR,
        .pNext = &f->rt_pipeline,
        .accelerationStructure = VK_TRUE,
    };
    /* The driver's ray-tracing path, where offered (vk_trace_rt.h). */
    f->f13 = (VkPhysicalDeviceVulkan13Features){
        .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_3_FEATURES,
        .pNext = bd->ray_tracing ? &f->rt_accel : NULL,
        .dynamicRendering = VK_TRUE,
        .synchronization2 = VK_TRUE,
        .maintenance4 = have13.maintenance4,
    };
    f->f12 = (VkPhysicalDeviceVulkan12Features){
        .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES,
        .pNext = &f->f13,
        .timelineSemaphore = VK_TRUE,
        .bufferDeviceAddress = VK_TRUE,
        .scalarBlockLayout = have12.scalarBlockLayout,
    };
    f->features = (VkPhysicalDeviceFeatures2){
        .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2,
        .pNext = &f->f12,
        .features = {
            .shaderStorageImageReadWithoutFormat = have.features.shaderStorageImageReadWithoutFormat,
            .shaderStorageImageWriteWithoutFormat = have.features.shaderStorageImageWriteWithoutFormat,
            .shaderInt64 = have.features.shaderInt64,
            .vertexPipelineStoresAndAtomics = have.features.vertexPipelineStoresAndAtomics,
            .fragmentStoresAndAtomics = have.features.fragmentStoresAndAtomics,
        },
    };
}

#define MAX_EXTENSIONS (5 + VK_RT_EXTENSION_COUNT)

/* The extensions the subsystems use, where offered; sets what bd enables. */
static uint32_t plan_extensions(cv_backend_device *bd, const char **extensions, bool *calibrated) {
    VkPhysicalDevice physical = bd->adapter.physical;
    uint32_t n = 0;
    extensions[n++] = VK_KHR_PUSH_DESCRIPTOR_EXTENSION_NAME;
    bd->ray_tracing = vk_rt_offered(physical);
    for (uint32_t i = 0; bd->ray_tracing && i < VK_RT_EXTENSION_COUNT; i++)
        extensions[n++] = vk_rt_extensions[i];
    /* Cross-device links, where offered (vk_link.h). */
    bd->external_fd = vk_device_offers(physical, VK_KHR_EXTERNAL_MEMORY_FD_EXTENSION_NAME);
    bd->external_host = vk_device_offers(physical, VK_EXT_EXTERNAL_MEMORY_HOST_EXTENSION_NAME);
    if (bd->external_fd)
        extensions[n++] = VK_KHR_EXTERNAL_MEMORY_FD_EXTENSION_NAME;
    if (bd->external_host)
        extensions[n++] = VK_EXT_EXTERNAL_MEMORY_HOST_EXTENSION_NAME;
    /* Cross-device waits through imported semaphores, where chosen (vk_cross_wait.h). */
    if (bd->cross_import)
        extensions[n++] = VK_KHR_EXTERNAL_SEMAPHORE_FD_EXTENSION_NAME;
    /* Pass starts on the host's clock (vk_timestamps.h), where the adapter can say. */
    *calibrated = calibration_offered(bd);
    if (*calibrated)
        extensions[n++] = VK_EXT_CALIBRATED_TIMESTAMPS_EXTENSION_NAME;
    return n;
}

/* The VkDevice: the adapter's own, or a slot of the shared one (vk_shared.h). */
static cv_result open_device(cv_backend_device *bd, const VkDeviceCreateInfo *info) {
    if (bd->vgpu_shared) {
        cv_result r = vk_shared_acquire(bd, info, &bd->shared, &bd->shared_slot);
        if (r == CV_OK)
            bd->device = bd->shared->device;
        return r;
    }
    vk_layer_exclusive_begin(bd->instance);
    VkResult vr = vkCreateDevice(bd->adapter.physical, info, NULL, &bd->device);
    vk_layer_exclusive_end(bd->instance);
    return vr == VK_SUCCESS
               ? CV_OK
               : vk_fail(vr, "vkCreateDevice on adapter %u '%s'", bd->adapter.info.index, bd->adapter.info.name);
}

static cv_result get_queues(cv_backend_device *bd, const device_queues *dq) {
    for (int s = 0; s < VK_SLOT_COUNT; s++) {
        uint32_t family = dq->families[s];
        if (family == VK_NO_FAMILY)
            continue;
        vk_queue *q = &bd->queues[s];
        q->present = true;
        q->family = family;
        q->flags = dq->props[family].queueFlags;
        uint32_t bits = dq->props[family].timestampValidBits;
        q->timestamp_mask = bits >= 64 ? UINT64_MAX : bits ? (1ull << bits) - 1 : 0;
        /* vk_shared.h's queue rule: slot k takes queue k % queueCount; every submit takes its mutex. */
        q->index = bd->shared ? bd->shared_slot % dq->queues[s] : 0;
        q->lock = bd->shared ? &bd->shared->queue_locks[s][q->index] : NULL;
        vkGetDeviceQueue(bd->device, family, q->index, &q->queue);
        bd->families[bd->family_count++] = family;
        VkCommandPoolCreateInfo pool_info = { .sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO,
                                              .queueFamilyIndex = family };
        VkResult vr = vkCreateCommandPool(bd->device, &pool_info, NULL, &q->pool);
        if (vr != VK_SUCCESS)
            return vk_fail(vr, "vkCreateCommandPool for queue family %u", family);
    }
    bd->slot_of_type[CV_QUEUE_GRAPHICS] = VK_SLOT_GRAPHICS;
    bd->slot_of_type[CV_QUEUE_COMPUTE] = bd->queues[VK_SLOT_COMPUTE].present ? VK_SLOT_COMPUTE : VK_SLOT_GRAPHICS;
    bd->slot_of_type[CV_QUEUE_COPY] = bd->queues[VK_SLOT_COPY].present ? VK_SLOT_COPY : VK_SLOT_GRAPHICS;
    bd->link_slot = bd->slot_of_type[bd->link_queue];
    return CV_OK;
}

#define DEVICE_PROC(bd, type, name) ((type)vkGetDeviceProcAddr((bd)->device, name))

/* The enabled extensions' entry points; an extension without them counts as not enabled. */
static cv_result load_entry_points(cv_backend_device *bd, bool calibrated) {
    if (bd->external_fd)
        bd->get_memory_fd = DEVICE_PROC(bd, PFN_vkGetMemoryFdKHR, "vkGetMemoryFdKHR");
    if (bd->external_host)
        bd->get_host_pointer_properties = DEVICE_PROC(bd, PFN_vkGetMemoryHostPointerPropertiesEXT,
                                                      "vkGetMemoryHostPointerPropertiesEXT");
    bd->external_fd = bd->external_fd && bd->get_memory_fd;
    bd->external_host = bd->external_host && bd->get_host_pointer_properties;
    if (bd->cross_import) {
        bd->get_semaphore_fd = DEVICE_PROC(bd, PFN_vkGetSemaphoreFdKHR, "vkGetSemaphoreFdKHR");
        bd->import_semaphore_fd = DEVICE_PROC(bd, PFN_vkImportSemaphoreFdKHR, "vkImportSemaphoreFdKHR");
        if (!bd->get_semaphore_fd || !bd->import_semaphore_fd) {
            bd->cross_import = false;
            snprintf(bd->cross_missing, sizeof(bd->cross_missing), "vkGetSemaphoreFdKHR/vkImportSemaphoreFdKHR");
            if (bd->cross_required)
                return cv_error(CV_ERROR_UNSUPPORTED,
                                "device '%s': cross_wait import needs %s, which it lacks (use bridge or auto)",
                                bd->label, bd->cross_missing);
        }
    }
    if (calibrated)
        bd->get_calibrated_timestamps = DEVICE_PROC(bd, PFN_vkGetCalibratedTimestampsEXT,
                                                    "vkGetCalibratedTimestampsEXT");
    bd->cmd_push_descriptor_set = DEVICE_PROC(bd, PFN_vkCmdPushDescriptorSetKHR, "vkCmdPushDescriptorSetKHR");
    if (!bd->cmd_push_descriptor_set)
        return cv_error(CV_ERROR_UNSUPPORTED, "vulkan: vkCmdPushDescriptorSetKHR missing on '%s'",
                        bd->adapter.info.name);
    return CV_OK;
}

static cv_result create_vk_device(cv_backend_device *bd) {
    device_queues queues;
    plan_queues(bd, &queues);
    const char *extensions[MAX_EXTENSIONS];
    bool calibrated;
    uint32_t extension_count = plan_extensions(bd, extensions, &calibrated);
    device_features features;
    plan_features(bd, &features);
    VkDeviceCreateInfo info = {
        .sType = VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO,
        .pNext = &features.features,
        .queueCreateInfoCount = queues.info_count,
        .pQueueCreateInfos = queues.infos,
        .enabledExtensionCount = extension_count,
        .ppEnabledExtensionNames = extensions,
    };
    cv_result r = open_device(bd, &info);
    if (r == CV_OK)
        vk_device_core_init(bd, bd->shared ? &bd->shared->host_lock : NULL);
    if (r == CV_OK)
        r = get_queues(bd, &queues);
    return r == CV_OK ? load_entry_points(bd, calibrated) : r;
}

static void fill_info(const cv_backend_device *bd, cv_device_info *info) {
    const cv_vulkan_adapter_info *a = &bd->adapter.info;
    memset(info, 0, sizeof(*info));
    snprintf(info->name, sizeof(info->name), "%s", a->name);
    snprintf(info->backend, sizeof(info->backend), "vulkan");
    snprintf(info->driver, sizeof(info->driver), "%s", a->driver);
    info->adapter_index = a->index;
    info->vendor_id = a->vendor_id;
    info->device_id = a->device_id;
    info->separate_compute_queue = bd->queues[VK_SLOT_COMPUTE].present;
    info->separate_copy_queue = bd->queues[VK_SLOT_COPY].present;
    info->ray_tracing_pipeline = bd->ray_tracing;
    snprintf(info->trace_path, sizeof(info->trace_path), "%s", cv_vulkan_trace_path_name(vk_trace_path_now(bd)));
    /* Shared VkDevice: waits on the other instances' semaphores directly (others: import or bridge). */
    snprintf(info->cross_wait, sizeof(info->cross_wait), "%s",
             bd->shared         ? "device"
             : bd->cross_import ? "import"
                                : "bridge");
    info->gpu_timestamps = bd->queues[VK_SLOT_GRAPHICS].timestamp_mask != 0 && bd->timestamp_period_ns > 0;
    info->max_storage_buffer_range = bd->limits.maxStorageBufferRange;
    for (int i = 0; i < 3; i++)
        info->max_dispatch[i] = bd->limits.maxComputeWorkGroupCount[i];
}

/* The adapter's limits, timestamp period, UUIDs and host import alignment. */
static void read_properties(cv_backend_device *bd) {
    VkPhysicalDeviceExternalMemoryHostPropertiesEXT host = {
        .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_EXTERNAL_MEMORY_HOST_PROPERTIES_EXT
    };
    VkPhysicalDeviceIDProperties ids = {
        .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_ID_PROPERTIES,
        .pNext = vk_device_offers(bd->adapter.physical, VK_EXT_EXTERNAL_MEMORY_HOST_EXTENSION_NAME) ? &host : NULL
    };
    VkPhysicalDeviceProperties2 props2 = { .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2, .pNext = &ids };
    vkGetPhysicalDeviceProperties2(bd->adapter.physical, &props2);
    const VkPhysicalDeviceProperties *props = &props2.properties;
    bd->limits = props->limits;
    bd->timestamp_period_ns = props->limits.timestampPeriod;
    memcpy(bd->driver_uuid, ids.driverUUID, VK_UUID_SIZE);
    memcpy(bd->device_uuid, ids.deviceUUID, VK_UUID_SIZE);
    bd->host_import_alignment = host.minImportedHostPointerAlignment;
}

/* The subsystems over the VkDevice, in order (vk_device_destroy stops them). */
static cv_result start_subsystems(cv_backend_device *bd, const cv_vulkan_device_options *o) {
    vk_memory_init(&bd->memory, bd->device, bd->adapter.physical);
    bd->memory.device_address = true;
    if (bd->external_host && vk_resources_host_import_ok(bd))
        vk_memory_enable_host_import(&bd->memory, bd->get_host_pointer_properties, bd->host_import_alignment);
    cv_result r = vk_device_create_timeline(bd, &bd->ticket, "ticket", bd->cross_import);
    if (r == CV_OK)
        r = vk_device_create_timeline(bd, &bd->chain, "segment chain", false);
    if (r == CV_OK)
        r = vk_immediate_init(bd);
    if (r == CV_OK)
        r = vk_bridge_init(bd);
    if (r == CV_OK)
        r = vk_trace_init(bd, o->trace_path);
    if (r == CV_OK)
        r = vk_indirect_init(bd);
    return r;
}

/* Every option within its enum (trace_path: vk_trace_init). */
static cv_result check_options(const cv_device_desc *desc, const cv_vulkan_device_options *o) {
    const char *bad = o->vgpu_device > CV_VULKAN_VGPU_SHARED               ? "vgpu_device"
                      : o->cross_wait > CV_VULKAN_CROSS_WAIT_IMPORT        ? "cross_wait"
                      : o->link_queue > CV_VULKAN_LINK_QUEUE_COPY          ? "link_queue"
                      : o->sync_validation > CV_VULKAN_SYNC_VALIDATION_OFF ? "sync_validation"
                                                                           : NULL;
    return bad ? cv_error(CV_ERROR_INVALID_ARGUMENT, "device '%s': cv_vulkan_device_options.%s out of its enum",
                          desc->label, bad)
               : CV_OK;
}

cv_result vk_device_create(const cv_device_desc *desc, cv_device_info *info, cv_backend_device **out) {
    cv_backend_device *bd = calloc(1, sizeof(*bd));
    if (!bd)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "vulkan: device");
    if (memchr(desc->label, '\0', CV_LABEL_MAX))
        snprintf(bd->label, sizeof(bd->label), "%s", desc->label);
    static const cv_vulkan_device_options defaults = { 0 };
    const cv_vulkan_device_options *o = desc->backend_options ? desc->backend_options : &defaults;
    cv_result r = check_options(desc, o);
    if (r != CV_OK) {
        free(bd);
        return r;
    }
    static const cv_queue_type link_queues[] = { CV_QUEUE_COMPUTE, CV_QUEUE_GRAPHICS, CV_QUEUE_COPY };
    bd->link_queue = link_queues[o->link_queue];
    r = vk_instance_acquire(desc->validation, o->sync_validation, &bd->instance);
    if (r != CV_OK) {
        free(bd);
        return r;
    }
    vk_layer_enter(bd->instance); /* every call below on the layer; left at the end */
    r = pick_adapter(bd->instance, desc->adapter, &bd->adapter);
    if (r == CV_OK) {
        bd->vgpu_shared = o->vgpu_device == CV_VULKAN_VGPU_SHARED ||
                          (o->vgpu_device == CV_VULKAN_VGPU_AUTO &&
                           vk_shared_auto_choice(bd->adapter.physical, bd->adapter.graphics_family));
        read_properties(bd);
        if (!bd->label[0])
            snprintf(bd->label, sizeof(bd->label), "vulkan:%u", bd->adapter.info.index);
        r = vk_cross_wait_setup(bd, o->cross_wait);
    }
    if (r == CV_OK)
        r = create_vk_device(bd);
    if (r == CV_OK)
        r = start_subsystems(bd, o);
    vk_instance *inst = bd->instance;
    if (r != CV_OK) {
        vk_device_destroy(bd);
        vk_layer_leave(inst);
        return r;
    }
    fill_info(bd, info);
    vk_layer_leave(inst);
    *out = bd;
    return CV_OK;
}

/* A shared VkDevice's instance cannot wait for the device to idle (that
 * waits for the other instances' work, and vkDeviceWaitIdle needs every queue
 * externally synchronised): it waits for its own last ticket and immediate
 * submission instead, which follow everything it submitted. */
static void wait_own_work(cv_backend_device *bd) {
    VkSemaphore semaphores[3];
    uint64_t values[3];
    uint32_t n = 0;
    if (bd->ticket)
        semaphores[n] = bd->ticket, values[n++] = bd->last_ticket;
    if (bd->chain) /* segments of a submission that failed part-way */
        semaphores[n] = bd->chain, values[n++] = bd->chain_value;
    if (bd->immediate)
        semaphores[n] = bd->immediate, values[n++] = bd->immediate_value;
    VkSemaphoreWaitInfo info = { .sType = VK_STRUCTURE_TYPE_SEMAPHORE_WAIT_INFO,
                                 .semaphoreCount = n,
                                 .pSemaphores = semaphores,
                                 .pValues = values };
    if (!n)
        return;
    if (bd->serialize)
        pthread_mutex_lock(bd->host);
    vkWaitSemaphores(bd->device, &info, UINT64_MAX); /* fails only with a lost device */
    if (bd->serialize)
        pthread_mutex_unlock(bd->host);
}

void vk_device_destroy(cv_backend_device *bd) {
    vk_instance *inst = bd->instance;
    vk_layer_enter(inst);
    if (bd->device) {
        vk_bridge_finish(bd); /* before the idle wait: it signals what is still queued */
        if (bd->shared)
            wait_own_work(bd);
        else
            vkDeviceWaitIdle(bd->device);
        vk_trace_finish(bd);
        vk_indirect_finish(bd);
        vk_link_async_finish(bd);
        vk_cross_wait_finish(bd); /* after the idle wait: no submission waits on an import */
        vk_link_finish(bd);
        vk_immediate_finish(bd);
        if (bd->memory.device)
            vk_memory_finish(&bd->memory);
        vkDestroySemaphore(bd->device, bd->chain, NULL);
        for (int s = 0; s < VK_SLOT_COUNT; s++)
            if (bd->queues[s].pool)
                vk_device_destroy_command_pool(bd, bd->queues[s].pool);
        if (bd->shared) {
            vk_shared_retire(bd->shared, bd->ticket); /* other instances may still wait on it */
            vk_shared_release(bd->shared, bd->shared_slot);
        } else {
            vkDestroySemaphore(bd->device, bd->ticket, NULL);
            vk_layer_exclusive_begin(inst);
            vkDestroyDevice(bd->device, NULL);
            vk_layer_exclusive_end(inst);
        }
        vk_device_core_finish(bd);
    }
    vk_layer_leave(inst);
    vk_instance_release(inst);
    free(bd);
}
