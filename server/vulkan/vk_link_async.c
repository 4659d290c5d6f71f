/* Asynchronous link copies (see vk_link.h, backend.h's link_copy_async). */
#include <stdlib.h>

#include "vk_bridge.h"
#include "vk_cross_wait.h"
#include "vk_host_transfer.h"
#include "vk_immediate.h"
#include "vk_link.h"
#include "vk_shared.h"

/* A command buffer of the async pool and the ticket of its latest use. */
typedef struct vk_async_cmd {
    VkCommandBuffer cmd;
    uint64_t ticket;
} vk_async_cmd;

/* The device's asynchronous copies: their pool, made at the first copy, and
 * command buffers, each free once its ticket finished. */
struct vk_link_async {
    VkCommandPool pool;
    vk_async_cmd *cmds;
    uint32_t count;
};

void vk_link_async_finish(cv_backend_device *bd) {
    vk_link_async *a = bd->async;
    if (!a)
        return;
    if (a->pool)
        vk_device_destroy_command_pool(bd, a->pool);
    free(a->cmds);
    free(a);
    bd->async = NULL;
}

/* A command buffer no submitted work uses (one of the pool's, or a new one). */
static cv_result take_cmd(cv_backend_device *bd, vk_async_cmd **out) {
    if (!bd->async && !(bd->async = calloc(1, sizeof(*bd->async))))
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "device '%s': asynchronous transfers", bd->label);
    vk_link_async *a = bd->async;
    if (!a->pool) {
        VkCommandPoolCreateInfo info = { .sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO,
                                         .flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT,
                                         .queueFamilyIndex = bd->queues[bd->link_slot].family };
        VkResult vr = vkCreateCommandPool(bd->device, &info, NULL, &a->pool);
        if (vr != VK_SUCCESS)
            return vk_fail(vr, "vkCreateCommandPool (asynchronous transfers, device '%s')", bd->label);
    }
    uint64_t done = vk_host_counter(bd, bd->ticket);
    for (uint32_t i = 0; i < a->count; i++)
        if (a->cmds[i].ticket <= done) {
            *out = &a->cmds[i];
            return CV_OK;
        }
    vk_async_cmd *grown = realloc(a->cmds, (a->count + 1) * sizeof(*grown));
    if (!grown)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "device '%s': asynchronous transfer command buffers", bd->label);
    a->cmds = grown;
    VkCommandBufferAllocateInfo alloc = { .sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO,
                                          .commandPool = a->pool,
                                          .level = VK_COMMAND_BUFFER_LEVEL_PRIMARY,
                                          .commandBufferCount = 1 };
    vk_async_cmd *c = &a->cmds[a->count];
    VkResult vr = vkAllocateCommandBuffers(bd->device, &alloc, &c->cmd);
    if (vr != VK_SUCCESS)
        return vk_fail(vr, "vkAllocateCommandBuffers (asynchronous transfers, device '%s')", bd->label);
    c->ticket = 0;
    a->count++;
    *out = c;
    return CV_OK;
}

/* take_cmd, then the command buffer reset and begun for one submission;
 * `what` names the transfer in the error. */
static cv_result begin_cmd(cv_backend_device *bd, vk_async_cmd **out, const char *what) {
    cv_result r = take_cmd(bd, out);
    if (r != CV_OK)
        return r;
    VkCommandBufferBeginInfo begin = { .sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO,
                                       .flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT };
    VkResult vr = vkResetCommandBuffer((*out)->cmd, 0);
    if (vr == VK_SUCCESS)
        vr = vkBeginCommandBuffer((*out)->cmd, &begin);
    if (vr != VK_SUCCESS)
        return vk_fail(vr, "vkBeginCommandBuffer (%s, device '%s')", what, bd->label);
    return CV_OK;
}

static VkSemaphoreSubmitInfo semaphore_info(VkSemaphore s, uint64_t value) {
    return (VkSemaphoreSubmitInfo){ .sType = VK_STRUCTURE_TYPE_SEMAPHORE_SUBMIT_INFO,
                                    .semaphore = s,
                                    .value = value,
                                    .stageMask = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT };
}

/* Appends to waits[*count] the wait for wait->device's ticket (none if it is
 * already reached, or no device): directly on the other device's semaphore
 * where both share one VkDevice (vk_shared.h), on its imported semaphore where
 * the pair allows, else through the bridge. `ticket`: bd's submission that waits. */
