/* The process's VkInstances: one plain, one with the validation layer. Devices
 * share them (reference counted); the last release destroys the instance. */
#ifndef CORVID_VK_INSTANCE_H
#define CORVID_VK_INSTANCE_H

#include "vk_common.h"

typedef struct vk_instance {
    VkInstance instance;
    bool validation;
    uint32_t refs;
    VkDebugUtilsMessengerEXT messenger;
    /* VK_EXT_debug_utils, only on the validated instance (NULL otherwise). */
    PFN_vkSetDebugUtilsObjectNameEXT set_object_name;
    PFN_vkCmdBeginDebugUtilsLabelEXT cmd_begin_label;
    PFN_vkCmdEndDebugUtilsLabelEXT cmd_end_label;
} vk_instance;

/* The process's plain or validated instance, made on first use; `sync`
 * counts only when it makes the validated one. */
cv_result vk_instance_acquire(bool validation, cv_vulkan_sync_validation sync, vk_instance **out);
void vk_instance_release(vk_instance *inst);

/* The validation layer (1.3.239) finds its state for a call in one map for the
 * whole process (the chassis' layer_data_map, keyed by dispatch table), which
 * it reads on every call and changes without a lock in vkCreateDevice and
 * vkDestroyDevice. A VkDevice created or destroyed on one thread while another
 * thread calls into any other VkDevice therefore races inside the layer. So
 * does vkFreeCommandBuffers (and vkDestroyCommandPool): it erases the buffers'
 * debug labels from a map of the instance, shared by all its devices, without
 * the lock vkCmdBeginDebugUtilsLabelEXT takes to add to it; a node session
 * freeing a command list while another recorded one crashed there
 * (node_remote_render under ASan, about 1 run in 6 in CI). So, on the
 * validated instance only, every Vulkan call runs inside vk_layer_enter/leave
 * (shared: the backend's table entries, the host waits slice by slice, the
 * bridge thread's signal), and vkCreateDevice, vkDestroyDevice,
 * vkFreeCommandBuffers and vkDestroyCommandPool inside
 * vk_layer_exclusive_begin/end (alone). enter/leave
 * nest on one thread; exclusive_begin may be called inside them (it gives the
 * thread's share up meanwhile). Lock order: a cv_device's lock, then this,
 * then every lock of this folder (the shared-device registry's, a device's
 * host lock, ...). No-ops on the plain instance. */
void vk_layer_enter(const vk_instance *inst);
/* Marks the calling thread as one whose calls must not wait for a device's
 * creation or destruction to begin (vk_bridge.c's threads; vk_instance.c says why). */
void vk_layer_urgent_thread(void);
void vk_layer_leave(const vk_instance *inst);
void vk_layer_exclusive_begin(const vk_instance *inst);
void vk_layer_exclusive_end(const vk_instance *inst);

#endif
