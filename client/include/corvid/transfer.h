/* Cross-device transfers: the basis of multi-GPU partitions.
 *
 * Copies a buffer range or a texture rectangle from a resource on one device to
 * a resource on another (any backends), through host staging memory, and
 * reports the bytes moved and the time taken. Both devices must have the
 * handles loaded; ranges are checked on both sides before anything moves. */
#ifndef CORVID_TRANSFER_H
#define CORVID_TRANSFER_H

#include "corvid/device.h"

typedef struct cv_transfer_stats {
    uint64_t bytes;
    double read_ms;     /* source device -> host */
    double write_ms;    /* host -> destination device */
    double total_ms;
} cv_transfer_stats;

cv_result cv_transfer_buffer(cv_device *src, cv_buffer src_buffer, uint64_t src_offset,
                             cv_device *dst, cv_buffer dst_buffer, uint64_t dst_offset,
                             uint64_t size, cv_transfer_stats *stats);
cv_result cv_transfer_texture(cv_device *src, cv_texture src_texture, cv_rect src_rect,
                              cv_device *dst, cv_texture dst_texture, uint32_t dst_x,
                              uint32_t dst_y, cv_transfer_stats *stats);

#endif
