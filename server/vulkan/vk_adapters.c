/* Adapter enumeration, capabilities, choice by purpose and lookup by name.
 *
 * Indices are positions in vkEnumeratePhysicalDevices' order, which is the same
 * for the plain and the validated instance, so an index names one adapter
 * whichever instance a device is created on. */
#include <ctype.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "vk_adapters.h"

static cv_vulkan_adapter_type type_of(VkPhysicalDeviceType t) {
    switch (t) {
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU: return CV_VULKAN_ADAPTER_INTEGRATED;
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU: return CV_VULKAN_ADAPTER_DISCRETE;
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU: return CV_VULKAN_ADAPTER_VIRTUAL;
    case VK_PHYSICAL_DEVICE_TYPE_CPU: return CV_VULKAN_ADAPTER_CPU;
    default: return CV_VULKAN_ADAPTER_OTHER;
    }
}

static bool has_extension(const VkExtensionProperties *exts, uint32_t count, const char *name) {
    for (uint32_t i = 0; i < count; i++)
        if (strcmp(exts[i].extensionName, name) == 0)
            return true;
    return false;
}

static void pick_families(vk_adapter *a) {
    uint32_t count = 0;
    vkGetPhysicalDeviceQueueFamilyProperties(a->physical, &count, NULL);
    VkQueueFamilyProperties families[32];
    if (count > 32)
        count = 32;
    vkGetPhysicalDeviceQueueFamilyProperties(a->physical, &count, families);
    a->graphics_family = a->compute_family = a->copy_family = VK_NO_FAMILY;
    for (uint32_t i = 0; i < count; i++) {
        VkQueueFlags f = families[i].queueFlags;
        if (families[i].queueCount == 0)
            continue;
        bool graphics = f & VK_QUEUE_GRAPHICS_BIT, compute = f & VK_QUEUE_COMPUTE_BIT;
        if (graphics && compute && a->graphics_family == VK_NO_FAMILY)
            a->graphics_family = i;
        else if (!graphics && compute && a->compute_family == VK_NO_FAMILY)
            a->compute_family = i;
        else if (!graphics && !compute && (f & VK_QUEUE_TRANSFER_BIT) && a->copy_family == VK_NO_FAMILY &&
                 families[i].minImageTransferGranularity.width == 1 &&
                 families[i].minImageTransferGranularity.height == 1)
            a->copy_family = i;
    }
}

static void describe(vk_adapter *a, uint32_t index) {
    VkPhysicalDeviceDriverProperties driver = { .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_DRIVER_PROPERTIES };
    VkPhysicalDeviceProperties2 props = { .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2, .pNext = &driver };
    vkGetPhysicalDeviceProperties2(a->physical, &props);
    VkPhysicalDeviceMemoryProperties mem;
    vkGetPhysicalDeviceMemoryProperties(a->physical, &mem);

    cv_vulkan_adapter_info *info = &a->info;
    info->index = index;
    snprintf(info->name, sizeof(info->name), "%s", props.properties.deviceName);
    snprintf(info->driver, sizeof(info->driver), "%.60s %.60s", driver.driverName, driver.driverInfo);
    info->type = type_of(props.properties.deviceType);
    info->vendor_id = props.properties.vendorID;
    info->device_id = props.properties.deviceID;
    info->api_version = props.properties.apiVersion;
    for (uint32_t i = 0; i < mem.memoryHeapCount; i++)
        if ((mem.memoryHeaps[i].flags & VK_MEMORY_HEAP_DEVICE_LOCAL_BIT) &&
            mem.memoryHeaps[i].size > info->device_local_bytes)
            info->device_local_bytes = mem.memoryHeaps[i].size;

    pick_families(a);
    info->separate_compute_queue = a->compute_family != VK_NO_FAMILY;
    info->separate_copy_queue = a->copy_family != VK_NO_FAMILY;

    uint32_t ext_count = 0;
    vkEnumerateDeviceExtensionProperties(a->physical, NULL, &ext_count, NULL);
    VkExtensionProperties *exts = calloc(ext_count ? ext_count : 1, sizeof(*exts));
    if (exts)
        vkEnumerateDeviceExtensionProperties(a->physical, NULL, &ext_count, exts);
    else
        ext_count = 0;
    info->ray_tracing_pipeline = has_extension(exts, ext_count, VK_KHR_RAY_TRACING_PIPELINE_EXTENSION_NAME);
    bool push_descriptor = has_extension(exts, ext_count, VK_KHR_PUSH_DESCRIPTOR_EXTENSION_NAME);
    free(exts);

    VkPhysicalDeviceVulkan13Features f13 = { .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_3_FEATURES };
    VkPhysicalDeviceVulkan12Features f12 = { .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES,
                                             .pNext = &f13 };
    VkPhysicalDeviceFeatures2 f = { .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2, .pNext = &f12 };
    if (info->api_version >= VK_API_VERSION_1_3)
        vkGetPhysicalDeviceFeatures2(a->physical, &f);
    a->storage_without_format = f.features.shaderStorageImageReadWithoutFormat &&
                                f.features.shaderStorageImageWriteWithoutFormat;

    const char *missing = NULL;
    if (info->api_version < VK_API_VERSION_1_3)
        missing = "Vulkan 1.3";
    else if (!push_descriptor)
        missing = VK_KHR_PUSH_DESCRIPTOR_EXTENSION_NAME;
    else if (!f13.dynamicRendering)
        missing = "dynamicRendering";
    else if (!f13.synchronization2)
        missing = "synchronization2";
    else if (!f12.timelineSemaphore)
        missing = "timelineSemaphore";
    else if (!f12.bufferDeviceAddress)
        missing = "bufferDeviceAddress";
    else if (a->graphics_family == VK_NO_FAMILY)
        missing = "a graphics+compute queue family";
    info->usable = missing == NULL;
    if (missing)
        snprintf(info->unusable_reason, sizeof(info->unusable_reason), "lacks %s", missing);
}

