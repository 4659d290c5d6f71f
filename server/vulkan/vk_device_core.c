/* The device's shared services (vk_device_core.h): timelines, host waits on
 * them, debug names, sharing modes, extension checks, command pool teardown. */
#include <sched.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "corvid/clock.h"
#include "vk_device_core.h"

/* With validation: one slice of a host wait under the host lock. */
#define HOST_SLICE_NS (200ull * 1000)

void vk_device_core_init(cv_backend_device *bd, pthread_mutex_t *shared_host_lock) {
    pthread_mutex_init(&bd->host_lock, NULL);
    bd->host = shared_host_lock ? shared_host_lock : &bd->host_lock;
    bd->serialize = bd->instance->validation;
}

void vk_device_core_finish(cv_backend_device *bd) {
    if (!bd->host)
        return;
    pthread_mutex_destroy(&bd->host_lock);
    bd->host = NULL;
    bd->serialize = false;
}

VkResult vk_host_wait(cv_backend_device *bd, const VkSemaphoreWaitInfo *info, uint64_t timeout_ns) {
    if (!bd->serialize)
        return vkWaitSemaphores(bd->device, info, timeout_ns);
    uint64_t start = cv_now_ns();
    for (;;) {
        uint64_t spent = cv_now_ns() - start;
        uint64_t left = spent >= timeout_ns ? 0 : timeout_ns - spent;
        vk_layer_enter(bd->instance); /* slice by slice, so a device's creation can come between */
        pthread_mutex_lock(bd->host);
        VkResult vr = vkWaitSemaphores(bd->device, info, left < HOST_SLICE_NS ? left : HOST_SLICE_NS);
        pthread_mutex_unlock(bd->host);
        vk_layer_leave(bd->instance);
        if (vr != VK_TIMEOUT || left <= HOST_SLICE_NS)
            return vr;
        sched_yield(); /* let a bridge thread take the lock */
    }
}

uint64_t vk_host_counter(cv_backend_device *bd, VkSemaphore semaphore) {
    uint64_t value = 0;
    vk_layer_enter(bd->instance);
    if (bd->serialize)
        pthread_mutex_lock(bd->host);
    vkGetSemaphoreCounterValue(bd->device, semaphore, &value);
    if (bd->serialize)
        pthread_mutex_unlock(bd->host);
    vk_layer_leave(bd->instance);
    return value;
}

void vk_host_signal(cv_backend_device *bd, const VkSemaphoreSignalInfo *signal) {
    vk_layer_enter(bd->instance);
    if (bd->serialize)
        pthread_mutex_lock(bd->host);
    vkSignalSemaphore(bd->device, signal); /* fails only with a lost device: nothing waits then */
    if (bd->serialize)
        pthread_mutex_unlock(bd->host);
    vk_layer_leave(bd->instance);
}

bool vk_device_offers(VkPhysicalDevice physical, const char *name) {
    uint32_t count = 0;
    vkEnumerateDeviceExtensionProperties(physical, NULL, &count, NULL);
    VkExtensionProperties *exts = calloc(count ? count : 1, sizeof(*exts));
    bool found = false;
    if (exts && vkEnumerateDeviceExtensionProperties(physical, NULL, &count, exts) >= 0)
        for (uint32_t i = 0; i < count && !found; i++)
            found = strcmp(exts[i].extensionName, name) == 0;
    free(exts);
    return found;
}

cv_result vk_device_create_timeline(cv_backend_device *bd, VkSemaphore *out, const char *what, bool exportable) {
    VkExportSemaphoreCreateInfo export = { .sType = VK_STRUCTURE_TYPE_EXPORT_SEMAPHORE_CREATE_INFO,
                                           .handleTypes = VK_EXTERNAL_SEMAPHORE_HANDLE_TYPE_OPAQUE_FD_BIT };
    VkSemaphoreTypeCreateInfo type = { .sType = VK_STRUCTURE_TYPE_SEMAPHORE_TYPE_CREATE_INFO,
                                       .pNext = exportable ? &export : NULL,
                                       .semaphoreType = VK_SEMAPHORE_TYPE_TIMELINE };
    VkSemaphoreCreateInfo info = { .sType = VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO, .pNext = &type };
    *out = VK_NULL_HANDLE;
    VkResult vr = vkCreateSemaphore(bd->device, &info, NULL, out);
    return vr == VK_SUCCESS ? CV_OK
                            : vk_fail(vr, "vkCreateSemaphore (%s timeline%s, device '%s')", what,
                                      exportable ? ", exportable" : "", bd->label);
}

void vk_device_free_command_buffers(cv_backend_device *bd, VkCommandPool pool, uint32_t count,
                                    const VkCommandBuffer *buffers) {
    vk_layer_exclusive_begin(bd->instance);
    vkFreeCommandBuffers(bd->device, pool, count, buffers);
    vk_layer_exclusive_end(bd->instance);
}

void vk_device_destroy_command_pool(cv_backend_device *bd, VkCommandPool pool) {
    vk_layer_exclusive_begin(bd->instance);
    vkDestroyCommandPool(bd->device, pool, NULL);
    vk_layer_exclusive_end(bd->instance);
}

bool vk_device_same(const cv_backend_device *a, const cv_backend_device *b) {
    return a->shared && a->shared == b->shared;
}

void vk_device_sharing(const cv_backend_device *bd, VkSharingMode *mode, uint32_t *family_count,
                       const uint32_t **families) {
    bool shared = bd->family_count > 1;
    *mode = shared ? VK_SHARING_MODE_CONCURRENT : VK_SHARING_MODE_EXCLUSIVE;
    *family_count = shared ? bd->family_count : 0;
    *families = shared ? bd->families : NULL;
}

void vk_device_name(const cv_backend_device *bd, VkObjectType type, uint64_t handle, const char *label) {
    if (!bd->instance->set_object_name || !label || !label[0])
        return;
    char name[CV_LABEL_MAX];
    snprintf(name, sizeof(name), "%s", label);
    VkDebugUtilsObjectNameInfoEXT info = { .sType = VK_STRUCTURE_TYPE_DEBUG_UTILS_OBJECT_NAME_INFO_EXT,
                                           .objectType = type,
                                           .objectHandle = handle,
                                           .pObjectName = name };
    bd->instance->set_object_name(bd->device, &info);
}
