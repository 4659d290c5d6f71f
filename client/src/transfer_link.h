/* Cross-device links for transfer.c: the staging memory that the SHARED and
 * HOST_IMPORT paths move chunks through (transfer_link.c), and the choice of
 * path for a pair of devices (transfer_path.c). */
#ifndef CORVID_TRANSFER_LINK_H
#define CORVID_TRANSFER_LINK_H

#include "corvid/transfer_types.h"

/* Two slots of slot_bytes each, at offsets 0 and slot_bytes of both stagings. */
typedef struct transfer_link {
    void *src_staging, *dst_staging; /* the backends' objects for the one memory */
    uint64_t slot_bytes;
    bool held; /* the link lock is held (transfer_link_release drops it) */
} transfer_link;

/* Gets the stagings of the pair for a SHARED or HOST_IMPORT path that
 * cv_transfer_choose_path accepted. Link transfers run one at a time in the
 * process (the stagings are reused): on success the link lock is held until
 * transfer_link_release. */
cv_result transfer_link_acquire(cv_device *src, cv_device *dst, cv_transfer_path path, transfer_link *out);
void transfer_link_release(transfer_link *link);

#endif
