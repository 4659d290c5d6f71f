/* Queue submission with timeline semaphores (see vk_submit.h). */
#include "vk_bridge.h"
#include "vk_immediate.h"
#include "vk_shared.h"
#include "vk_submit.h"

static VkSemaphoreSubmitInfo semaphore_info(VkSemaphore s, uint64_t value) {
    return (VkSemaphoreSubmitInfo){ .sType = VK_STRUCTURE_TYPE_SEMAPHORE_SUBMIT_INFO,
                                    .semaphore = s,
                                    .value = value,
                                    .stageMask = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT };
}

cv_result vk_submit(cv_backend_device *bd, vk_compiled *c, uint64_t ticket) {
    /* Images created since the last submission get their first layout now. */
    cv_result r = vk_immediate_flush(bd);
    if (r == CV_OK && c->indirect.used)
        r = vk_indirect_reserve(bd, ticket);
    if (r != CV_OK)
        return r;
    for (uint32_t i = 0; i < c->segment_count; i++) {
        const vk_segment *seg = &c->segments[i];
        bool first = i == 0, last = i + 1 == c->segment_count;
        VkSemaphoreSubmitInfo waits[2];
        uint32_t wait_count = 0;
        if (first) {
            waits[wait_count++] = semaphore_info(bd->ticket, ticket - 1);
            /* Host transfers ran on the graphics queue: their writes must be visible here. */
            if (bd->immediate_value)
                waits[wait_count++] = semaphore_info(bd->immediate, bd->immediate_value);
        } else {
            waits[wait_count++] = semaphore_info(bd->chain, bd->chain_value);
        }
        VkSemaphoreSubmitInfo signal = last ? semaphore_info(bd->ticket, ticket)
                                            : semaphore_info(bd->chain, bd->chain_value + 1);
        VkCommandBufferSubmitInfo buffers[2];
        uint32_t buffer_count = 0;
        if (seg->prologue)
            buffers[buffer_count++] = (VkCommandBufferSubmitInfo){
                .sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_SUBMIT_INFO, .commandBuffer = seg->prologue
            };
        buffers[buffer_count++] = (VkCommandBufferSubmitInfo){ .sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_SUBMIT_INFO,
                                                               .commandBuffer = seg->body };
        VkSubmitInfo2 submit = {
            .sType = VK_STRUCTURE_TYPE_SUBMIT_INFO_2,
            .waitSemaphoreInfoCount = wait_count,
            .pWaitSemaphoreInfos = waits,
            .commandBufferInfoCount = buffer_count,
            .pCommandBufferInfos = buffers,
            .signalSemaphoreInfoCount = 1,
            .pSignalSemaphoreInfos = &signal,
        };
        VkResult vr = vk_queue_submit(bd, seg->slot, &submit);
        if (vr != VK_SUCCESS)
            return vk_fail(vr, "vkQueueSubmit2 of ticket %llu, segment %u of %u, device '%s'",
                           (unsigned long long)ticket, i + 1, c->segment_count, bd->label);
        if (!last)
            bd->chain_value++;
    }
    if (ticket > bd->last_ticket)
        bd->last_ticket = ticket;
    if (c->indirect.used)
        vk_indirect_submitted(bd, &c->indirect, ticket);
    return CV_OK;
}

cv_result vk_wait(cv_backend_device *bd, uint64_t ticket, uint64_t timeout_ns) {
    VkSemaphoreWaitInfo info = { .sType = VK_STRUCTURE_TYPE_SEMAPHORE_WAIT_INFO,
                                 .semaphoreCount = 1,
                                 .pSemaphores = &bd->ticket,
                                 .pValues = &ticket };
    VkResult vr = vk_host_wait(bd, &info, timeout_ns);
    if (vr == VK_TIMEOUT)
        return cv_error(CV_ERROR_TIMEOUT, "device '%s': ticket %llu not finished after %llu ns", bd->label,
                        (unsigned long long)ticket, (unsigned long long)timeout_ns);
    return vr == VK_SUCCESS ? CV_OK
                            : vk_fail(vr, "vkWaitSemaphores for ticket %llu on device '%s'",
                                      (unsigned long long)ticket, bd->label);
}

uint64_t vk_completed(cv_backend_device *bd) { return vk_host_counter(bd, bd->ticket); }
