/* The immediate command buffer and the batch of images awaiting their first
 * layout transition (see vk_immediate.h). */
#include <stdlib.h>
#include <string.h>

#include "vk_bridge.h"
#include "vk_immediate.h"
#include "vk_resources.h"
#include "vk_shared.h"

cv_result vk_immediate_init(cv_backend_device *bd) {
    VkCommandPoolCreateInfo pool_info = {
        .sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO,
        .flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT | VK_COMMAND_POOL_CREATE_TRANSIENT_BIT,
        .queueFamilyIndex = bd->queues[VK_SLOT_GRAPHICS].family,
    };
    VkResult vr = vkCreateCommandPool(bd->device, &pool_info, NULL, &bd->immediate_pool);
    if (vr != VK_SUCCESS)
        return vk_fail(vr, "vkCreateCommandPool (immediate)");
    VkCommandBufferAllocateInfo alloc = { .sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO,
                                          .commandPool = bd->immediate_pool,
                                          .level = VK_COMMAND_BUFFER_LEVEL_PRIMARY,
                                          .commandBufferCount = 1 };
    vr = vkAllocateCommandBuffers(bd->device, &alloc, &bd->immediate_cmd);
    if (vr != VK_SUCCESS)
        return vk_fail(vr, "vkAllocateCommandBuffers (immediate)");
    return vk_device_create_timeline(bd, &bd->immediate, "immediate");
}

void vk_immediate_finish(cv_backend_device *bd) {
    vkDestroySemaphore(bd->device, bd->immediate, NULL);
    vk_device_destroy_command_pool(bd, bd->immediate_pool);
    free(bd->pending_images);
    bd->pending_images = NULL;
    bd->pending_count = bd->pending_capacity = 0;
}

static void record_pending(cv_backend_device *bd, VkCommandBuffer cmd) {
    if (!bd->pending_count)
        return;
    VkImageMemoryBarrier2 barriers[64];
    uint32_t done = 0;
    while (done < bd->pending_count) {
        uint32_t n = 0;
        for (; n < 64 && done < bd->pending_count; n++, done++) {
            vk_texture *t = bd->pending_images[done];
            t->pending = false;
            barriers[n] = (VkImageMemoryBarrier2){
                .sType = VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER_2,
                .srcStageMask = VK_PIPELINE_STAGE_2_NONE,
                .dstStageMask = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT,
                .dstAccessMask = VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT,
                .oldLayout = VK_IMAGE_LAYOUT_UNDEFINED,
                .newLayout = VK_IMAGE_LAYOUT_GENERAL,
                .srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED,
                .dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED,
                .image = t->image,
                .subresourceRange = { t->aspect, 0, 1, 0, 1 },
            };
        }
        VkDependencyInfo dep = { .sType = VK_STRUCTURE_TYPE_DEPENDENCY_INFO,
                                 .imageMemoryBarrierCount = n,
                                 .pImageMemoryBarriers = barriers };
        vkCmdPipelineBarrier2(cmd, &dep);
    }
    bd->pending_count = 0;
}

cv_result vk_immediate_begin(cv_backend_device *bd, VkCommandBuffer *out) {
    VkResult vr = vkResetCommandBuffer(bd->immediate_cmd, 0);
    if (vr != VK_SUCCESS)
        return vk_fail(vr, "vkResetCommandBuffer (immediate)");
    VkCommandBufferBeginInfo begin = { .sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO,
                                       .flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT };
    vr = vkBeginCommandBuffer(bd->immediate_cmd, &begin);
    if (vr != VK_SUCCESS)
        return vk_fail(vr, "vkBeginCommandBuffer (immediate)");
    record_pending(bd, bd->immediate_cmd);
    *out = bd->immediate_cmd;
    return CV_OK;
}

