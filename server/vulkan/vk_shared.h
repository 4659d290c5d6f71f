/* Virtual GPUs that share one VkDevice (cv_vulkan_device_options.vgpu_device SHARED).
 *
 * By default every cv_device is its own VkDevice, so the virtual GPUs of one
 * adapter are separate contexts, which a GPU like the H200 time-slices (they
 * never run concurrently). In shared mode the instances of one adapter in one
 * process share one VkDevice, found or created here in a small refcounted
 * registry keyed by (vk_instance, physical device, enabled extension set);
 * the validation setting is the vk_instance's. Queues of one VkDevice do run
 * concurrently.
 *
 *     cv_backend_device *bd = ...;  // adapter chosen, bd->vgpu_shared set
 *     VkDeviceCreateInfo info = ...;  // every queue of each family used (<= VK_SHARED_MAX_QUEUES)
 *     vk_shared_acquire(bd, &info, &bd->shared, &bd->shared_slot);  // bd->device = shared->device
 *     ...
 *     vk_shared_release(bd->shared, bd->shared_slot);  // the last one destroys the VkDevice
 *
 * What is shared: the VkDevice and its queues, one mutex per queue (Vulkan
 * requires external synchronisation of vkQueueSubmit; held around every submit
 * of every instance of the shared device), and the host lock that serialises
 * semaphore host waits under the validation layer (vk_bridge.h: the layer's
 * lock is per VkDevice), and the pipelines: a VkPipeline is immutable and
 * usable by every queue of its VkDevice, so the instances share one per
 * registry entry (vk_pipelines.c builds it for the first instance that asks
 * and destroys it with the last reference; the 2nd..Nth virtual GPU of an
 * adapter costs no shader compilation). Everything else stays per instance
 * (command pools, semaphores, memory allocator, immediate command buffer,
 * tracer, resources; the tracer's compute traversal pipeline is shared,
 * its ray-tracing pipeline is not).
 *
 * Queue rule: an instance takes the lowest free slot k of its shared device
 * and uses queue index k % queueCount in every family it uses (lavapipe: every
 * instance shares its one queue).
 *
 * Instances of one shared VkDevice copy between each other's resources
 * directly (vk_link.h's vk_link_copy_device: transfer.h's DEVICE path;
 * cv_link_caps.device_group is the registry entry's address), and
 * cv_device_info.cross_wait says "device".
 *
 * Ticket semaphores of a shared device's instances are waited on directly by
 * the other instances (no import, no bridge), so a destroyed instance's ticket
 * semaphore may still be referenced by another instance's pending submission:
 * vk_shared_retire keeps it until the VkDevice goes. */
#ifndef CORVID_VK_SHARED_H
#define CORVID_VK_SHARED_H

#include <pthread.h>

#include "vk_device_core.h"

#define VK_SHARED_MAX_QUEUES 16u

/* One pipeline shared by the instances of a shared VkDevice (vk_pipelines.c). */
typedef struct vk_shared_pipeline {
    struct vk_shared_pipeline *next;
    cv_pipeline_info info; /* the key: the creating entry's contents */
    vk_pipeline *pipeline;
    uint32_t refs;
} vk_shared_pipeline;

struct vk_shared_device {
    struct vk_shared_device *next; /* in the registry */
    vk_instance *instance;
    VkPhysicalDevice physical;
    uint32_t extensions; /* key: a hash of the enabled extension names */
    VkDevice device;
    uint32_t refs;
    uint64_t slots; /* bit k: slot k taken */
    pthread_mutex_t queue_locks[VK_SLOT_COUNT][VK_SHARED_MAX_QUEUES];
    pthread_mutex_t host_lock;     /* vk_bridge.h's host lock, for every instance */
    pthread_mutex_t pipeline_lock; /* guards `pipelines`; held while one is built */
    vk_shared_pipeline *pipelines;
    VkSemaphore *retired; /* ticket semaphores of destroyed instances */
    uint32_t retired_count;
};

/* CV_VULKAN_VGPU_AUTO's choice (vulkan.h) for an adapter: its graphics family has more than one queue. */
bool vk_shared_auto_choice(VkPhysicalDevice physical, uint32_t graphics_family);

/* Finds the shared VkDevice for bd's instance, adapter and info's extensions,
 * or creates it from info; takes a slot. On failure nothing is held. */
cv_result vk_shared_acquire(cv_backend_device *bd, const VkDeviceCreateInfo *info, vk_shared_device **out,
                            uint32_t *slot);
/* Gives the slot back; the last reference destroys the retired semaphores and the VkDevice. */
void vk_shared_release(vk_shared_device *s, uint32_t slot);
/* Keeps a destroyed instance's ticket semaphore until the VkDevice goes (see above). */
void vk_shared_retire(vk_shared_device *s, VkSemaphore semaphore);

/* vkQueueSubmit2 on bd's queue of `slot`, under the queue's mutex where the VkDevice is shared. */
VkResult vk_queue_submit(cv_backend_device *bd, vk_queue_slot slot, const VkSubmitInfo2 *submit);

#endif
