/* Bounded indirect dispatches (see vk_indirect.h). */
#include <stdlib.h>
#include <string.h>

#include "vk_indirect.h"
#include "vk_pipelines.h"

/* Push constants of dispatch_bound.comp. */
typedef struct bound_push {
    VkDeviceAddress args, slot;
    uint32_t limit[3];
} bound_push;

/* What the shader leaves in a slot. */
typedef struct slot_words {
    uint32_t bounded[3];
    uint32_t refused;
    uint32_t read_as[3];
    uint32_t pad;
} slot_words;

_Static_assert(sizeof(slot_words) == VK_INDIRECT_SLOT_BYTES, "slot layout of dispatch_bound.comp");

static const cv_pipeline_info bound_info = {
    .name = "vulkan.dispatch_bound",
    .kind = CV_PIPELINE_COMPUTE,
    .local_size = { 1, 1, 1 },
    .push_constant_size = sizeof(bound_push),
    .compute_shader = "dispatch_bound.comp",
};

typedef struct check {
    uint64_t ticket;
    const vk_indirect_slots *slots;
} check;

struct vk_indirect {
    vk_pipeline *pipeline; /* built at the first list that needs it (under the device lock) */
    pthread_mutex_t lock;  /* the checks: added under the device lock, read after waits outside it */
    check *checks;
    uint32_t check_count, check_capacity;
};

cv_result vk_indirect_init(cv_backend_device *bd) {
    vk_indirect *in = calloc(1, sizeof(*in));
    if (!in)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "vulkan: indirect bounds of device '%s'", bd->label);
    pthread_mutex_init(&in->lock, NULL);
    bd->indirect = in;
    return CV_OK;
}

void vk_indirect_finish(cv_backend_device *bd) {
    vk_indirect *in = bd->indirect;
    if (!in)
        return;
    if (in->pipeline)
        vk_pipeline_release(bd, in->pipeline);
    free(in->checks);
    pthread_mutex_destroy(&in->lock);
    free(in);
    bd->indirect = NULL;
}

cv_result vk_indirect_prepare(cv_backend_device *bd, uint32_t count, vk_indirect_slots *slots) {
    vk_indirect *in = bd->indirect;
    cv_result r = in->pipeline ? CV_OK : vk_pipeline_build(bd, &bound_info, &in->pipeline);
    if (r != CV_OK)
        return r;
    *slots = (vk_indirect_slots){ .count = count };
    if (!(slots->commands = calloc(count, sizeof(*slots->commands))))
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "vulkan: %u indirect dispatch slots", count);
    r = vk_buffer_create_host(bd, (VkDeviceSize)count * VK_INDIRECT_SLOT_BYTES,
                              VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT | VK_BUFFER_USAGE_STORAGE_BUFFER_BIT |
                                  VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT,
                              "indirect dispatch slots", &slots->buffer);
    if (r != CV_OK) {
        free(slots->commands);
        slots->commands = NULL;
        return r;
    }
    /* Until the bound first runs, a slot reads as not refused. */
    memset(slots->buffer->memory.mapped, 0, (size_t)count * VK_INDIRECT_SLOT_BYTES);
    vk_memory_flush(&bd->memory, &slots->buffer->memory, 0, (VkDeviceSize)count * VK_INDIRECT_SLOT_BYTES);
    return CV_OK;
}

VkDeviceSize vk_indirect_record(cv_backend_device *bd, vk_indirect_slots *slots, VkCommandBuffer cmd,
                                VkDeviceAddress args, uint32_t index) {
    const vk_pipeline *p = bd->indirect->pipeline;
    uint32_t n = slots->used++;
    slots->commands[n] = index;
    VkDeviceSize offset = (VkDeviceSize)n * VK_INDIRECT_SLOT_BYTES;
    bound_push push = { .args = args, .slot = slots->buffer->address + offset };
    for (int i = 0; i < 3; i++)
        push.limit[i] = bd->limits.maxComputeWorkGroupCount[i];
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, p->pipeline);
    vkCmdPushConstants(cmd, p->layout, p->stages, 0, sizeof(push), &push);
    vkCmdDispatch(cmd, 1, 1, 1);
    VkMemoryBarrier2 barrier = {
        .sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER_2,
        .srcStageMask = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
        .srcAccessMask = VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
        .dstStageMask = VK_PIPELINE_STAGE_2_DRAW_INDIRECT_BIT | VK_PIPELINE_STAGE_2_HOST_BIT,
        .dstAccessMask = VK_ACCESS_2_INDIRECT_COMMAND_READ_BIT | VK_ACCESS_2_HOST_READ_BIT,
    };
    VkDependencyInfo dep = { .sType = VK_STRUCTURE_TYPE_DEPENDENCY_INFO,
                             .memoryBarrierCount = 1,
                             .pMemoryBarriers = &barrier };
    vkCmdPipelineBarrier2(cmd, &dep);
    return offset;
}