cv_result vk_adapters_enumerate(const vk_instance *inst, vk_adapter **out, uint32_t *count) {
    uint32_t n = 0;
    VkResult vr = vkEnumeratePhysicalDevices(inst->instance, &n, NULL);
    if (vr != VK_SUCCESS)
        return vk_fail(vr, "vkEnumeratePhysicalDevices");
    VkPhysicalDevice *physical = calloc(n ? n : 1, sizeof(*physical));
    vk_adapter *adapters = calloc(n ? n : 1, sizeof(*adapters));
    if (!physical || !adapters) {
        free(physical);
        free(adapters);
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "vulkan: %u adapters", n);
    }
    vr = vkEnumeratePhysicalDevices(inst->instance, &n, physical);
    if (vr < 0) {
        free(physical);
        free(adapters);
        return vk_fail(vr, "vkEnumeratePhysicalDevices");
    }
    for (uint32_t i = 0; i < n; i++) {
        adapters[i].physical = physical[i];
        describe(&adapters[i], i);
    }
    free(physical);
    *out = adapters;
    *count = n;
    return CV_OK;
}

static int type_rank(cv_vulkan_adapter_type t) {
    switch (t) {
    case CV_VULKAN_ADAPTER_DISCRETE: return 4;
    case CV_VULKAN_ADAPTER_INTEGRATED: return 3;
    case CV_VULKAN_ADAPTER_VIRTUAL: return 2;
    case CV_VULKAN_ADAPTER_CPU: return 1;
    default: return 0;
    }
}

/* True if a is a better choice than b for the purpose. */
static bool better(const cv_vulkan_adapter_info *a, const cv_vulkan_adapter_info *b, cv_vulkan_purpose purpose) {
    if (purpose == CV_VULKAN_PURPOSE_RAY_TRACING && a->ray_tracing_pipeline != b->ray_tracing_pipeline)
        return a->ray_tracing_pipeline;
    if (purpose == CV_VULKAN_PURPOSE_SOFTWARE) {
        bool a_cpu = a->type == CV_VULKAN_ADAPTER_CPU, b_cpu = b->type == CV_VULKAN_ADAPTER_CPU;
        if (a_cpu != b_cpu)
            return a_cpu;
    }
    if (type_rank(a->type) != type_rank(b->type))
        return type_rank(a->type) > type_rank(b->type);
    return a->device_local_bytes > b->device_local_bytes;
}

static void list_adapters(const vk_adapter *adapters, uint32_t count, char *buf, size_t cap) {
    size_t used = 0;
    buf[0] = '\0';
    for (uint32_t i = 0; i < count && used < cap; i++)
        used += (size_t)snprintf(buf + used, cap - used, "%s%u '%s'%s%s", i ? ", " : "", i, adapters[i].info.name,
                                 adapters[i].info.usable ? "" : " (", adapters[i].info.usable ? "" : "unusable)");
    if (count == 0)
        snprintf(buf, cap, "none");
}

cv_result vk_adapters_choose(const vk_adapter *adapters, uint32_t count, cv_vulkan_purpose purpose, uint32_t *index) {
    uint32_t best = UINT32_MAX;
    for (uint32_t i = 0; i < count; i++)
        if (adapters[i].info.usable &&
            (best == UINT32_MAX || better(&adapters[i].info, &adapters[best].info, purpose)))
            best = i;
    if (best == UINT32_MAX) {
        char names[512];
        list_adapters(adapters, count, names, sizeof(names));
        return cv_error(CV_ERROR_NOT_FOUND,
                        "vulkan: no usable adapter (Vulkan 1.3 with push descriptors); adapters: %s", names);
    }
    *index = best;
    return CV_OK;
}

