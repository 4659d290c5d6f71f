/* The barrier tracker (see vk_barriers.h for the model). */
#include <stdlib.h>
#include <string.h>

#include "vk_barriers.h"

struct vk_track {
    uint64_t id;
    VkBuffer buffer;
    VkImage image;
    VkImageAspectFlags aspect;
    VkImageLayout layout;
    bool touched;                       /* used in this segment (else its first transition is hoisted) */
    VkPipelineStageFlags2 write_stages; /* the last write, if not yet followed by a barrier hint */
    VkAccessFlags2 write_access;
    VkPipelineStageFlags2 visible_stages; /* stages and accesses the last write is visible to */
    VkAccessFlags2 visible_access;
    VkPipelineStageFlags2 read_stages; /* reads since the last write */
};

void vk_tracker_init(vk_tracker *t) { memset(t, 0, sizeof(*t)); }

void vk_tracker_finish(vk_tracker *t) {
    free(t->tracks);
    cv_hash_map_finish(&t->index);
    free(t->uses);
    free(t->buffer_barriers);
    free(t->image_barriers);
    free(t->prologue);
    memset(t, 0, sizeof(*t));
}

cv_result vk_tracker_status(const vk_tracker *t) {
    return t->out_of_memory ? cv_error(CV_ERROR_OUT_OF_MEMORY, "vulkan: barrier tracker state") : CV_OK;
}

/* Grows an array to hold one more element; false (and out_of_memory) if it cannot. */
static bool reserve(vk_tracker *t, void **array, uint32_t count, uint32_t *capacity, size_t size) {
    if (count < *capacity)
        return true;
    uint32_t cap = *capacity ? *capacity * 2 : 16;
    void *grown = realloc(*array, cap * size);
    if (!grown) {
        t->out_of_memory = true;
        return false;
    }
    *array = grown;
    *capacity = cap;
    return true;
}

static vk_track *find(const vk_tracker *t, uint64_t id) {
    uint64_t index;
    return cv_hash_map_get(&t->index, id, &index) ? &t->tracks[index] : NULL;
}

/* The state of a resource, created (untouched, in GENERAL) on first sight. */
static vk_track *state_of(vk_tracker *t, const vk_use *u) {
    vk_track *s = find(t, u->id);
    if (s)
        return s;
    if (!reserve(t, (void **)&t->tracks, t->count, &t->capacity, sizeof(*t->tracks)))
        return NULL;
    if (cv_hash_map_put(&t->index, u->id, t->count) != CV_OK) {
        t->out_of_memory = true;
        return NULL;
    }
    s = &t->tracks[t->count];
    *s = (vk_track){
        .id = u->id, .buffer = u->buffer, .image = u->image, .aspect = u->aspect, .layout = VK_IMAGE_LAYOUT_GENERAL
    };
    t->count++;
    return s;
}

void vk_tracker_use(vk_tracker *t, const vk_use *use) {
    for (uint32_t i = 0; i < t->use_count; i++) {
        vk_use *u = &t->uses[i];
        if (u->id != use->id)
            continue;
        u->stages |= use->stages;
        u->reads |= use->reads;
        u->writes |= use->writes;
        if (u->layout != use->layout)
            u->layout = VK_IMAGE_LAYOUT_GENERAL;
        return;
    }
    if (!reserve(t, (void **)&t->uses, t->use_count, &t->use_capacity, sizeof(*t->uses)))
        return;
    t->uses[t->use_count++] = *use;
}

static VkImageMemoryBarrier2 image_barrier(const vk_track *s, VkPipelineStageFlags2 src_stages,
                                           VkAccessFlags2 src_access, VkPipelineStageFlags2 dst_stages,
                                           VkAccessFlags2 dst_access, VkImageLayout new_layout) {
    return (VkImageMemoryBarrier2){
        .sType = VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER_2,
        .srcStageMask = src_stages,
        .srcAccessMask = src_access,
        .dstStageMask = dst_stages,
        .dstAccessMask = dst_access,
        .oldLayout = s->layout,
        .newLayout = new_layout,
        .srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED,
        .dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED,
        .image = s->image,
        .subresourceRange = { s->aspect, 0, 1, 0, 1 },
    };
}

