/* The immediate command buffer and the batch of new images and buffers
 * awaiting their first layout transition and zero fill (see vk_immediate.h). */
#include <stdlib.h>
#include <string.h>

#include "corvid/clock.h"
#include "vk_immediate.h"
#include "vk_objects.h"
#include "vk_shared.h"

/* One object awaiting its initialisation: an image or a buffer. */
struct vk_pending_init {
    vk_texture *image;
    vk_buffer *buffer;
};

/* The immediate command buffer, and the objects created and not yet
 * initialised: images still in VK_IMAGE_LAYOUT_UNDEFINED, buffers the host
 * cannot map not yet zeroed. */
struct vk_immediate {
    VkCommandPool pool;
    VkCommandBuffer cmd;
    struct vk_pending_init *pending;
    uint32_t pending_count, pending_capacity;
    uint64_t zero_started_ns; /* the submission being recorded zeroes something: its start */
};

cv_result vk_immediate_init(cv_backend_device *bd) {
    bd->imm = calloc(1, sizeof(*bd->imm));
    if (!bd->imm)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "device '%s': immediate command buffer", bd->label);
    VkCommandPoolCreateInfo pool_info = {
        .sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO,
        .flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT | VK_COMMAND_POOL_CREATE_TRANSIENT_BIT,
        .queueFamilyIndex = bd->queues[VK_SLOT_GRAPHICS].family,
    };
    VkResult vr = vkCreateCommandPool(bd->device, &pool_info, NULL, &bd->imm->pool);
    if (vr != VK_SUCCESS)
        return vk_fail(vr, "vkCreateCommandPool (immediate)");
    VkCommandBufferAllocateInfo alloc = { .sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO,
                                          .commandPool = bd->imm->pool,
                                          .level = VK_COMMAND_BUFFER_LEVEL_PRIMARY,
                                          .commandBufferCount = 1 };
    vr = vkAllocateCommandBuffers(bd->device, &alloc, &bd->imm->cmd);
    if (vr != VK_SUCCESS)
        return vk_fail(vr, "vkAllocateCommandBuffers (immediate)");
    return vk_device_create_timeline(bd, &bd->immediate, "immediate", false);
}

void vk_immediate_finish(cv_backend_device *bd) {
    vkDestroySemaphore(bd->device, bd->immediate, NULL);
    bd->immediate = VK_NULL_HANDLE;
    if (!bd->imm)
        return;
    if (bd->imm->pool)
        vk_device_destroy_command_pool(bd, bd->imm->pool);
    free(bd->imm->pending);
    free(bd->imm);
    bd->imm = NULL;
}

/* Image barriers recorded in batches of 64, with an optional memory barrier. */
typedef struct barrier_batch {
    VkImageMemoryBarrier2 images[64];
    uint32_t count;
} barrier_batch;

static void batch_flush(VkCommandBuffer cmd, barrier_batch *b, const VkMemoryBarrier2 *memory) {
    if (!b->count && !memory)
        return;
    VkDependencyInfo dep = { .sType = VK_STRUCTURE_TYPE_DEPENDENCY_INFO,
                             .memoryBarrierCount = memory ? 1 : 0,
                             .pMemoryBarriers = memory,
                             .imageMemoryBarrierCount = b->count,
                             .pImageMemoryBarriers = b->images };
    vkCmdPipelineBarrier2(cmd, &dep);
    b->count = 0;
}

static void batch_add(VkCommandBuffer cmd, barrier_batch *b, const vk_texture *t, VkImageLayout from,
                      VkImageLayout to, VkPipelineStageFlags2 src_stage, VkAccessFlags2 src_access,
                      VkPipelineStageFlags2 dst_stage, VkAccessFlags2 dst_access) {
    if (b->count == 64)
        batch_flush(cmd, b, NULL);
    b->images[b->count++] = vk_image_barrier(t, from, to, src_stage, src_access, dst_stage, dst_access);
}

