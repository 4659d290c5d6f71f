/* Cross-device transfers: the basis of multi-GPU partitions.
 *
 * Copies a buffer range or a texture rectangle from a resource on one device to
 * a resource on another (any backends) and reports the bytes moved, the time
 * taken and the path the bytes took. Both devices must have the handles
 * loaded; ranges are checked on both sides before anything moves, and a
 * refused transfer changes nothing.
 *
 * Paths (client/src/transfer.c chooses; docs/transfers.md has the details):
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
 * AUTO (the default) takes the first of these the pair can use. The
 * environment variable CORVID_TRANSFER_PATH=shared|host-import|staged|auto,
 * read at every transfer, or cv_transfer_set_path (which wins over it) forces
 * one: a forced path that a pair cannot use fails with CV_ERROR_UNSUPPORTED
 * naming both devices and what is missing. */
#ifndef CORVID_TRANSFER_H
#define CORVID_TRANSFER_H

#include "corvid/device.h"

typedef enum cv_transfer_path {
    CV_TRANSFER_AUTO = 0,
    CV_TRANSFER_STAGED = 1,
    CV_TRANSFER_HOST_IMPORT = 2,
    CV_TRANSFER_SHARED = 3,
    CV_TRANSFER_PEER = 4,
    CV_TRANSFER_PATH_COUNT
} cv_transfer_path;

typedef struct cv_transfer_stats {
    uint64_t bytes;
    double read_ms;  /* source device -> staging (host memory, or shared memory) */
    double write_ms; /* staging -> destination device */
    double total_ms;
    cv_transfer_path path; /* the path the bytes took: STAGED, HOST_IMPORT or SHARED */
} cv_transfer_stats;

cv_result cv_transfer_buffer(cv_device *src, cv_buffer src_buffer, uint64_t src_offset, cv_device *dst,
                             cv_buffer dst_buffer, uint64_t dst_offset, uint64_t size, cv_transfer_stats *stats);
cv_result cv_transfer_texture(cv_device *src, cv_texture src_texture, cv_rect src_rect, cv_device *dst,
                              cv_texture dst_texture, uint32_t dst_x, uint32_t dst_y, cv_transfer_stats *stats);

/* "auto", "staged", "host-import", "shared" ("unknown" out of range). */
const char *cv_transfer_path_name(cv_transfer_path path);
/* Parses a name above; CV_ERROR_INVALID_ARGUMENT (listing the names) otherwise. */
cv_result cv_transfer_path_parse(const char *name, cv_transfer_path *out);
/* Process-wide: the path every transfer from now on takes (AUTO: chosen per
 * pair). Overrides CORVID_TRANSFER_PATH; cv_transfer_clear_path returns to it. */
cv_result cv_transfer_set_path(cv_transfer_path path);
void cv_transfer_clear_path(void);
/* The path a transfer from src to dst would take now (the mode in force,
 * resolved for the pair); CV_ERROR_UNSUPPORTED if a forced path does not fit. */
cv_result cv_transfer_choose_path(cv_device *src, cv_device *dst, cv_transfer_path *out);

#endif