static cv_result cross_wait(cv_backend_device *bd, const cv_link_wait *wait, uint64_t ticket,
                            VkSemaphoreSubmitInfo *waits, uint32_t *count) {
    if (!wait || !wait->device || wait->device == bd)
        return CV_OK;
    if (vk_host_counter(wait->device, wait->device->ticket) >= wait->ticket)
        return CV_OK;
    VkSemaphore imported = VK_NULL_HANDLE;
    uint64_t value = 0;
    cv_result r = CV_OK;
    if (vk_device_same(bd, wait->device))
        imported = wait->device->ticket;
    else if (vk_cross_wait_direct(bd, wait->device))
        r = vk_cross_wait_semaphore(bd, wait->device, ticket, &imported);
    if (r == CV_OK && !imported)
        r = vk_bridge_request(bd, wait->device, wait->ticket, &value);
    if (r == CV_OK)
        waits[(*count)++] = imported ? semaphore_info(imported, wait->ticket)
                                     : semaphore_info(vk_bridge_semaphore(bd), value);
    return r;
}

cv_result vk_link_wait(cv_backend_device *bd, const cv_link_wait *wait, uint64_t ticket) {
    /* An empty submission: after the device's previous ticket and host writes,
     * and after the other device's ticket; later work waits for this one. */
    cv_result r = vk_immediate_flush(bd); /* images created since the last submission get their first layout */
    VkSemaphoreSubmitInfo waits[3];
    uint32_t wait_count = 0;
    waits[wait_count++] = semaphore_info(bd->ticket, ticket - 1);
    if (bd->immediate_value)
        waits[wait_count++] = semaphore_info(bd->immediate, bd->immediate_value);
    if (r == CV_OK)
        r = cross_wait(bd, wait, ticket, waits, &wait_count);
    if (r != CV_OK)
        return r;
    VkSemaphoreSubmitInfo signal = semaphore_info(bd->ticket, ticket);
    VkSubmitInfo2 submit = { .sType = VK_STRUCTURE_TYPE_SUBMIT_INFO_2,
                             .waitSemaphoreInfoCount = wait_count,
                             .pWaitSemaphoreInfos = waits,
                             .signalSemaphoreInfoCount = 1,
                             .pSignalSemaphoreInfos = &signal };
    VkResult vr = vk_queue_submit(bd, bd->link_slot, &submit);
    if (vr != VK_SUCCESS)
        return vk_fail(vr, "vkQueueSubmit2 (GPU wait for device '%s', ticket %llu, device '%s')",
                       wait && wait->device ? wait->device->label : "?", (unsigned long long)ticket, bd->label);
    if (ticket > bd->last_ticket)
        bd->last_ticket = ticket;
    return CV_OK;
}

cv_result vk_link_copy_async(cv_backend_device *bd, void *staging, uint64_t staging_offset, cv_handle_type type,
                             void *obj, uint64_t offset, uint64_t size, cv_rect rect, bool to_staging,
                             const cv_link_wait *wait, uint64_t ticket) {
    cv_result r = vk_link_in_range(bd, staging, staging_offset, type, obj, size, rect);
    if (r == CV_OK) /* images created since the last submission get their first layout */
        r = vk_immediate_flush(bd);
    vk_async_cmd *c = NULL;
    if (r == CV_OK)
        r = begin_cmd(bd, &c, "asynchronous transfer");
    if (r != CV_OK)
        return r;
    vk_link_record(bd, c->cmd, bd->link_slot, staging, staging_offset, type, obj, offset, size, rect, to_staging);
    /* Writes into the staging reach the other device (through host memory
     * for HOST stagings) before the ticket signals. */
    VkMemoryBarrier2 out = { .sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER_2,
                             .srcStageMask = VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT,
                             .srcAccessMask = VK_ACCESS_2_TRANSFER_WRITE_BIT,
                             .dstStageMask = VK_PIPELINE_STAGE_2_HOST_BIT,
                             .dstAccessMask = VK_ACCESS_2_HOST_READ_BIT };
    VkDependencyInfo dep = { .sType = VK_STRUCTURE_TYPE_DEPENDENCY_INFO,
                             .memoryBarrierCount = 1,
                             .pMemoryBarriers = &out };
    if (to_staging)
        vkCmdPipelineBarrier2(c->cmd, &dep);
    VkResult vr = vkEndCommandBuffer(c->cmd);
    if (vr != VK_SUCCESS)
        return vk_fail(vr, "vkEndCommandBuffer (asynchronous transfer, device '%s')", bd->label);
    VkSemaphoreSubmitInfo waits[3];
    uint32_t wait_count = 0;
    waits[wait_count++] = semaphore_info(bd->ticket, ticket - 1);
    if (bd->immediate_value)
        waits[wait_count++] = semaphore_info(bd->immediate, bd->immediate_value);
    r = cross_wait(bd, wait, ticket, waits, &wait_count);
    if (r != CV_OK)
        return r;
    VkSemaphoreSubmitInfo signal = semaphore_info(bd->ticket, ticket);
    VkCommandBufferSubmitInfo cmd_info = { .sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_SUBMIT_INFO,
                                           .commandBuffer = c->cmd };
    VkSubmitInfo2 submit = { .sType = VK_STRUCTURE_TYPE_SUBMIT_INFO_2,
                             .waitSemaphoreInfoCount = wait_count,
                             .pWaitSemaphoreInfos = waits,
                             .commandBufferInfoCount = 1,
                             .pCommandBufferInfos = &cmd_info,
                             .signalSemaphoreInfoCount = 1,
                             .pSignalSemaphoreInfos = &signal };
    vr = vk_queue_submit(bd, bd->link_slot, &submit);
    if (vr != VK_SUCCESS)
        return vk_fail(vr, "vkQueueSubmit2 (asynchronous transfer, ticket %llu, device '%s')",
                       (unsigned long long)ticket, bd->label);
    c->ticket = ticket;
    if (ticket > bd->last_ticket)
        bd->last_ticket = ticket;
    return CV_OK;
}

