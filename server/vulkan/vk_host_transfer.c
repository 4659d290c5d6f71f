/* Host transfers. A buffer in host-visible memory (lavapipe's only memory
 * type, or a GPU's) is read and written through its persistent mapping. Other
 * buffers, and all textures (optimal tiling is opaque to the host), go through
 * a temporary host-visible staging buffer and a copy on the immediate command
 * buffer, in chunks of at most STAGING_MAX bytes. */
#include <string.h>

#include "vk_host_transfer.h"
#include "vk_immediate.h"

#define STAGING_MAX (32ull << 20)

typedef struct staging {
    VkBuffer buffer;
    vk_allocation memory;
} staging;

static cv_result staging_create(cv_backend_device *bd, VkDeviceSize size, bool for_reading, staging *out) {
    VkBufferCreateInfo info = {
        .sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO,
        .pNext = vk_memory_buffer_external(&bd->memory),
        .size = size,
        .usage = VK_BUFFER_USAGE_TRANSFER_SRC_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
        .sharingMode = VK_SHARING_MODE_EXCLUSIVE,
    };
    VkResult vr = vkCreateBuffer(bd->device, &info, NULL, &out->buffer);
    if (vr != VK_SUCCESS) {
        *out = (staging){ 0 };
        return vk_fail(vr, "vkCreateBuffer (staging, %llu bytes)", (unsigned long long)size);
    }
    VkMemoryRequirements req;
    vkGetBufferMemoryRequirements(bd->device, out->buffer, &req);
    cv_result r = vk_memory_alloc(&bd->memory, &req,
                                  VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT,
                                  for_reading ? VK_MEMORY_PROPERTY_HOST_CACHED_BIT : 0, VK_MEMORY_LINEAR, "staging",
                                  &out->memory);
    if (r == CV_OK) {
        vr = vkBindBufferMemory(bd->device, out->buffer, out->memory.memory, out->memory.offset);
        if (vr != VK_SUCCESS)
            r = vk_fail(vr, "vkBindBufferMemory (staging)");
    }
    if (r != CV_OK) {
        vkDestroyBuffer(bd->device, out->buffer, NULL);
        vk_memory_free(&bd->memory, &out->memory);
        *out = (staging){ 0 };
    }
    return r;
}

static void staging_destroy(cv_backend_device *bd, staging *s) {
    vkDestroyBuffer(bd->device, s->buffer, NULL);
    vk_memory_free(&bd->memory, &s->memory);
}

static VkDeviceSize min_size(VkDeviceSize a, VkDeviceSize b) { return a < b ? a : b; }

/* ---- buffers ------------------------------------------------------------------- */

static cv_result buffer_copy(cv_backend_device *bd, VkBuffer src, VkDeviceSize src_offset, VkBuffer dst,
                             VkDeviceSize dst_offset, VkDeviceSize size) {
    VkCommandBuffer cmd;
    cv_result r = vk_immediate_begin(bd, &cmd);
    if (r != CV_OK)
        return r;
    VkBufferCopy region = { src_offset, dst_offset, size };
    vkCmdCopyBuffer(cmd, src, dst, 1, &region);
    return vk_immediate_end(bd);
}

cv_result vk_host_buffer_write(cv_backend_device *bd, vk_buffer *b, uint64_t offset, uint64_t size,
                               const void *data) {
    if (b->memory.mapped) {
        memcpy((char *)b->memory.mapped + offset, data, size);
        vk_memory_flush(&bd->memory, &b->memory, offset, size);
        return CV_OK;
    }
    staging s = { 0 };
    cv_result r = staging_create(bd, min_size(size, STAGING_MAX), false, &s);
    for (uint64_t done = 0; r == CV_OK && done < size;) {
        VkDeviceSize n = min_size(size - done, STAGING_MAX);
        memcpy(s.memory.mapped, (const char *)data + done, n);
        r = buffer_copy(bd, s.buffer, 0, b->buffer, offset + done, n);
        done += n;
    }
    if (s.buffer)
        staging_destroy(bd, &s);
    return r;
}

cv_result vk_host_buffer_read(cv_backend_device *bd, vk_buffer *b, uint64_t offset, uint64_t size, void *out) {
    if (b->memory.mapped) {
        vk_memory_invalidate(&bd->memory, &b->memory, offset, size);
        memcpy(out, (const char *)b->memory.mapped + offset, size);
        return CV_OK;
    }
    staging s = { 0 };
    cv_result r = staging_create(bd, min_size(size, STAGING_MAX), true, &s);
    for (uint64_t done = 0; r == CV_OK && done < size;) {
        VkDeviceSize n = min_size(size - done, STAGING_MAX);
        r = buffer_copy(bd, b->buffer, offset + done, s.buffer, 0, n);
        if (r == CV_OK)
            memcpy((char *)out + done, s.memory.mapped, n);
        done += n;
    }
    if (s.buffer)
        staging_destroy(bd, &s);
    return r;
}

