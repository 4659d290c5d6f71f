/* Cross-device GPU waits, the portable way (backend.h: link_copy_async's
 * wait). A submission on device B that must wait until device A reached a
 * ticket cannot wait on A's timeline semaphore: it belongs to another
 * VkDevice, and sharing it needs VK_KHR_external_semaphore_fd, which lavapipe
 * lacks. Instead every device has a "bridge": a timeline semaphore of its own
 * that such submissions wait on (waiting before the signal is submitted is
 * legal for timeline semaphores), and a thread that, request by request in
 * order, waits on the host until A reached the ticket (vkWaitSemaphores on A's
 * device) and then signals the bridge's next value (vkSignalSemaphore).
 *
 *     uint64_t value;
 *     vk_bridge_request(b_dev, a_dev, ticket, &value);   // B's bridge, A's ticket
 *     ... B's submission waits on vk_bridge_semaphore(b_dev) at `value` ...
 *
 * A's side is a vk_watch: a reference-counted view of A's ticket semaphore
 * that outlives A's VkDevice. A's destroy marks it closing and waits until no
 * bridge thread is inside a wait on A; a request that finds A closing needs no
 * wait (the core waited for every ticket of A before destroying it). The
 * thread starts with the first request and is joined in vk_bridge_finish; at
 * finish, requests still queued (the core's final wait failed: a lost device)
 * are signalled without waiting, so the device's queue drains.
 *
 * The validation layer of Debian 12 (1.3.239) deadlocks on host signals: a
 * thread whose vkWaitSemaphores succeeded waits, inside the layer and under
 * its device lock, until the layer recorded the signals the GPU's progress
 * needed, while the bridge thread that made one waits for that lock to record
 * it (it times out after seconds with UNASSIGNED-VkSemaphore-state-timeout;
 * fixed upstream by Vulkan-ValidationLayers PR 8519). With validation on, every
 * host wait, query and signal of a device's semaphores therefore runs under
 * the device's host lock (vk_device_core.h), waits polling in short slices
 * (vk_host_wait), so no wait can see progress whose host signal is still
 * being recorded. Without validation they run as plain Vulkan calls. */
#ifndef CORVID_VK_BRIDGE_H
#define CORVID_VK_BRIDGE_H

#include "vk_device_core.h"

cv_result vk_bridge_init(cv_backend_device *bd);
/* Closes this device's watch, drains and joins the thread, destroys the semaphore. */
void vk_bridge_finish(cv_backend_device *bd);
/* A submission on bd that waits on vk_bridge_semaphore(bd) at *value runs once
 * `other` reached `ticket`. Runs on bd's calling thread while both devices are alive. */
cv_result vk_bridge_request(cv_backend_device *bd, cv_backend_device *other, uint64_t ticket, uint64_t *value);

/* The bridge's timeline semaphore, and the device's watch. */
VkSemaphore vk_bridge_semaphore(const cv_backend_device *bd);
vk_watch *vk_bridge_watch(const cv_backend_device *bd);
/* A device's watch, as other devices hold it: references,
 * and whether the device began destroying itself (its tickets are all done). */
void vk_watch_ref(vk_watch *w);
void vk_watch_unref(vk_watch *w);
bool vk_watch_closing(vk_watch *w);

#endif
