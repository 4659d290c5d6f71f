/* Cross-device GPU waits by importing the other device's ticket semaphore
 * (the direct way; vk_bridge.h is the portable one). Where both VkDevices are
 * on one physical device (equal deviceUUID and driverUUID) and both can
 * export and import opaque-fd TIMELINE semaphores (VK_KHR_external_semaphore_fd,
 * vkGetPhysicalDeviceExternalSemaphoreProperties with a timeline type chained),
 * every device creates its ticket semaphore exportable, and a device that must
 * wait for another one's ticket imports that semaphore once (a timeline
 * semaphore of its own carrying the other's payload) and waits on it at the
 * ticket itself, on the GPU: no host thread, no host signal.
 *
 * The choice, per device at creation, from cv_vulkan_device_options.cross_wait:
 *   auto (default, or unset): import where the pair allows it, else the bridge;
 *   bridge: always the bridge;
 *   import: a device that cannot share its ticket semaphore fails to create
 *           (CV_ERROR_UNSUPPORTED naming the device and what it lacks), and a
 *           ring between a pair that cannot import is refused likewise.
 * cv_device_info.cross_wait says "import" or "bridge".
 *
 * Imports are cached per (waiter, source) on the waiter: the entry holds a
 * reference to the source's vk_watch (so a later device at the same address is
 * never taken for it) and the waiter's latest ticket that waited on it. A new
 * wait never uses the entry of a closing source (the core waited for all its
 * tickets before destroying it, so nothing needs waiting); such entries are
 * destroyed once the waiter finished its last use, the rest with the waiter
 * (after its idle wait). The payload itself lives until every semaphore
 * holding it is gone, so the order in which the two devices go does not
 * matter. Only the waiter's calling thread touches its cache (the core's
 * device lock). */
#ifndef CORVID_VK_CROSS_WAIT_H
#define CORVID_VK_CROSS_WAIT_H

#include <stddef.h>

#include "vk_device_core.h"

/* Whether a device can share its ticket semaphore, from what it offers: the
 * extension, and the external semaphore properties of opaque-fd timeline
 * semaphores. Pure; on false, `missing` names what is lacking. */
bool vk_cross_wait_capable(bool has_extension, const VkExternalSemaphoreProperties *props, char *missing,
                           size_t missing_size);

/* The device's decision: *import whether it shares and imports tickets.
 * mode IMPORT and !capable: CV_ERROR_UNSUPPORTED naming `label` and `missing`
 * (*import false). Pure. */
cv_result vk_cross_wait_decide(cv_vulkan_cross_wait mode, bool capable, const char *missing, const char *label,
                               bool *import);

/* Whether two devices' UUIDs (driver, device) say they may share payloads. Pure. */
bool vk_cross_wait_same_device(const uint8_t driver_a[VK_UUID_SIZE], const uint8_t device_a[VK_UUID_SIZE],
                               const uint8_t driver_b[VK_UUID_SIZE], const uint8_t device_b[VK_UUID_SIZE]);

/* Queries the adapter (before its VkDevice exists) and decides by `mode`:
 * sets bd->cross_import, bd->cross_required and bd->cross_missing. */
cv_result vk_cross_wait_setup(cv_backend_device *bd, cv_vulkan_cross_wait mode);

/* Whether `waiter` waits for `source` through an imported semaphore. */
bool vk_cross_wait_direct(const cv_backend_device *waiter, const cv_backend_device *source);

/* The waiter's semaphore carrying source's tickets, imported on first need;
 * `use` is the waiter's ticket of the submission that will wait on it. */
cv_result vk_cross_wait_semaphore(cv_backend_device *waiter, cv_backend_device *source, uint64_t use,
                                  VkSemaphore *out);

/* Destroys the waiter's imports; after its idle wait. */
void vk_cross_wait_finish(cv_backend_device *bd);

#endif
