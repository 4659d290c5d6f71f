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
    bool zeroed; /* reads as zeros: fresh pages of an imported block, never handed out before */
} vk_allocation;

typedef struct vk_memory {
    VkDevice device;
    VkPhysicalDeviceMemoryProperties properties;
    VkDeviceSize block_size;
    VkDeviceSize atom;   /* nonCoherentAtomSize */
    bool device_address; /* linear blocks allocated with VK_MEMORY_ALLOCATE_DEVICE_ADDRESS_BIT
                                  (set when the device enables bufferDeviceAddress) */
    /* Host import (vk_memory_enable_host_import): blocks of these memory types are anonymous mappings of
     * our own, imported; 0 = none. */
    uint32_t host_import_types;
    VkDeviceSize host_import_alignment;
    PFN_vkGetMemoryHostPointerPropertiesEXT host_pointer_properties;
    pthread_mutex_t lock;
    vk_block *blocks[VK_MAX_MEMORY_TYPES][2]; /* per type and kind, linked */
    uint32_t block_count, allocation_count;
    uint64_t block_bytes, allocated_bytes;
} vk_memory;

void vk_memory_init(vk_memory *m, VkDevice device, VkPhysicalDevice physical);

/* Fresh memory for free. A new resource must read as zeros, and zeroing costs
 * a pass over its bytes. Where the device's own memory is host memory that it
 * can import (lavapipe: VK_EXT_external_memory_host into the memory type its
 * resources use), blocks become anonymous mappings of our own, imported: the
 * kernel hands their pages out as zeros, so a range of a block that was never
 * handed out needs no zeroing (vk_allocation.zeroed; a block keeps the
 * watermark below which ranges have been used). Every buffer and image is
 * then created with the host-allocation handle type (vk_memory_buffer_external,
 * vk_memory_image_external), as binding to imported memory requires; the
 * caller has checked that every kind of buffer and image it makes can be
 * (vk_resources_host_import_ok). Enables it only if a probe import lands in
 * the memory type device-local allocations choose; returns whether it did.
 * Call before the first allocation. */
bool vk_memory_enable_host_import(vk_memory *m, PFN_vkGetMemoryHostPointerPropertiesEXT properties,
                                  VkDeviceSize alignment);
/* The pNext for VkBufferCreateInfo / VkImageCreateInfo that host import needs, or NULL. */
const void *vk_memory_buffer_external(const vk_memory *m);
const void *vk_memory_image_external(const vk_memory *m);
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