cv_result vk_immediate_end(cv_backend_device *bd) {
    /* Make the work's writes visible to the host (staging reads) before it signals. */
    VkMemoryBarrier2 to_host = {
        .sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER_2,
        .srcStageMask = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT,
        .srcAccessMask = VK_ACCESS_2_MEMORY_WRITE_BIT,
        .dstStageMask = VK_PIPELINE_STAGE_2_HOST_BIT,
        .dstAccessMask = VK_ACCESS_2_HOST_READ_BIT | VK_ACCESS_2_HOST_WRITE_BIT,
    };
    VkDependencyInfo dep = { .sType = VK_STRUCTURE_TYPE_DEPENDENCY_INFO,
                             .memoryBarrierCount = 1,
                             .pMemoryBarriers = &to_host };
    vkCmdPipelineBarrier2(bd->immediate_cmd, &dep);
    VkResult vr = vkEndCommandBuffer(bd->immediate_cmd);
    if (vr != VK_SUCCESS)
        return vk_fail(vr, "vkEndCommandBuffer (immediate)");
    /* Waiting on the ticket value already reached costs nothing but orders this
     * work after the writes of every finished list (a memory dependency). */
    uint64_t finished = vk_host_counter(bd, bd->ticket);
    VkSemaphoreSubmitInfo wait = { .sType = VK_STRUCTURE_TYPE_SEMAPHORE_SUBMIT_INFO,
                                   .semaphore = bd->ticket,
                                   .value = finished,
                                   .stageMask = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT };
    VkSemaphoreSubmitInfo signal = { .sType = VK_STRUCTURE_TYPE_SEMAPHORE_SUBMIT_INFO,
                                     .semaphore = bd->immediate,
                                     .value = bd->immediate_value + 1,
                                     .stageMask = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT };
    VkCommandBufferSubmitInfo cmd_info = { .sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_SUBMIT_INFO,
                                           .commandBuffer = bd->immediate_cmd };
    VkSubmitInfo2 submit = { .sType = VK_STRUCTURE_TYPE_SUBMIT_INFO_2,
                             .waitSemaphoreInfoCount = 1,
                             .pWaitSemaphoreInfos = &wait,
                             .commandBufferInfoCount = 1,
                             .pCommandBufferInfos = &cmd_info,
                             .signalSemaphoreInfoCount = 1,
                             .pSignalSemaphoreInfos = &signal };
    vr = vk_queue_submit(bd, VK_SLOT_GRAPHICS, &submit);
    if (vr != VK_SUCCESS)
        return vk_fail(vr, "vkQueueSubmit2 (immediate, device '%s')", bd->label);
    bd->immediate_value++;
    VkSemaphoreWaitInfo wait_info = { .sType = VK_STRUCTURE_TYPE_SEMAPHORE_WAIT_INFO,
                                      .semaphoreCount = 1,
                                      .pSemaphores = &bd->immediate,
                                      .pValues = &bd->immediate_value };
    vr = vk_host_wait(bd, &wait_info, UINT64_MAX);
    return vr == VK_SUCCESS ? CV_OK : vk_fail(vr, "vkWaitSemaphores (immediate, device '%s')", bd->label);
}

cv_result vk_immediate_flush(cv_backend_device *bd) {
    if (!bd->pending_count)
        return CV_OK;
    VkCommandBuffer cmd;
    cv_result r = vk_immediate_begin(bd, &cmd);
    return r == CV_OK ? vk_immediate_end(bd) : r;
}

cv_result vk_immediate_add_image(cv_backend_device *bd, vk_texture *tex) {
    if (bd->pending_count == bd->pending_capacity) {
        uint32_t cap = bd->pending_capacity ? bd->pending_capacity * 2 : 64;
        vk_texture **grown = realloc(bd->pending_images, cap * sizeof(*grown));
        if (!grown)
            return cv_error(CV_ERROR_OUT_OF_MEMORY, "vulkan: pending image list of %u", cap);
        bd->pending_images = grown;
        bd->pending_capacity = cap;
    }
    tex->pending = true;
    bd->pending_images[bd->pending_count++] = tex;
    return CV_OK;
}

void vk_immediate_forget_image(cv_backend_device *bd, vk_texture *tex) {
    if (!tex->pending)
        return;
    for (uint32_t i = bd->pending_count; i-- > 0;)
        if (bd->pending_images[i] == tex) {
            bd->pending_images[i] = bd->pending_images[--bd->pending_count];
            break;
        }
    tex->pending = false;
}