#define ALL_ACCESS (VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT)

/* First layouts: GENERAL, or TRANSFER_DST_OPTIMAL for an image to be cleared
 * (a clear in GENERAL followed by a memory barrier did not satisfy the
 * synchronisation validation of a later layout transition; a transition after
 * the clear does). */
static void record_layouts(cv_backend_device *bd, VkCommandBuffer cmd) {
    barrier_batch batch = { .count = 0 };
    for (uint32_t i = 0; i < bd->imm->pending_count; i++) {
        const vk_texture *t = bd->imm->pending[i].image;
        if (t && t->clear)
            batch_add(cmd, &batch, t, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                      VK_PIPELINE_STAGE_2_NONE, 0, VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT,
                      VK_ACCESS_2_TRANSFER_WRITE_BIT);
        else if (t)
            batch_add(cmd, &batch, t, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_GENERAL, VK_PIPELINE_STAGE_2_NONE, 0,
                      VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, ALL_ACCESS);
    }
    batch_flush(cmd, &batch, NULL);
}

/* Zero clears of new images and fills of new buffers (after record_layouts). */
static void record_zeroes(cv_backend_device *bd, VkCommandBuffer cmd) {
    uint64_t bytes = 0;
    for (uint32_t i = 0; i < bd->imm->pending_count; i++) {
        const vk_texture *t = bd->imm->pending[i].image;
        if (bd->imm->pending[i].buffer) {
            vkCmdFillBuffer(cmd, bd->imm->pending[i].buffer->buffer, 0, VK_WHOLE_SIZE, 0);
            bytes += bd->imm->pending[i].buffer->size;
            continue;
        }
        if (!t->clear)
            continue;
        bytes += (uint64_t)t->width * t->height * t->texel_bytes;
        VkImageSubresourceRange range = { t->aspect, 0, 1, 0, 1 };
        VkImageLayout layout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
        if (t->aspect & VK_IMAGE_ASPECT_DEPTH_BIT)
            vkCmdClearDepthStencilImage(cmd, t->image, layout, &(VkClearDepthStencilValue){ 0 }, 1, &range);
        else
            vkCmdClearColorImage(cmd, t->image, layout, &(VkClearColorValue){ 0 }, 1, &range);
    }
    if (bytes) {
        atomic_fetch_add(&bd->zeroed_bytes, bytes);
        bd->imm->zero_started_ns = cv_now_ns();
    }
}

/* Cleared images to GENERAL and the fills before everything after them (in
 * this command buffer; later lists wait for the immediate submission). */
static void record_zeroed(cv_backend_device *bd, VkCommandBuffer cmd) {
    barrier_batch batch = { .count = 0 };
    bool buffers = false;
    for (uint32_t i = 0; i < bd->imm->pending_count; i++) {
        vk_texture *t = bd->imm->pending[i].image;
        vk_buffer *b = bd->imm->pending[i].buffer;
        if (b) {
            b->pending = false;
            buffers = true;
            continue;
        }
        if (t->clear)
            batch_add(cmd, &batch, t, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_IMAGE_LAYOUT_GENERAL,
                      VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                      VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, ALL_ACCESS);
        t->pending = t->clear = false;
    }
    VkMemoryBarrier2 filled = {
        .sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER_2,
        .srcStageMask = VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, /* fills are transfers, clears too */
        .srcAccessMask = VK_ACCESS_2_TRANSFER_WRITE_BIT,
        .dstStageMask = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT,
        .dstAccessMask = ALL_ACCESS,
    };
    batch_flush(cmd, &batch, buffers ? &filled : NULL);
}

static void record_pending(cv_backend_device *bd, VkCommandBuffer cmd) {
    record_layouts(bd, cmd);
    record_zeroes(bd, cmd);
    record_zeroed(bd, cmd);
    bd->imm->pending_count = 0;
}

