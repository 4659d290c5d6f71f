/* One checked transfer, shared by the synchronous paths (transfer.c) and
 * the asynchronous rings (transfer_ring.c): what moves, from where to where.
 * transfer_buffer_job / transfer_texture_job run every check of
 * cv_transfer_buffer / cv_transfer_texture (handles loaded, types, formats,
 * ranges) and fill a job; they change nothing. */
#ifndef CORVID_TRANSFER_JOB_H
#define CORVID_TRANSFER_JOB_H

#include "transfer_link.h"

typedef struct job {
    cv_device *src, *dst;
    uint64_t src_id, dst_id;
    bool texture;
    uint64_t src_offset, dst_offset, size; /* buffers */
    cv_rect src_rect;                      /* textures */
    uint32_t dst_x, dst_y, rows_per_chunk;
    uint64_t chunk_bytes, row_bytes;
    uint8_t *host[2];   /* STAGED: the slots */
    transfer_link link; /* SHARED, HOST_IMPORT */
} transfer_job;

cv_result transfer_buffer_job(cv_device *src, cv_buffer src_buffer, uint64_t src_offset, cv_device *dst,
                              cv_buffer dst_buffer, uint64_t dst_offset, uint64_t size, transfer_job *out);
cv_result transfer_texture_job(cv_device *src, cv_texture src_texture, cv_rect src_rect, cv_device *dst,
                               cv_texture dst_texture, uint32_t dst_x, uint32_t dst_y, transfer_job *out);
/* The DEVICE path: the whole job as one direct copy (device_internal.h,
 * cv_device_link_copy_device); its tickets on both devices, no host wait. */
cv_result transfer_job_device(const transfer_job *j, uint64_t *src_ticket, uint64_t *dst_ticket);

#endif
