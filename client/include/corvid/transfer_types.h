/* The words of transfers between devices, as plain types: the paths bytes can
 * take and what one transfer reports. transfer.h's functions and the pieces
 * transfer.c is built from (its staging links and the peer path, in
 * client/src) all speak them, so they live below all of them.
 *
 *     cv_transfer_stats st;
 *     cv_transfer_buffer(src, a, 0, dst, b, 0, size, &st);   // transfer.h
 *     if (st.path == CV_TRANSFER_STAGED)
 *         printf("%.2f ms through host memory\n", st.total_ms); */
#ifndef CORVID_TRANSFER_TYPES_H
#define CORVID_TRANSFER_TYPES_H

#include "corvid/device_info.h"
#include "corvid/result.h"

typedef enum cv_transfer_path {
    CV_TRANSFER_AUTO = 0,
    CV_TRANSFER_STAGED = 1,
    CV_TRANSFER_HOST_IMPORT = 2,
    CV_TRANSFER_SHARED = 3,
    CV_TRANSFER_PEER = 4,
    CV_TRANSFER_DEVICE = 5, /* one GPU copy between two instances of one shared device (CORVID_VGPU_DEVICE=shared) */
    CV_TRANSFER_PATH_COUNT
} cv_transfer_path;

typedef struct cv_transfer_stats {
    uint64_t bytes;
    double read_ms;  /* source device -> staging (host memory, or shared memory) */
    double write_ms; /* staging -> destination device */
    double total_ms;
    cv_transfer_path path; /* the path the bytes took: STAGED, HOST_IMPORT, SHARED, PEER or DEVICE */
} cv_transfer_stats;

#endif
