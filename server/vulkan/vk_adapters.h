/* Adapter enumeration: every physical device with its capabilities, the queue
 * families a device on it would use, and whether it meets our requirements. */
#ifndef CORVID_VK_ADAPTERS_H
#define CORVID_VK_ADAPTERS_H

#include "vk_instance.h"

#define VK_NO_FAMILY UINT32_MAX

typedef struct vk_adapter {
    VkPhysicalDevice physical;
    cv_vulkan_adapter_info info;
    uint32_t graphics_family;    /* graphics + compute */
    uint32_t compute_family;     /* compute without graphics, or VK_NO_FAMILY */
    uint32_t copy_family;        /* transfer only, or VK_NO_FAMILY */
    bool storage_without_format; /* shaderStorageImageRead/WriteWithoutFormat */
} vk_adapter;

/* All adapters of an instance (malloc'ed array; free() it). */
cv_result vk_adapters_enumerate(const vk_instance *inst, vk_adapter **out, uint32_t *count);
/* Index of the adapter a spec names (see cv_vulkan_find_adapter). */
cv_result vk_adapters_resolve(const vk_adapter *adapters, uint32_t count, const char *spec, uint32_t *index);
/* Index of the best usable adapter for a purpose, or CV_ERROR_NOT_FOUND. */
cv_result vk_adapters_choose(const vk_adapter *adapters, uint32_t count, cv_vulkan_purpose purpose, uint32_t *index);

#endif
