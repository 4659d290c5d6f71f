/* Cross-device transfers: the basis of multi-GPU partitions.
 *
 * Copies a buffer range or a texture rectangle from a resource on one device to
 * a resource on another (any backends) and reports the bytes moved, the time
 * taken and the path the bytes took. Both devices must have the handles
 * loaded; ranges are checked on both sides before anything moves, and a
 * refused transfer changes nothing.
 *
 * Paths (client/src/transfer.c chooses; docs/transfers.md has the details):
 *   DEVICE       two instances of one shared device (Vulkan: virtual GPUs of
 *                one adapter on one VkDevice, CORVID_VGPU_DEVICE=shared): one
 *                GPU copy from the source resource to the destination
 *                resource on the source's queue, ordered by the two devices'
 *                tickets on the GPU. No staging, no host copy.
 *   SHARED       two devices of one adapter (same backend, equal driver and
 *                device UUIDs, both able to export and import memory as file
 *                descriptors: Vulkan's VK_KHR_external_memory_fd): the source
 *                exports a device-local staging buffer, the destination imports
 *                it; the source copies into it on its queue, the destination
 *                out of it on its own. No host copy.
 *   HOST_IMPORT  two devices that can both import host memory
 *                (VK_EXT_external_memory_host): one page-aligned host
 *                allocation, touched once, imported into both; the source's GPU
 *                copies into it, the destination's GPU copies out. No CPU copy.
 *   STAGED       any two devices: read into host memory, write from it,
 *                pipelined in 4 MiB pieces (the only path between backends).
 *   PEER         two proxy devices on different corvid-node sessions: the
 *                source node sends the bytes (compressed) to the destination
 *                node itself, in the sessions' message order; the call returns
 *                without waiting and the client sees none of the bytes
 *                (docs/node.md, "Clusters").
 * AUTO (the default) takes the first of these the pair can use.
 * cv_transfer_set_path forces one (programs: CORVID_TRANSFER_PATH=device|
 * shared|host-import|staged|auto, read by apps/common/env_client.h): a forced
 * path that a pair cannot use fails with CV_ERROR_UNSUPPORTED naming both
 * devices and what is missing.
 *
 * Asynchronous transfers (DEVICE, SHARED and HOST_IMPORT pairs whose backends
 * have asynchronous link copies, Vulkan's): on DEVICE a ring has no slots and
 * each transfer is one copy as above; otherwise a ring of staging slots owned by one
 * (source, destination) pair. A transfer through it returns at once: the
 * source copies into the next slot on its queue, after everything already
 * submitted there (so it sees the work before it, no host wait), and the
 * destination copies out of the slot on its queue after waiting on the GPU
 * for the source's copy; later submissions on the destination see the bytes.
 * A slot is written again only after the destination's previous read of it,
 * again a GPU-side wait. The tickets returned are ordinary device tickets
 * (cv_device_wait works on them). A transfer larger than a slot takes several.
 *
 *     cv_transfer_ring *ring;
 *     if (cv_transfer_ring_create(a, b, 8u << 20, 2, &ring) == CV_OK) {   // else: cv_transfer_texture
 *         cv_transfer_async t;
 *         cv_transfer_texture_async(ring, tex, (cv_rect){ x, 0, w, h }, tex, x, 0, &t);
 *         ... submit b's work that reads tex: it runs after the copy ...
 *         cv_transfer_ring_destroy(ring);   // before either device
 *     }
 *
 * One thread at a time per ring; rings of different pairs share nothing. */
#ifndef CORVID_TRANSFER_H
#define CORVID_TRANSFER_H

#include "corvid/device.h"
#include "corvid/transfer_types.h"

cv_result cv_transfer_buffer(cv_device *src, cv_buffer src_buffer, uint64_t src_offset, cv_device *dst,
                             cv_buffer dst_buffer, uint64_t dst_offset, uint64_t size, cv_transfer_stats *stats);
cv_result cv_transfer_texture(cv_device *src, cv_texture src_texture, cv_rect src_rect, cv_device *dst,
                              cv_texture dst_texture, uint32_t dst_x, uint32_t dst_y, cv_transfer_stats *stats);

/* "auto", "staged", "host-import", "shared", "peer", "device" ("unknown" out of range). */
const char *cv_transfer_path_name(cv_transfer_path path);
/* Parses a name above; CV_ERROR_INVALID_ARGUMENT (listing the names) otherwise. */
cv_result cv_transfer_path_parse(const char *name, cv_transfer_path *out);
/* Process-wide: the path every transfer from now on takes (AUTO: chosen per
 * pair); cv_transfer_clear_path returns to AUTO. Programs read it from
 * CORVID_TRANSFER_PATH (apps/common/env_client.h). */
cv_result cv_transfer_set_path(cv_transfer_path path);
void cv_transfer_clear_path(void);
/* The mode in force: the API's path, else AUTO. */
cv_result cv_transfer_mode(cv_transfer_path *out);
/* The path a transfer from src to dst would take now (the mode in force,
 * resolved for the pair); CV_ERROR_UNSUPPORTED if a forced path does not fit. */
cv_result cv_transfer_choose_path(cv_device *src, cv_device *dst, cv_transfer_path *out);

/* ---- asynchronous transfers ---- */

typedef struct cv_transfer_ring cv_transfer_ring;

typedef struct cv_transfer_async {
    uint64_t bytes;
    uint64_t src_ticket, dst_ticket; /* the last copy's tickets on each device */
    cv_transfer_path path;           /* DEVICE, SHARED or HOST_IMPORT */
} cv_transfer_async;

/* A ring of `slots` (2..64) slots of slot_bytes (a multiple of 256, at least
 * one row of any texture moved through it) from src to dst, on the path the
 * mode in force gives the pair (cv_transfer_choose_path). CV_ERROR_UNSUPPORTED,
 * naming the devices and why, where that path is STAGED or the backends have
 * no asynchronous copies: use cv_transfer_buffer / cv_transfer_texture then. */
cv_result cv_transfer_ring_create(cv_device *src, cv_device *dst, uint64_t slot_bytes, uint32_t slots,
                                  cv_transfer_ring **out);
/* Waits for the ring's copies on both devices and frees its slots. Destroy a
 * ring before either of its devices. NULL is ignored. */
void cv_transfer_ring_destroy(cv_transfer_ring *ring);
cv_transfer_path cv_transfer_ring_path(const cv_transfer_ring *ring);
/* As cv_transfer_buffer / cv_transfer_texture (the same checks, the same
 * errors; a refused transfer changes nothing), between the ring's devices,
 * without waiting on the host. `out` may be NULL. */
cv_result cv_transfer_buffer_async(cv_transfer_ring *ring, cv_buffer src_buffer, uint64_t src_offset,
                                   cv_buffer dst_buffer, uint64_t dst_offset, uint64_t size, cv_transfer_async *out);
cv_result cv_transfer_texture_async(cv_transfer_ring *ring, cv_texture src_texture, cv_rect src_rect,
                                    cv_texture dst_texture, uint32_t dst_x, uint32_t dst_y, cv_transfer_async *out);

#endif