cv_result vk_immediate_begin(cv_backend_device *bd, VkCommandBuffer *out) {
    VkResult vr = vkResetCommandBuffer(bd->imm->cmd, 0);
    if (vr != VK_SUCCESS)
        return vk_fail(vr, "vkResetCommandBuffer (immediate)");
    VkCommandBufferBeginInfo begin = { .sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO,
                                       .flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT };
    vr = vkBeginCommandBuffer(bd->imm->cmd, &begin);
    if (vr != VK_SUCCESS)
        return vk_fail(vr, "vkBeginCommandBuffer (immediate)");
    record_pending(bd, bd->imm->cmd);
    *out = bd->imm->cmd;
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
    vkCmdPipelineBarrier2(bd->imm->cmd, &dep);
    VkResult vr = vkEndCommandBuffer(bd->imm->cmd);
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
                                           .commandBuffer = bd->imm->cmd };
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
    if (bd->imm->zero_started_ns) {
        atomic_fetch_add(&bd->zero_ns, cv_now_ns() - bd->imm->zero_started_ns);
        bd->imm->zero_started_ns = 0;
    }
    return vr == VK_SUCCESS ? CV_OK : vk_fail(vr, "vkWaitSemaphores (immediate, device '%s')", bd->label);
}

cv_result vk_immediate_flush(cv_backend_device *bd) {
    if (!bd->imm->pending_count)
        return CV_OK;
    VkCommandBuffer cmd;
    cv_result r = vk_immediate_begin(bd, &cmd);
    return r == CV_OK ? vk_immediate_end(bd) : r;
}

static cv_result add_pending(cv_backend_device *bd, struct vk_pending_init item) {
    if (bd->imm->pending_count == bd->imm->pending_capacity) {
        uint32_t cap = bd->imm->pending_capacity ? bd->imm->pending_capacity * 2 : 64;
        struct vk_pending_init *grown = realloc(bd->imm->pending, cap * sizeof(*grown));
        if (!grown)
            return cv_error(CV_ERROR_OUT_OF_MEMORY, "vulkan: pending initialisation list of %u", cap);
        bd->imm->pending = grown;
        bd->imm->pending_capacity = cap;
    }
    bd->imm->pending[bd->imm->pending_count++] = item;
    return CV_OK;
}

static void forget_pending(cv_backend_device *bd, const void *object) {
    for (uint32_t i = bd->imm->pending_count; i-- > 0;)
        if ((const void *)bd->imm->pending[i].image == object || (const void *)bd->imm->pending[i].buffer == object) {
            bd->imm->pending[i] = bd->imm->pending[--bd->imm->pending_count];
            return;
        }
}

cv_result vk_immediate_add_image(cv_backend_device *bd, vk_texture *tex) {
    cv_result r = add_pending(bd, (struct vk_pending_init){ .image = tex });
    tex->pending = r == CV_OK;
    return r;
}

void vk_immediate_forget_image(cv_backend_device *bd, vk_texture *tex) {
    if (tex->pending)
        forget_pending(bd, tex);
    tex->pending = false;
}

cv_result vk_immediate_zero_buffer(cv_backend_device *bd, vk_buffer *buf) {
    if (buf->memory.zeroed)
        return CV_OK; /* fresh pages (vk_memory.h) */
    if (buf->memory.mapped) {
        uint64_t start = cv_now_ns();
        memset(buf->memory.mapped, 0, buf->size);
        vk_memory_flush(&bd->memory, &buf->memory, 0, buf->size);
        atomic_fetch_add(&bd->zeroed_bytes, buf->size);
        atomic_fetch_add(&bd->zero_ns, cv_now_ns() - start);
        return CV_OK;
    }
    cv_result r = add_pending(bd, (struct vk_pending_init){ .buffer = buf });
    buf->pending = r == CV_OK;
    return r;
}

void vk_immediate_forget_buffer(cv_backend_device *bd, vk_buffer *buf) {
    if (buf->pending)
        forget_pending(bd, buf);
    buf->pending = false;
}
