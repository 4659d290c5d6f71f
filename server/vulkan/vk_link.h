/* Cross-device links (backend.h: link_caps, link_staging, link_copy): staging
 * buffers whose memory another VkDevice reaches too, and GPU copies between
 * them and resources.
 *
 * Three kinds of staging, each a VkBuffer over the whole memory:
 *   EXPORT  device memory (device-local where the buffer may have it)
 *           allocated exportable as an opaque fd (VK_KHR_external_memory_fd);
 *           one per device, kept until the device goes.
 *   IMPORT  another device's EXPORT, imported from its fd; legal only between
 *           devices with equal driverUUID and deviceUUID (the core checks).
 *   HOST    a host allocation imported with VK_EXT_external_memory_host.
 * Stagings are cached (EXPORT for good, IMPORT by key, HOST by address, at
 * most VK_LINK_CACHE of the last two, oldest evicted) and freed with the
 * device. An import keeps the memory alive after its exporter is destroyed.
 *
 * Copies run on the immediate command buffer and are waited for on the host,
 * like host transfers; the memory barrier at the end of every immediate
 * submission makes the copy's writes available before it signals. Opaque-fd
 * memory is shared with another VkDevice, so each copy first acquires the
 * buffer from VK_QUEUE_FAMILY_EXTERNAL and releases it back after.
 *
 * Asynchronous copies (vk_link_async.c, backend.h's link_copy_async) record
 * the same commands into a command buffer of their own, submitted with the
 * next ticket on the device's link queue (the link_queue option: compute by
 * default, where the passes that write and read the copied resources run): they wait for the previous ticket (so
 * they follow everything submitted before, as a list does), for the latest
 * immediate submission, and, when asked, for another device's ticket through
 * this device's bridge (vk_bridge.h). Stagings made with desc->owned are not
 * cached; vk_link_release frees one. */
#ifndef CORVID_VK_LINK_H
#define CORVID_VK_LINK_H

#include "vk_resources.h"

#define VK_LINK_CACHE 8

void vk_link_caps(cv_backend_device *bd, cv_link_caps *out);
cv_result vk_link_staging(cv_backend_device *bd, cv_staging_desc *desc, void **out);
cv_result vk_link_copy(cv_backend_device *bd, void *staging, uint64_t staging_offset, cv_handle_type type, void *obj,
                       uint64_t offset, uint64_t size, cv_rect rect, bool to_staging);
cv_result vk_link_copy_async(cv_backend_device *bd, void *staging, uint64_t staging_offset, cv_handle_type type,
                             void *obj, uint64_t offset, uint64_t size, cv_rect rect, bool to_staging,
                             const cv_link_wait *wait, uint64_t ticket);
void vk_link_release(cv_backend_device *bd, void *staging);
/* One copy between resources of two instances of one shared VkDevice (vk_shared.h;
 * backend.h: link_copy_device), on bd's link queue; dst_bd gets an empty
 * submission with dst_ticket that waits for it. */
cv_result vk_link_copy_device(cv_backend_device *bd, cv_backend_device *dst_bd, cv_handle_type type, void *src_obj,
                              void *dst_obj, const cv_link_region *region, uint64_t dst_wait, uint64_t ticket,
                              uint64_t dst_ticket);
/* A GPU-side wait (backend.h: link_wait): an empty submission on bd's link
 * queue with `ticket`, after ticket-1 and after wait->device's ticket. */
cv_result vk_link_wait(cv_backend_device *bd, const cv_link_wait *wait, uint64_t ticket);
/* For vk_link_async.c: the range check, and the commands of one copy. */
cv_result vk_link_in_range(const cv_backend_device *bd, void *staging, uint64_t staging_offset, cv_handle_type type,
                           void *obj, uint64_t size, cv_rect rect);
/* Records a link copy on cmd, a command buffer of `slot`'s family (the
 * opaque-fd staging's ownership moves between that family and the others). */
void vk_link_record(const cv_backend_device *bd, VkCommandBuffer cmd, vk_queue_slot slot, void *staging,
                    uint64_t staging_offset, cv_handle_type type, void *obj, uint64_t offset, uint64_t size,
                    cv_rect rect, bool to_staging);
/* Frees the asynchronous copies' command buffers (the device idle). */
void vk_link_async_finish(cv_backend_device *bd);
/* Frees every staging (at device destruction, the device idle). */
void vk_link_finish(cv_backend_device *bd);

#endif
