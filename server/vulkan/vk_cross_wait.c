/* Cross-device GPU waits through imported ticket semaphores (see vk_cross_wait.h). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "vk_bridge.h"
#include "vk_cross_wait.h"

/* One imported semaphore on the waiter (bd->imports). */
typedef struct vk_import {
    vk_watch *watch;       /* the source's, a reference: identifies it, says when it closed */
    VkSemaphore semaphore; /* VK_NULL_HANDLE: the import failed (auto mode): this pair uses the bridge */
    uint64_t last_use;     /* the waiter's latest ticket that waits on it */
} vk_import;

bool vk_cross_wait_capable(bool has_extension, const VkExternalSemaphoreProperties *props, char *missing,
                           size_t missing_size) {
    const char *lack = NULL;
    VkExternalSemaphoreFeatureFlags f = props ? props->externalSemaphoreFeatures : 0;
    if (!has_extension)
        lack = VK_KHR_EXTERNAL_SEMAPHORE_FD_EXTENSION_NAME;
    else if (!props || !(props->compatibleHandleTypes & VK_EXTERNAL_SEMAPHORE_HANDLE_TYPE_OPAQUE_FD_BIT))
        lack = "opaque-fd timeline semaphores (compatibleHandleTypes)";
    else if (!(f & VK_EXTERNAL_SEMAPHORE_FEATURE_EXPORTABLE_BIT))
        lack = "exportable opaque-fd timeline semaphores";
    else if (!(f & VK_EXTERNAL_SEMAPHORE_FEATURE_IMPORTABLE_BIT))
        lack = "importable opaque-fd timeline semaphores";
    if (missing && missing_size)
        snprintf(missing, missing_size, "%s", lack ? lack : "");
    return lack == NULL;
}

cv_result vk_cross_wait_decide(cv_vulkan_cross_wait mode, bool capable, const char *missing, const char *label,
                               bool *import) {
    *import = false;
    if (mode == CV_VULKAN_CROSS_WAIT_IMPORT && !capable)
        return cv_error(CV_ERROR_UNSUPPORTED,
                        "device '%s': cross_wait import needs %s, which it lacks (use bridge or auto)", label,
                        missing && missing[0] ? missing : "semaphore import");
    *import = capable && mode != CV_VULKAN_CROSS_WAIT_BRIDGE;
    return CV_OK;
}

bool vk_cross_wait_same_device(const uint8_t driver_a[VK_UUID_SIZE], const uint8_t device_a[VK_UUID_SIZE],
                               const uint8_t driver_b[VK_UUID_SIZE], const uint8_t device_b[VK_UUID_SIZE]) {
    return memcmp(driver_a, driver_b, VK_UUID_SIZE) == 0 && memcmp(device_a, device_b, VK_UUID_SIZE) == 0;
}

cv_result vk_cross_wait_setup(cv_backend_device *bd, cv_vulkan_cross_wait mode) {
    bool extension = vk_device_offers(bd->adapter.physical, VK_KHR_EXTERNAL_SEMAPHORE_FD_EXTENSION_NAME);
    VkExternalSemaphoreProperties props = { .sType = VK_STRUCTURE_TYPE_EXTERNAL_SEMAPHORE_PROPERTIES };
    if (extension) {
        VkSemaphoreTypeCreateInfo type = { .sType = VK_STRUCTURE_TYPE_SEMAPHORE_TYPE_CREATE_INFO,
                                           .semaphoreType = VK_SEMAPHORE_TYPE_TIMELINE };
        VkPhysicalDeviceExternalSemaphoreInfo info = {
            .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_EXTERNAL_SEMAPHORE_INFO,
            .pNext = &type,
            .handleType = VK_EXTERNAL_SEMAPHORE_HANDLE_TYPE_OPAQUE_FD_BIT
        };
        vkGetPhysicalDeviceExternalSemaphoreProperties(bd->adapter.physical, &info, &props);
    }
    bool capable = vk_cross_wait_capable(extension, &props, bd->cross_missing, sizeof(bd->cross_missing));
    /* Under the validation layer, auto takes the bridge: the layer (1.3.239,
     * measured on the H200) never sees the other VkDevice signal an imported
     * semaphore, so it believes every submission that waited on one is still
     * pending and reports each reuse of its command buffer and resources as
     * "in use" (thousands of false reports in a render; the pixels are exact).
     * The cross_wait option IMPORT still forces it there. */
    if (mode == CV_VULKAN_CROSS_WAIT_AUTO && capable && bd->instance->validation) {
        capable = false;
        snprintf(bd->cross_missing, sizeof(bd->cross_missing),
                 "a device without the validation layer (it cannot follow imported semaphores)");
    }
    cv_result r = vk_cross_wait_decide(mode, capable, bd->cross_missing, bd->label, &bd->cross_import);
    bd->cross_required = mode == CV_VULKAN_CROSS_WAIT_IMPORT;
    return r;
}