/* ---- textures ------------------------------------------------------------------ */

void vk_image_transition(VkCommandBuffer cmd, const vk_texture *t, VkImageLayout from, VkImageLayout to,
                         VkPipelineStageFlags2 src_stage, VkAccessFlags2 src_access, VkPipelineStageFlags2 dst_stage,
                         VkAccessFlags2 dst_access) {
    VkImageMemoryBarrier2 barrier = vk_image_barrier(t, from, to, src_stage, src_access, dst_stage, dst_access);
    VkDependencyInfo dep = { .sType = VK_STRUCTURE_TYPE_DEPENDENCY_INFO,
                             .imageMemoryBarrierCount = 1,
                             .pImageMemoryBarriers = &barrier };
    vkCmdPipelineBarrier2(cmd, &dep);
}

void vk_record_texture_rows(VkCommandBuffer cmd, const vk_texture *t, VkBuffer buffer, VkDeviceSize buffer_offset,
                            cv_rect rect, bool to_image) {
    VkBufferImageCopy region = {
        .bufferOffset = buffer_offset,
        .imageSubresource = { t->aspect, 0, 0, 1 },
        .imageOffset = { (int32_t)rect.x, (int32_t)rect.y, 0 },
        .imageExtent = { rect.width, rect.height, 1 },
    };
    VkImageLayout layout = to_image ? VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL : VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
    VkAccessFlags2 access = to_image ? VK_ACCESS_2_TRANSFER_WRITE_BIT : VK_ACCESS_2_TRANSFER_READ_BIT;
    vk_image_transition(cmd, t, VK_IMAGE_LAYOUT_GENERAL, layout, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, 0,
                        VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, access);
    if (to_image)
        vkCmdCopyBufferToImage(cmd, buffer, t->image, layout, 1, &region);
    else
        vkCmdCopyImageToBuffer(cmd, t->image, layout, buffer, 1, &region);
    vk_image_transition(cmd, t, layout, VK_IMAGE_LAYOUT_GENERAL, VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT,
                        to_image ? VK_ACCESS_2_TRANSFER_WRITE_BIT : 0, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT,
                        VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT);
}

/* Copies rows [y, y+rows) of rect between the staging buffer and the image.
 * Earlier GPU work is ordered by the immediate submission's wait
 * (vk_immediate_end), which the first barrier chains on. */
static cv_result texture_rows(cv_backend_device *bd, vk_texture *t, VkBuffer buffer, cv_rect rect, uint32_t y,
                              uint32_t rows, bool to_image) {
    VkCommandBuffer cmd;
    cv_result r = vk_immediate_begin(bd, &cmd);
    if (r != CV_OK)
        return r;
    vk_record_texture_rows(cmd, t, buffer, 0, (cv_rect){ rect.x, rect.y + y, rect.width, rows }, to_image);
    return vk_immediate_end(bd);
}

static cv_result texture_transfer(cv_backend_device *bd, vk_texture *t, cv_rect rect, const void *data, void *out) {
    VkDeviceSize row_bytes = (VkDeviceSize)rect.width * t->texel_bytes;
    uint32_t rows_per_chunk = (uint32_t)min_size(rect.height, STAGING_MAX / row_bytes ? STAGING_MAX / row_bytes : 1);
    staging s = { 0 };
    cv_result r = staging_create(bd, row_bytes * rows_per_chunk, out != NULL, &s);
    for (uint32_t y = 0; r == CV_OK && y < rect.height; y += rows_per_chunk) {
        uint32_t rows = (uint32_t)min_size(rows_per_chunk, rect.height - y);
        VkDeviceSize bytes = row_bytes * rows;
        if (data) {
            memcpy(s.memory.mapped, (const char *)data + row_bytes * y, bytes);
            r = texture_rows(bd, t, s.buffer, rect, y, rows, true);
        } else {
            r = texture_rows(bd, t, s.buffer, rect, y, rows, false);
            if (r == CV_OK)
                memcpy((char *)out + row_bytes * y, s.memory.mapped, bytes);
        }
    }
    if (s.buffer)
        staging_destroy(bd, &s);
    return r;
}

cv_result vk_host_texture_write(cv_backend_device *bd, vk_texture *t, cv_rect rect, const void *data) {
    return texture_transfer(bd, t, rect, data, NULL);
}

cv_result vk_host_texture_read(cv_backend_device *bd, vk_texture *t, cv_rect rect, void *out) {
    return texture_transfer(bd, t, rect, NULL, out);
}
