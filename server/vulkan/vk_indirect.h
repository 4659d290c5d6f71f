/* Bounded indirect dispatches: dispatch_indirect reads its group counts from a
 * buffer the client filled, so the host never sees them before the GPU does. A
 * count past maxComputeWorkGroupCount is undefined behaviour in Vulkan, and in
 * practice runs for hours (three 0xFFFFFFFF) and wedges the device, and on
 * lavapipe every device of the process, since they share one compute pool.
 *
 * So, as WebGPU implementations do, each dispatch_indirect is recorded as two
 * dispatches: shaders/dispatch_bound.comp (one invocation) copies the counts
 * into the compiled list's own slot, or zeros when any exceeds the device's
 * limit, then vkCmdDispatchIndirect reads the slot. The slot, in host-visible
 * memory, also keeps the counts as read and a refused flag: once the
 * submission finished, vk_indirect_report turns a refusal into an error naming
 * the device, ticket and command (cv_device_wait returns it, once).
 *
 * Locking: slots are recorded and submissions registered under the core's
 * device lock; vk_indirect_report runs outside it (after a wait), so the list
 * of submissions to check has a lock of its own, also taken when a compiled
 * list is released (its slots are then never read again). */
#ifndef CORVID_VK_INDIRECT_H
#define CORVID_VK_INDIRECT_H

#include "vk_resources.h"

/* The slots of one compiled list: one per dispatch_indirect, in order. */
typedef struct vk_indirect_slots {
    vk_buffer *buffer;  /* VK_INDIRECT_SLOT_BYTES per slot, host-visible; NULL: none */
    uint32_t *commands; /* the list's command index of each slot */
    uint32_t count, used;
} vk_indirect_slots;

#define VK_INDIRECT_SLOT_BYTES 32u

/* At device creation / destruction (the device is idle). */
cv_result vk_indirect_init(cv_backend_device *bd);
void vk_indirect_finish(cv_backend_device *bd);

/* Before recording a list with `count` dispatch_indirect commands: builds the
 * bound pipeline on first use and the list's slots. */
cv_result vk_indirect_prepare(cv_backend_device *bd, uint32_t count, vk_indirect_slots *slots);
/* Records the bound of the next slot for command `index`, reading the counts at
 * device address `args` (the caller declared that read to its tracker), and the
 * barrier that makes the slot visible to the indirect read and the host.
 * Returns the slot's offset in slots->buffer for vkCmdDispatchIndirect. The
 * caller must bind its own pipeline again afterwards. */
VkDeviceSize vk_indirect_record(cv_backend_device *bd, vk_indirect_slots *slots, VkCommandBuffer cmd,
                                VkDeviceAddress args, uint32_t index);
/* Frees the slots (after removing them from the checks). */
void vk_indirect_release(cv_backend_device *bd, vk_indirect_slots *slots);

/* Before queueing a submission of a list with slots: room for its check. */
cv_result vk_indirect_reserve(cv_backend_device *bd, uint64_t ticket);
/* After it was queued (under the device lock, before the core hands out its
 * ticket, so no wait can look for it earlier): the check of `ticket`. A
 * submission that failed leaves none, as its ticket is given again. */
void vk_indirect_submitted(cv_backend_device *bd, const vk_indirect_slots *slots, uint64_t ticket);
/* After `ticket` finished: CV_ERROR_OUT_OF_RANGE naming the first refused
 * dispatch of a submission up to `ticket` not reported before, else CV_OK.
 * Each submission is checked once. A list submitted again before the earlier
 * submission was checked shares its slots: the check sees the later counts. */
cv_result vk_indirect_report(cv_backend_device *bd, uint64_t ticket);

#endif
