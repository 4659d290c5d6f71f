/* Host <-> device data for buffers and textures (the backend's read/write
 * calls). Synchronous; the core calls them only when no submitted work uses
 * the resource. */
#ifndef CORVID_VK_HOST_TRANSFER_H
#define CORVID_VK_HOST_TRANSFER_H

#include "vk_resources.h"

cv_result vk_host_buffer_write(cv_backend_device *bd, vk_buffer *b, uint64_t offset, uint64_t size, const void *data);
cv_result vk_host_buffer_read(cv_backend_device *bd, vk_buffer *b, uint64_t offset, uint64_t size, void *out);
/* Texture data is tightly packed rows of rect.width texels. */
cv_result vk_host_texture_write(cv_backend_device *bd, vk_texture *t, cv_rect rect, const void *data);
cv_result vk_host_texture_read(cv_backend_device *bd, vk_texture *t, cv_rect rect, void *out);

/* Records a copy of rect between the image and tightly packed rows at
 * buffer_offset of buffer; the image rests in VK_IMAGE_LAYOUT_GENERAL and is
 * moved to the transfer layout for the copy (barriers on both sides). */
void vk_record_texture_rows(VkCommandBuffer cmd, const vk_texture *t, VkBuffer buffer, VkDeviceSize buffer_offset,
                            cv_rect rect, bool to_image);

/* One image layout transition barrier over the whole of t. */
void vk_image_transition(VkCommandBuffer cmd, const vk_texture *t, VkImageLayout from, VkImageLayout to,
                         VkPipelineStageFlags2 src_stage, VkAccessFlags2 src_access, VkPipelineStageFlags2 dst_stage,
                         VkAccessFlags2 dst_access);

#endif
