/* The registry of VkDevices shared by virtual GPUs (see vk_shared.h). */
#include <stdlib.h>

#include "vk_instance.h"
#include "vk_shared.h"

/* process-wide: like vk_instance.c's instances and for the same reason: the
 * instances of one adapter are created by independent cv_device_create calls
 * (possibly from several contexts and threads), so the only place they can
 * find the VkDevice they share is state of the process. Guarded by
 * registry_lock; entries live while an instance holds them. */
static pthread_mutex_t registry_lock = PTHREAD_MUTEX_INITIALIZER;
static vk_shared_device *registry;

bool vk_shared_auto_choice(VkPhysicalDevice physical, uint32_t graphics_family) {
    uint32_t count = 0;
    vkGetPhysicalDeviceQueueFamilyProperties(physical, &count, NULL);
    VkQueueFamilyProperties props[32];
    if (count > 32)
        count = 32;
    vkGetPhysicalDeviceQueueFamilyProperties(physical, &count, props);
    return graphics_family < count && props[graphics_family].queueCount > 1;
}

static uint32_t extension_key(const VkDeviceCreateInfo *info) {
    uint32_t h = 2166136261u; /* FNV-1a over the names, order-independent (summed) */
    uint32_t sum = 0;
    for (uint32_t i = 0; i < info->enabledExtensionCount; i++) {
        h = 2166136261u;
        for (const char *p = info->ppEnabledExtensionNames[i]; *p; p++)
            h = (h ^ (uint8_t)*p) * 16777619u;
        sum += h;
    }
    return sum + info->enabledExtensionCount;
}

static void entry_free(vk_shared_device *s) {
    for (int q = 0; q < VK_SLOT_COUNT; q++)
        for (uint32_t i = 0; i < VK_SHARED_MAX_QUEUES; i++)
            pthread_mutex_destroy(&s->queue_locks[q][i]);
    pthread_mutex_destroy(&s->host_lock);
    pthread_mutex_destroy(&s->pipeline_lock);
    free(s->retired);
    free(s);
}

static uint32_t take_slot(vk_shared_device *s) {
    for (uint32_t k = 0; k < 64; k++)
        if (!(s->slots & (1ull << k))) {
            s->slots |= 1ull << k;
            return k;
        }
    return s->refs; /* more than 64 instances: beyond the mask, never given back */
}

cv_result vk_shared_acquire(cv_backend_device *bd, const VkDeviceCreateInfo *info, vk_shared_device **out,
                            uint32_t *slot) {
    uint32_t key = extension_key(info);
    cv_result r = CV_OK;
    vk_layer_exclusive_begin(bd->instance); /* for vkCreateDevice; before registry_lock (vk_instance.h) */
    pthread_mutex_lock(&registry_lock);
    vk_shared_device *s = registry;
    while (s && !(s->instance == bd->instance && s->physical == bd->adapter.physical && s->extensions == key))
        s = s->next;
    if (!s) {
        s = calloc(1, sizeof(*s));
        VkResult vr = s ? vkCreateDevice(bd->adapter.physical, info, NULL, &s->device) : VK_ERROR_OUT_OF_HOST_MEMORY;
        if (vr != VK_SUCCESS) {
            free(s);
            s = NULL;
            r = vk_fail(vr, "vkCreateDevice (shared by virtual GPUs) on adapter %u '%s'", bd->adapter.info.index,
                        bd->adapter.info.name);
        } else {
            s->instance = bd->instance;
            s->physical = bd->adapter.physical;
            s->extensions = key;
            for (int q = 0; q < VK_SLOT_COUNT; q++)
                for (uint32_t i = 0; i < VK_SHARED_MAX_QUEUES; i++)
                    pthread_mutex_init(&s->queue_locks[q][i], NULL);
            pthread_mutex_init(&s->host_lock, NULL);
            pthread_mutex_init(&s->pipeline_lock, NULL);
            s->next = registry;
            registry = s;
        }
    }
    if (s) {
        s->refs++;
        *slot = take_slot(s);
        *out = s;
    }
    pthread_mutex_unlock(&registry_lock);
    vk_layer_exclusive_end(bd->instance);
    return r;
}

void vk_shared_retire(vk_shared_device *s, VkSemaphore semaphore) {
    if (!semaphore)
        return;
    pthread_mutex_lock(&registry_lock);
    VkSemaphore *grown = realloc(s->retired, (s->retired_count + 1) * sizeof(*grown));
    if (grown) {
        s->retired = grown;
        s->retired[s->retired_count++] = semaphore;
    }
    pthread_mutex_unlock(&registry_lock);
    /* Out of memory: the semaphore is leaked until the process ends (destroying it
     * now could pull it from under another instance's pending wait). */
}

void vk_shared_release(vk_shared_device *s, uint32_t slot) {
    pthread_mutex_lock(&registry_lock);
    if (slot < 64)
        s->slots &= ~(1ull << slot);
    bool last = --s->refs == 0;
    if (last) {
        vk_shared_device **p = &registry;
        while (*p != s)
            p = &(*p)->next;
        *p = s->next;
    }
    pthread_mutex_unlock(&registry_lock);
    if (!last)
        return;
    vkDeviceWaitIdle(s->device); /* the last instance: nothing else uses it */
    for (uint32_t i = 0; i < s->retired_count; i++)
        vkDestroySemaphore(s->device, s->retired[i], NULL);
    vk_layer_exclusive_begin(s->instance);
    vkDestroyDevice(s->device, NULL);
    vk_layer_exclusive_end(s->instance);
    entry_free(s);
}

VkResult vk_queue_submit(cv_backend_device *bd, vk_queue_slot slot, const VkSubmitInfo2 *submit) {
    vk_queue *q = &bd->queues[slot];
    if (q->lock)
        pthread_mutex_lock(q->lock);
    VkResult vr = vkQueueSubmit2(q->queue, 1, submit, VK_NULL_HANDLE);
    if (q->lock)
        pthread_mutex_unlock(q->lock);
    return vr;
}