static void add_barrier(vk_tracker *t, const vk_track *s, VkPipelineStageFlags2 src_stages, VkAccessFlags2 src_access,
                        VkPipelineStageFlags2 dst_stages, VkAccessFlags2 dst_access, VkImageLayout new_layout) {
    /* A transition with nothing to wait for still has to follow the work
     * before it (a hint barrier or the previous submission): chain on all. */
    if (!src_stages)
        src_stages = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT;
    if (s->image) {
        if (reserve(t, (void **)&t->image_barriers, t->image_barrier_count, &t->image_barrier_capacity,
                    sizeof(*t->image_barriers)))
            t->image_barriers[t->image_barrier_count++] = image_barrier(s, src_stages, src_access, dst_stages,
                                                                        dst_access, new_layout);
        return;
    }
    if (reserve(t, (void **)&t->buffer_barriers, t->buffer_barrier_count, &t->buffer_barrier_capacity,
                sizeof(*t->buffer_barriers)))
        t->buffer_barriers[t->buffer_barrier_count++] = (VkBufferMemoryBarrier2){
            .sType = VK_STRUCTURE_TYPE_BUFFER_MEMORY_BARRIER_2,
            .srcStageMask = src_stages,
            .srcAccessMask = src_access,
            .dstStageMask = dst_stages,
            .dstAccessMask = dst_access,
            .srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED,
            .dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED,
            .buffer = s->buffer,
            .offset = 0,
            .size = VK_WHOLE_SIZE,
        };
}

static void flush_barriers(vk_tracker *t, VkCommandBuffer cmd, const VkMemoryBarrier2 *global) {
    if (!t->buffer_barrier_count && !t->image_barrier_count && !global)
        return;
    VkDependencyInfo dep = {
        .sType = VK_STRUCTURE_TYPE_DEPENDENCY_INFO,
        .memoryBarrierCount = global ? 1u : 0u,
        .pMemoryBarriers = global,
        .bufferMemoryBarrierCount = t->buffer_barrier_count,
        .pBufferMemoryBarriers = t->buffer_barriers,
        .imageMemoryBarrierCount = t->image_barrier_count,
        .pImageMemoryBarriers = t->image_barriers,
    };
    vkCmdPipelineBarrier2(cmd, &dep);
    t->barriers_emitted++;
    t->buffer_barrier_count = t->image_barrier_count = 0;
}

/* Decides the barrier one use needs and updates the resource's state. */
static void apply_use(vk_tracker *t, const vk_use *u) {
    vk_track *s = state_of(t, u);
    if (!s)
        return;
    bool transition = s->image && s->layout != u->layout;
    if (transition && !s->touched) {
        if (reserve(t, (void **)&t->prologue, t->prologue_count, &t->prologue_capacity, sizeof(*t->prologue)))
            t->prologue[t->prologue_count++] =
                image_barrier(s, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, 0, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT,
                              VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT, u->layout);
        s->layout = u->layout;
        transition = false;
    }
    s->touched = true;
    VkAccessFlags2 access = u->reads | u->writes;
    if (u->writes) {
        if (transition || s->write_stages || s->read_stages)
            add_barrier(t, s, s->write_stages | s->read_stages, s->write_access, u->stages, access, u->layout);
        s->write_stages = u->stages;
        s->write_access = u->writes;
        s->visible_stages = 0;
        s->visible_access = 0;
        s->read_stages = 0;
    } else if (transition) {
        add_barrier(t, s, s->write_stages | s->read_stages, s->write_access, u->stages, access, u->layout);
        /* Later uses in other stages must wait for the transition: treat it as
         * a write at these stages. The earlier write is already available (this
         * barrier did it), so later barriers only chain on the stages. */
        s->write_stages = u->stages;
        s->write_access = 0;
        s->visible_stages = u->stages;
        s->visible_access = u->reads;
        s->read_stages = u->stages;
    } else {
        bool hidden = (u->stages & ~s->visible_stages) || (u->reads & ~s->visible_access);
        if (s->write_stages && hidden) {
            add_barrier(t, s, s->write_stages, s->write_access, u->stages, access, u->layout);
            s->visible_stages |= u->stages;
            s->visible_access |= u->reads;
        }
        s->read_stages |= u->stages;
    }
    s->layout = u->layout;
}

