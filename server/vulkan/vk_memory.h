/* Device memory sub-allocation: resources take ranges of large VkDeviceMemory
 * blocks instead of one vkAllocateMemory each (drivers limit the number of
 * allocations, and each one is slow). */
#ifndef CORVID_VK_MEMORY_H
#define CORVID_VK_MEMORY_H

#include <pthread.h>

#include "vk_common.h"

typedef struct vk_block vk_block;

/* Buffers and optimally tiled images live in separate blocks, so no range
 * needs bufferImageGranularity padding. */
typedef enum vk_memory_kind { VK_MEMORY_LINEAR = 0, VK_MEMORY_OPTIMAL = 1 } vk_memory_kind;

typedef struct vk_allocation {
    vk_block *block;
    VkDeviceMemory memory;
    VkDeviceSize offset, size;
    void *mapped; /* host pointer to offset, NULL if not host-visible */
    bool coherent;
} vk_allocation;

typedef struct vk_memory {
    VkDevice device;
    VkPhysicalDeviceMemoryProperties properties;
    VkDeviceSize block_size;
    VkDeviceSize atom;   /* nonCoherentAtomSize */
    bool device_address; /* linear blocks allocated with VK_MEMORY_ALLOCATE_DEVICE_ADDRESS_BIT
                                  (set when the device enables bufferDeviceAddress) */
    pthread_mutex_t lock;
    vk_block *blocks[VK_MAX_MEMORY_TYPES][2]; /* per type and kind, linked */
    uint32_t block_count, allocation_count;
    uint64_t block_bytes, allocated_bytes;
} vk_memory;

void vk_memory_init(vk_memory *m, VkDevice device, VkPhysicalDevice physical);
/* Frees every block (all allocations must have been freed). */
void vk_memory_finish(vk_memory *m);

/* Allocates for `req` from a memory type having all of `required` flags,
 * preferring types that have `preferred` and no flags beyond required|preferred. */
cv_result vk_memory_alloc(vk_memory *m, const VkMemoryRequirements *req, VkMemoryPropertyFlags required,
                          VkMemoryPropertyFlags preferred, vk_memory_kind kind, const char *what, vk_allocation *out);
void vk_memory_free(vk_memory *m, vk_allocation *a);

/* Makes host writes to a non-coherent mapping visible to the device, and
 * device writes visible to the host (no-ops on coherent memory). */
void vk_memory_flush(vk_memory *m, const vk_allocation *a, VkDeviceSize offset, VkDeviceSize size);
void vk_memory_invalidate(vk_memory *m, const vk_allocation *a, VkDeviceSize offset, VkDeviceSize size);

void vk_memory_stats(vk_memory *m, cv_vulkan_memory_stats *out);

#endif
