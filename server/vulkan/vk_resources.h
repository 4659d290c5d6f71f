/* Buffers, 2D textures and samplers: the device objects behind handles. */
#ifndef CORVID_VK_RESOURCES_H
#define CORVID_VK_RESOURCES_H

#include "vk_device.h"

struct vk_buffer {
    VkBuffer buffer;
    vk_allocation memory;
    VkDeviceSize size;
    VkDeviceAddress address; /* storage buffers: where kernels find it (trace_rays); else 0 */
    bool pending;            /* awaiting its zero fill on the GPU (vk_immediate.h) */
};

struct vk_texture {
    VkImage image;
    VkImageView view;
    vk_allocation memory;
    VkFormat format;
    VkImageAspectFlags aspect;
    uint32_t width, height, texel_bytes;
    bool pending; /* awaiting its first layout transition (vk_immediate.h) */
    bool clear;   /* ... and its zero clear: a new image, not an alias of another device's */
    /* Shareable (CV_TEXTURE_USAGE_SHARED on a device that can export): a
     * dedicated opaque-fd VkDeviceMemory of its own (`own_memory`, not from the
     * block allocator), which aliases on other devices import. Aliases own
     * their import likewise. */
    bool exportable;
    VkDeviceMemory own_memory;
    VkDeviceSize allocation_size;
    uint32_t memory_type;
};

typedef struct vk_sampler {
    VkSampler sampler;
} vk_sampler;

/* A layout transition barrier over the whole of t. */
VkImageMemoryBarrier2 vk_image_barrier(const vk_texture *t, VkImageLayout from, VkImageLayout to,
                                       VkPipelineStageFlags2 src_stage, VkAccessFlags2 src_access,
                                       VkPipelineStageFlags2 dst_stage, VkAccessFlags2 dst_access);

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