static bool contains_ignoring_case(const char *haystack, const char *needle) {
    size_t n = strlen(needle);
    for (const char *h = haystack; *h; h++) {
        size_t i = 0;
        while (i < n && h[i] && tolower((unsigned char)h[i]) == tolower((unsigned char)needle[i]))
            i++;
        if (i == n)
            return true;
    }
    return n == 0;
}

cv_result vk_adapters_resolve(const vk_adapter *adapters, uint32_t count, const char *spec, uint32_t *index) {
    if (!spec || !spec[0])
        return vk_adapters_choose(adapters, count, CV_VULKAN_PURPOSE_RENDER, index);
    char names[512];
    size_t digits = strspn(spec, "0123456789");
    if (digits == strlen(spec) && digits < 10) {
        unsigned long i = strtoul(spec, NULL, 10);
        if (i >= count) {
            list_adapters(adapters, count, names, sizeof(names));
            return cv_error(CV_ERROR_NOT_FOUND, "vulkan: adapter index %lu out of range (%u adapters: %s)", i, count,
                            names);
        }
        if (!adapters[i].info.usable)
            return cv_error(CV_ERROR_UNSUPPORTED, "vulkan: adapter %lu '%s' %s", i, adapters[i].info.name,
                            adapters[i].info.unusable_reason);
        *index = (uint32_t)i;
        return CV_OK;
    }
    uint32_t unusable = UINT32_MAX;
    for (uint32_t i = 0; i < count; i++) {
        if (!contains_ignoring_case(adapters[i].info.name, spec))
            continue;
        if (adapters[i].info.usable) {
            *index = i;
            return CV_OK;
        }
        unusable = i;
    }
    if (unusable != UINT32_MAX)
        return cv_error(CV_ERROR_UNSUPPORTED, "vulkan: adapter %u '%s' matches '%s' but %s", unusable,
                        adapters[unusable].info.name, spec, adapters[unusable].info.unusable_reason);
    list_adapters(adapters, count, names, sizeof(names));
    return cv_error(CV_ERROR_NOT_FOUND, "vulkan: no adapter name contains '%s'; adapters: %s", spec, names);
}

/* ---- public queries (on the plain instance) -------------------------------- */

static cv_result with_adapters(vk_instance **inst, vk_adapter **adapters, uint32_t *count) {
    cv_result r = vk_instance_acquire(false, CV_VULKAN_SYNC_VALIDATION_DEFAULT, inst);
    if (r != CV_OK)
        return r;
    r = vk_adapters_enumerate(*inst, adapters, count);
    if (r != CV_OK)
        vk_instance_release(*inst);
    return r;
}

cv_result cv_vulkan_adapters(cv_vulkan_adapter_info *out, uint32_t capacity, uint32_t *count) {
    if (!count || (capacity && !out))
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_vulkan_adapters: NULL argument");
    vk_instance *inst;
    vk_adapter *adapters;
    uint32_t n;
    cv_result r = with_adapters(&inst, &adapters, &n);
    if (r != CV_OK)
        return r;
    for (uint32_t i = 0; i < n && i < capacity; i++)
        out[i] = adapters[i].info;
    *count = n;
    free(adapters);
    vk_instance_release(inst);
    return CV_OK;
}

/* One adapter picked from a fresh enumeration: by purpose (spec NULL) or by spec. */
static cv_result pick_adapter(cv_vulkan_purpose purpose, const char *spec, bool by_spec, uint32_t *index) {
    vk_instance *inst;
    vk_adapter *adapters;
    uint32_t n;
    cv_result r = with_adapters(&inst, &adapters, &n);
    if (r != CV_OK)
        return r;
    r = by_spec ? vk_adapters_resolve(adapters, n, spec, index) : vk_adapters_choose(adapters, n, purpose, index);
    free(adapters);
    vk_instance_release(inst);
    return r;
}

cv_result cv_vulkan_choose_adapter(cv_vulkan_purpose purpose, uint32_t *index) {
    if (!index)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_vulkan_choose_adapter: NULL index");
    return pick_adapter(purpose, NULL, false, index);
}

cv_result cv_vulkan_find_adapter(const char *spec, uint32_t *index) {
    if (!index)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_vulkan_find_adapter: NULL index");
    return pick_adapter(CV_VULKAN_PURPOSE_RENDER, spec, true, index);
}