void vk_tracker_apply(vk_tracker *t, VkCommandBuffer cmd) {
    for (uint32_t i = 0; i < t->use_count; i++)
        apply_use(t, &t->uses[i]);
    t->use_count = 0;
    flush_barriers(t, cmd, NULL);
}

VkImageLayout vk_tracker_layout(const vk_tracker *t, uint64_t id) {
    const vk_track *s = find(t, id);
    return s ? s->layout : VK_IMAGE_LAYOUT_GENERAL;
}

static void settle(vk_track *s) {
    s->write_stages = s->read_stages = 0;
    s->write_access = 0;
    s->visible_stages = 0;
    s->visible_access = 0;
}

void vk_tracker_barrier(vk_tracker *t, VkCommandBuffer cmd, uint64_t id) {
    VkMemoryBarrier2 all = {
        .sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER_2,
        .srcStageMask = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT,
        .srcAccessMask = VK_ACCESS_2_MEMORY_WRITE_BIT,
        .dstStageMask = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT,
        .dstAccessMask = VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT,
    };
    if (id == 0) {
        for (uint32_t i = 0; i < t->count; i++)
            settle(&t->tracks[i]);
        flush_barriers(t, cmd, &all);
        return;
    }
    vk_track *s = find(t, id);
    if (!s || !(s->write_stages | s->read_stages))
        return;
    add_barrier(t, s, s->write_stages | s->read_stages, s->write_access, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT,
                VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT, s->layout);
    settle(s);
    flush_barriers(t, cmd, NULL);
}

void vk_tracker_end_segment(vk_tracker *t, VkCommandBuffer cmd, bool to_host) {
    for (uint32_t i = 0; i < t->count; i++) {
        vk_track *s = &t->tracks[i];
        if (s->image && s->layout != VK_IMAGE_LAYOUT_GENERAL)
            add_barrier(t, s, s->write_stages | s->read_stages, s->write_access, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT,
                        0, VK_IMAGE_LAYOUT_GENERAL);
    }
    /* The semaphore signalled after this segment orders later GPU work; the
     * host, which reads mapped memory after waiting, needs its own dependency. */
    VkMemoryBarrier2 host = {
        .sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER_2,
        .srcStageMask = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT,
        .srcAccessMask = VK_ACCESS_2_MEMORY_WRITE_BIT,
        .dstStageMask = VK_PIPELINE_STAGE_2_HOST_BIT,
        .dstAccessMask = VK_ACCESS_2_HOST_READ_BIT | VK_ACCESS_2_HOST_WRITE_BIT,
    };
    flush_barriers(t, cmd, to_host ? &host : NULL);
}

bool vk_tracker_has_prologue(const vk_tracker *t) { return t->prologue_count > 0; }

void vk_tracker_record_prologue(vk_tracker *t, VkCommandBuffer cmd) {
    VkDependencyInfo dep = { .sType = VK_STRUCTURE_TYPE_DEPENDENCY_INFO,
                             .imageMemoryBarrierCount = t->prologue_count,
                             .pImageMemoryBarriers = t->prologue };
    vkCmdPipelineBarrier2(cmd, &dep);
    t->barriers_emitted++;
}

void vk_tracker_reset(vk_tracker *t) {
    cv_hash_map_clear(&t->index);
    t->count = 0;
    t->use_count = 0;
    t->prologue_count = 0;
}
