/* Automatic barriers and image layout transitions from tracked resource state.
 *
 * While a command list is compiled, each command declares the resources it
 * uses (stage, read and write access, and for images the layout it needs).
 * The tracker knows, per resource, the last write and the reads since, and
 * emits one batched vkCmdPipelineBarrier2 before the command with exactly the
 * dependencies needed: read-after-write, write-after-read and write-after-write
 * get a barrier, read-after-read gets none (and a write already made visible
 * to a stage is not made visible again).
 *
 * Images rest in VK_IMAGE_LAYOUT_GENERAL between segments of work. Within a
 * segment the tracker moves them to the layout each use wants; the first
 * transition of an image in a segment is hoisted into a prologue that runs
 * before the segment, so it waits for nothing in the segment, and an epilogue
 * returns every image to GENERAL at the segment's end. */
#ifndef CORVID_VK_BARRIERS_H
#define CORVID_VK_BARRIERS_H

#include "corvid/hash_map.h"
#include "vk_common.h"

typedef struct vk_use {
    uint64_t id;     /* the resource's handle */
    VkBuffer buffer; /* one of buffer / image */
    VkImage image;
    VkImageAspectFlags aspect;
    VkPipelineStageFlags2 stages;
    VkAccessFlags2 reads, writes;
    VkImageLayout layout; /* images */
} vk_use;

typedef struct vk_track vk_track;

typedef struct vk_tracker {
    vk_track *tracks; /* every resource seen since the last reset, in order of first sight */
    uint32_t count, capacity;
    cv_hash_map index; /* resource id -> its index in tracks */
    vk_use *uses;      /* the current command's uses, one per resource */
    uint32_t use_count, use_capacity;
    VkBufferMemoryBarrier2 *buffer_barriers;
    uint32_t buffer_barrier_count, buffer_barrier_capacity;
    VkImageMemoryBarrier2 *image_barriers;
    uint32_t image_barrier_count, image_barrier_capacity;
    VkImageMemoryBarrier2 *prologue;
    uint32_t prologue_count, prologue_capacity;
    uint32_t barriers_emitted; /* vkCmdPipelineBarrier2 calls, for tests and stats */
    bool out_of_memory;
} vk_tracker;

void vk_tracker_init(vk_tracker *t);
void vk_tracker_finish(vk_tracker *t);

/* Declares a use by the next command; uses of one resource by one command
 * are merged (an image wanted in two layouts gets GENERAL). */
void vk_tracker_use(vk_tracker *t, const vk_use *use);
/* Records the barriers the declared uses need, then forgets the uses. */
void vk_tracker_apply(vk_tracker *t, VkCommandBuffer cmd);
/* The layout an image is in after the last apply (GENERAL if untracked). */
VkImageLayout vk_tracker_layout(const vk_tracker *t, uint64_t id);
/* Explicit barrier hint: everything written so far (id 0) or one resource
 * becomes visible to every later stage. */
void vk_tracker_barrier(vk_tracker *t, VkCommandBuffer cmd, uint64_t id);

/* Records the epilogue (images back to GENERAL; with to_host, all writes made
 * visible to the host) at the end of a segment. */
void vk_tracker_end_segment(vk_tracker *t, VkCommandBuffer cmd, bool to_host);
/* Records the segment's prologue; false if it has none. */
bool vk_tracker_has_prologue(const vk_tracker *t);
void vk_tracker_record_prologue(vk_tracker *t, VkCommandBuffer cmd);
/* Starts the next segment: all state forgotten, every image in GENERAL. */
void vk_tracker_reset(vk_tracker *t);

/* CV_ERROR_OUT_OF_MEMORY if any growth failed since init (the recording is then incomplete). */
cv_result vk_tracker_status(const vk_tracker *t);

#endif
