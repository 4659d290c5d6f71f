/* Submission and completion. Each device has one timeline semaphore whose
 * value is the highest finished ticket: a submission's last segment signals
 * its ticket, its first segment waits for the previous ticket (so a device
 * runs its submissions in order, with their writes visible to the next), and
 * segments in between are chained through a second timeline semaphore. */
#ifndef CORVID_VK_SUBMIT_H
#define CORVID_VK_SUBMIT_H

#include "vk_compile.h"

cv_result vk_submit(cv_backend_device *bd, vk_compiled *c, uint64_t ticket);
cv_result vk_wait(cv_backend_device *bd, uint64_t ticket, uint64_t timeout_ns);
uint64_t vk_completed(cv_backend_device *bd);

#endif
