/* Compilation of a validated command list into Vulkan command buffers.
 *
 * Commands are grouped into segments by the queue they run on (their queue
 * type, mapped to the device's queues; commands that touch depth textures and
 * everything inside a render pass run on the graphics queue; markers,
 * timestamps and barrier hints stay with the work around them). Adjacent
 * commands on the same queue share one segment, so on a device with a single
 * queue every list is one command buffer. Segments are submitted in order,
 * each waiting for the previous one (vk_submit.h). */
#ifndef CORVID_VK_COMPILE_H
#define CORVID_VK_COMPILE_H

#include "vk_device_core.h"
#include "vk_indirect.h"
#include "vk_timestamps.h"

typedef struct vk_segment {
    vk_queue_slot slot;
    VkCommandBuffer prologue; /* first layout transitions, or VK_NULL_HANDLE */
    VkCommandBuffer body;
} vk_segment;

typedef struct vk_compiled {
    vk_segment *segments;
    uint32_t segment_count;
    vk_timestamps timestamps;
    uint32_t barrier_count;     /* pipeline barriers recorded, for stats */
    vk_indirect_slots indirect; /* one per dispatch_indirect (vk_indirect.h) */
} vk_compiled;

cv_result vk_compile_list(cv_backend_device *bd, cv_device *dev, const cv_command_list *list, vk_compiled **out);
void vk_compiled_release(cv_backend_device *bd, vk_compiled *c);

#endif
