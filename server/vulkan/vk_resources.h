/* Buffers, 2D textures and samplers: the device objects behind handles. */
#ifndef CORVID_VK_RESOURCES_H
#define CORVID_VK_RESOURCES_H

#include "vk_device_core.h"
#include "vk_objects.h"

/* Whether every buffer and image kind can live in imported host memory (vk_memory.h). */
bool vk_resources_host_import_ok(const cv_backend_device *bd);

/* The Vulkan format of a Corvid format (VK_FORMAT_UNDEFINED if none). */
VkFormat vk_format_of(cv_format f);

cv_result vk_buffer_create(cv_backend_device *bd, const cv_buffer_desc *desc, vk_buffer **out);
/* A device-local buffer with Vulkan usage flags of the caller's choosing and a
 * minimum memory alignment (0 = the driver's); gets a device address when the
 * usage asks for one. For the backend's internal buffers. */
cv_result vk_buffer_create_raw(cv_backend_device *bd, VkDeviceSize size, VkBufferUsageFlags usage,
                               VkDeviceSize alignment, const char *label, vk_buffer **out);
/* The same in host-visible memory (memory.mapped is set), for results the host reads. */
cv_result vk_buffer_create_host(cv_backend_device *bd, VkDeviceSize size, VkBufferUsageFlags usage, const char *label,
                                vk_buffer **out);
void vk_buffer_destroy(cv_backend_device *bd, vk_buffer *b);
/* CV_ERROR_UNSUPPORTED if the adapter's format lacks a feature a usage needs. */
cv_result vk_texture_create(cv_backend_device *bd, const cv_texture_desc *desc, vk_texture **out);
void vk_texture_destroy(cv_backend_device *bd, vk_texture *t);
/* bd's texture over the memory of `src`, src_bd's texture of the same
 * description (backend.h: resource_alias): an image of identical parameters
 * bound to src's exported memory, imported on bd. Both images get their first
 * layout now. CV_ERROR_UNSUPPORTED if src is not exportable or the devices
 * cannot share it. */
cv_result vk_texture_alias(cv_backend_device *bd, const cv_texture_desc *desc, cv_backend_device *src_bd,
                           vk_texture *src, vk_texture **out);
cv_result vk_sampler_create(cv_backend_device *bd, const cv_sampler_desc *desc, vk_sampler **out);
void vk_sampler_destroy(cv_backend_device *bd, vk_sampler *s);

#endif