bool vk_cross_wait_direct(const cv_backend_device *waiter, const cv_backend_device *source) {
    return waiter->cross_import && source->cross_import &&
           vk_cross_wait_same_device(waiter->driver_uuid, waiter->device_uuid, source->driver_uuid,
                                     source->device_uuid);
}

static void import_free(cv_backend_device *bd, vk_import *im) {
    if (im->semaphore)
        vkDestroySemaphore(bd->device, im->semaphore, NULL);
    vk_watch_unref(im->watch);
}

/* Drops the imports of closed sources that no submission of bd waits on any more. */
static void prune(cv_backend_device *bd) {
    bool any = false;
    for (uint32_t i = 0; i < bd->import_count && !any; i++)
        any = vk_watch_closing(bd->imports[i].watch);
    if (!any)
        return;
    uint64_t done = vk_host_counter(bd, bd->ticket);
    uint32_t kept = 0;
    for (uint32_t i = 0; i < bd->import_count; i++) {
        vk_import *im = &bd->imports[i];
        if (vk_watch_closing(im->watch) && im->last_use <= done)
            import_free(bd, im);
        else
            bd->imports[kept++] = *im;
    }
    bd->import_count = kept;
}

/* A timeline semaphore of bd carrying source's ticket payload. */
static cv_result import_ticket(cv_backend_device *bd, cv_backend_device *source, VkSemaphore *out) {
    *out = VK_NULL_HANDLE;
    int fd = -1;
    VkSemaphoreGetFdInfoKHR get = { .sType = VK_STRUCTURE_TYPE_SEMAPHORE_GET_FD_INFO_KHR,
                                    .semaphore = source->ticket,
                                    .handleType = VK_EXTERNAL_SEMAPHORE_HANDLE_TYPE_OPAQUE_FD_BIT };
    VkResult vr = source->get_semaphore_fd(source->device, &get, &fd);
    if (vr != VK_SUCCESS)
        return vk_fail(vr, "vkGetSemaphoreFdKHR (the ticket semaphore of device '%s', for device '%s')",
                       source->label, bd->label);
    VkSemaphore s;
    cv_result r = vk_device_create_timeline(bd, &s, "imported ticket", false);
    if (r != CV_OK) {
        close(fd);
        return r;
    }
    VkImportSemaphoreFdInfoKHR import = { .sType = VK_STRUCTURE_TYPE_IMPORT_SEMAPHORE_FD_INFO_KHR,
                                          .semaphore = s,
                                          .handleType = VK_EXTERNAL_SEMAPHORE_HANDLE_TYPE_OPAQUE_FD_BIT,
                                          .fd = fd };
    vr = bd->import_semaphore_fd(bd->device, &import);
    if (vr != VK_SUCCESS) {
        close(fd); /* not taken on failure */
        vkDestroySemaphore(bd->device, s, NULL);
        return vk_fail(vr, "vkImportSemaphoreFdKHR (the ticket semaphore of device '%s' into device '%s')",
                       source->label, bd->label);
    }
    vk_device_name(bd, VK_OBJECT_TYPE_SEMAPHORE, (uint64_t)s, source->label);
    *out = s;
    return CV_OK;
}

cv_result vk_cross_wait_semaphore(cv_backend_device *bd, cv_backend_device *source, uint64_t use, VkSemaphore *out) {
    *out = VK_NULL_HANDLE;
    prune(bd);
    vk_watch *w = vk_bridge_watch(source);
    for (uint32_t i = 0; i < bd->import_count; i++)
        if (bd->imports[i].watch == w) {
            if (bd->imports[i].semaphore)
                bd->imports[i].last_use = use;
            *out = bd->imports[i].semaphore;
            return CV_OK;
        }
    vk_import *grown = realloc(bd->imports, (bd->import_count + 1) * sizeof(*grown));
    if (!grown)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "device '%s': imported semaphores", bd->label);
    bd->imports = grown;
    VkSemaphore s;
    cv_result r = import_ticket(bd, source, &s);
    if (r != CV_OK && bd->cross_required)
        return r;
    /* auto: a failed import makes the pair use the bridge from now on (s is VK_NULL_HANDLE). */
    vk_watch_ref(w);
    bd->imports[bd->import_count++] = (vk_import){ .watch = w, .semaphore = s, .last_use = s ? use : 0 };
    *out = s;
    return CV_OK;
}

void vk_cross_wait_finish(cv_backend_device *bd) {
    for (uint32_t i = 0; i < bd->import_count; i++)
        import_free(bd, &bd->imports[i]);
    free(bd->imports);
    bd->imports = NULL;
    bd->import_count = 0;
}
