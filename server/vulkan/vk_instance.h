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

cv_result vk_instance_acquire(bool validation, vk_instance **out);
void vk_instance_release(vk_instance *inst);

#endif