/* ---- direct copies between instances of one shared VkDevice (backend.h: link_copy_device) ---- */

static cv_result device_region_check(const cv_backend_device *bd, cv_handle_type type, void *src_obj, void *dst_obj,
                                     const cv_link_region *g) {
    bool ok;
    if (type == CV_HANDLE_TEXTURE) {
        const vk_texture *s = src_obj, *d = dst_obj;
        const cv_rect *r = &g->src_rect;
        ok = s->format == d->format && r->x <= s->width && r->width <= s->width - r->x && r->y <= s->height &&
             r->height <= s->height - r->y && g->dst_x <= d->width && r->width <= d->width - g->dst_x &&
             g->dst_y <= d->height && r->height <= d->height - g->dst_y;
    } else {
        const vk_buffer *s = src_obj, *d = dst_obj;
        ok = g->src_offset <= s->size && g->size <= s->size - g->src_offset && g->dst_offset <= d->size &&
             g->size <= d->size - g->dst_offset;
    }
    return ok ? CV_OK
              : cv_error(CV_ERROR_OUT_OF_RANGE, "device '%s': a direct copy out of range of its resources",
                         bd->label);
}

cv_result vk_link_copy_device(cv_backend_device *bd, cv_backend_device *dst_bd, cv_handle_type type, void *src_obj,
                              void *dst_obj, const cv_link_region *region, uint64_t dst_wait, uint64_t ticket,
                              uint64_t dst_ticket) {
    if (!vk_device_same(bd, dst_bd))
        return cv_error(CV_ERROR_UNSUPPORTED, "devices '%s' and '%s' do not share a VkDevice", bd->label,
                        dst_bd->label);
    cv_result r = device_region_check(bd, type, src_obj, dst_obj, region);
    /* Images created since the last submission get their first layout (both ends). */
    if (r == CV_OK)
        r = vk_immediate_flush(bd);
    if (r == CV_OK)
        r = vk_immediate_flush(dst_bd);
    vk_async_cmd *c = NULL;
    if (r == CV_OK)
        r = begin_cmd(bd, &c, "direct transfer");
    if (r != CV_OK)
        return r;
    /* Images rest in GENERAL between operations; the semaphore waits below order
     * (and make visible) every earlier use of both resources. */
    if (type == CV_HANDLE_TEXTURE) {
        const vk_texture *s = src_obj, *d = dst_obj;
        const cv_rect *sr = &region->src_rect;
        VkImageCopy copy = { .srcSubresource = { s->aspect, 0, 0, 1 },
                             .srcOffset = { (int32_t)sr->x, (int32_t)sr->y, 0 },
                             .dstSubresource = { d->aspect, 0, 0, 1 },
                             .dstOffset = { (int32_t)region->dst_x, (int32_t)region->dst_y, 0 },
                             .extent = { sr->width, sr->height, 1 } };
        const VkPipelineStageFlags2 all = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT,
                                    copies = VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT;
        const VkAccessFlags2 memory = VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT;
        vk_image_transition(c->cmd, s, VK_IMAGE_LAYOUT_GENERAL, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, all, 0, copies,
                            VK_ACCESS_2_TRANSFER_READ_BIT);
        vk_image_transition(c->cmd, d, VK_IMAGE_LAYOUT_GENERAL, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, all, 0, copies,
                            VK_ACCESS_2_TRANSFER_WRITE_BIT);
        vkCmdCopyImage(c->cmd, s->image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, d->image,
                       VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &copy);
        vk_image_transition(c->cmd, s, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, VK_IMAGE_LAYOUT_GENERAL, copies, 0, all,
                            memory);
        vk_image_transition(c->cmd, d, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_IMAGE_LAYOUT_GENERAL, copies,
                            VK_ACCESS_2_TRANSFER_WRITE_BIT, all, memory);
    } else {
        const vk_buffer *s = src_obj, *d = dst_obj;
        VkBufferCopy copy = { region->src_offset, region->dst_offset, region->size };
        vkCmdCopyBuffer(c->cmd, s->buffer, d->buffer, 1, &copy);
    }
    VkResult vr = vkEndCommandBuffer(c->cmd);
    if (vr != VK_SUCCESS)
        return vk_fail(vr, "vkEndCommandBuffer (direct transfer, device '%s')", bd->label);
    /* The copy: after the source's earlier work and host writes, and after the
     * destination's last use of its resource and its host writes; all on one
     * VkDevice, so the other instance's semaphores are waited on directly. */
    VkSemaphoreSubmitInfo waits[4];
    uint32_t wait_count = 0;
    waits[wait_count++] = semaphore_info(bd->ticket, ticket - 1);
    if (bd->immediate_value)
        waits[wait_count++] = semaphore_info(bd->immediate, bd->immediate_value);
    if (dst_wait)
        waits[wait_count++] = semaphore_info(dst_bd->ticket, dst_wait);
    if (dst_bd->immediate_value)
        waits[wait_count++] = semaphore_info(dst_bd->immediate, dst_bd->immediate_value);
    VkSemaphoreSubmitInfo signal = semaphore_info(bd->ticket, ticket);
    VkCommandBufferSubmitInfo cmd_info = { .sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_SUBMIT_INFO,
                                           .commandBuffer = c->cmd };
    VkSubmitInfo2 submit = { .sType = VK_STRUCTURE_TYPE_SUBMIT_INFO_2,
                             .waitSemaphoreInfoCount = wait_count,
                             .pWaitSemaphoreInfos = waits,
                             .commandBufferInfoCount = 1,
                             .pCommandBufferInfos = &cmd_info,
                             .signalSemaphoreInfoCount = 1,
                             .pSignalSemaphoreInfos = &signal };
    vr = vk_queue_submit(bd, bd->link_slot, &submit);
    if (vr != VK_SUCCESS)
        return vk_fail(vr, "vkQueueSubmit2 (direct transfer '%s' -> '%s', ticket %llu)", bd->label, dst_bd->label,
                       (unsigned long long)ticket);
    c->ticket = ticket;
    bd->last_ticket = ticket;
    /* The destination's ticket: an empty submission that waits for the copy, so
     * the destination's later work (which waits for its previous ticket) follows it. */
    VkSemaphoreSubmitInfo marker_waits[2] = { semaphore_info(dst_bd->ticket, dst_ticket - 1),
                                              semaphore_info(bd->ticket, ticket) };
    VkSemaphoreSubmitInfo marker_signal = semaphore_info(dst_bd->ticket, dst_ticket);
    VkSubmitInfo2 marker = { .sType = VK_STRUCTURE_TYPE_SUBMIT_INFO_2,
                             .waitSemaphoreInfoCount = 2,
                             .pWaitSemaphoreInfos = marker_waits,
                             .signalSemaphoreInfoCount = 1,
                             .pSignalSemaphoreInfos = &marker_signal };
    vr = vk_queue_submit(dst_bd, dst_bd->link_slot, &marker);
    if (vr != VK_SUCCESS) /* the source's ticket was used: only a lost device fails here */
        return vk_fail(vr, "vkQueueSubmit2 (direct transfer '%s' -> '%s', destination ticket %llu)", bd->label,
                       dst_bd->label, (unsigned long long)dst_ticket);
    dst_bd->last_ticket = dst_ticket;
    return CV_OK;
}
