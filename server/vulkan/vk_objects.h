/* The device objects behind buffer, texture and sampler handles, below the
 * modules that create them (vk_resources.h) and the one that initialises them
 * (vk_immediate.h). */
#ifndef CORVID_VK_OBJECTS_H
#define CORVID_VK_OBJECTS_H

#include "vk_memory.h"

typedef struct vk_buffer vk_buffer;
typedef struct vk_texture vk_texture;

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

#endif