/* Removes the checks of `slots` (all of them when ticket is 0, else those up to
 * ticket), under the lock. */
static void drop_checks(vk_indirect *in, const vk_indirect_slots *slots, uint64_t ticket) {
    uint32_t kept = 0;
    for (uint32_t i = 0; i < in->check_count; i++) {
        const check *k = &in->checks[i];
        bool drop = slots ? k->slots == slots : k->ticket <= ticket;
        if (!drop)
            in->checks[kept++] = *k;
    }
    in->check_count = kept;
}

void vk_indirect_release(cv_backend_device *bd, vk_indirect_slots *slots) {
    if (!slots->buffer)
        return;
    vk_indirect *in = bd->indirect;
    pthread_mutex_lock(&in->lock);
    drop_checks(in, slots, 0);
    pthread_mutex_unlock(&in->lock);
    vk_buffer_destroy(bd, slots->buffer);
    free(slots->commands);
    *slots = (vk_indirect_slots){ 0 };
}

cv_result vk_indirect_reserve(cv_backend_device *bd, uint64_t ticket) {
    vk_indirect *in = bd->indirect;
    cv_result r = CV_OK;
    pthread_mutex_lock(&in->lock);
    if (in->check_count == in->check_capacity) {
        uint32_t cap = in->check_capacity ? in->check_capacity * 2 : 16;
        check *grown = realloc(in->checks, cap * sizeof(*grown));
        if (grown) {
            in->checks = grown;
            in->check_capacity = cap;
        } else {
            r = cv_error(CV_ERROR_OUT_OF_MEMORY, "device '%s': submission %llu: indirect dispatch checks", bd->label,
                         (unsigned long long)ticket);
        }
    }
    pthread_mutex_unlock(&in->lock);
    return r;
}

void vk_indirect_submitted(cv_backend_device *bd, const vk_indirect_slots *slots, uint64_t ticket) {
    vk_indirect *in = bd->indirect;
    pthread_mutex_lock(&in->lock);
    in->checks[in->check_count++] = (check){ ticket, slots };
    pthread_mutex_unlock(&in->lock);
}

/* The first refused slot of one finished submission, as an error. */
static cv_result check_slots(cv_backend_device *bd, const check *k) {
    const vk_indirect_slots *s = k->slots;
    vk_memory_invalidate(&bd->memory, &s->buffer->memory, 0, (VkDeviceSize)s->used * VK_INDIRECT_SLOT_BYTES);
    const slot_words *words = s->buffer->memory.mapped;
    for (uint32_t i = 0; i < s->used; i++) {
        const slot_words *w = &words[i];
        if (!w->refused)
            continue;
        return cv_indirect_refusal(bd->label, k->ticket, s->commands[i], w->read_as,
                                   bd->limits.maxComputeWorkGroupCount);
    }
    return CV_OK;
}

cv_result vk_indirect_report(cv_backend_device *bd, uint64_t ticket) {
    vk_indirect *in = bd->indirect;
    cv_result r = CV_OK;
    pthread_mutex_lock(&in->lock);
    for (uint32_t i = 0; i < in->check_count && r == CV_OK; i++)
        if (in->checks[i].ticket <= ticket)
            r = check_slots(bd, &in->checks[i]);
    drop_checks(in, NULL, ticket);
    pthread_mutex_unlock(&in->lock);
    return r;
}
