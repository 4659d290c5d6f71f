/* The PEER transfer path (transfer.h): two devices whose backend can move data
 * between its own devices without the client, such as proxy devices on different
 * corvid-node sessions (the nodes send the bytes to each other; docs/node.md,
 * "Clusters"). The backend registers its operations when it creates a device;
 * the core stays free of gRPC.
 *
 *     static const cv_transfer_peer_ops ops = { "proxy", capable, move };
 *     cv_transfer_peer_register(&ops);          // at the backend's device_create
 *     ...
 *     if (cv_transfer_peer_pair(src, dst))       // transfer_path.c: path PEER
 *         cv_transfer_peer_run(&region, &stats);  // transfer.c */
#ifndef CORVID_TRANSFER_PEER_H
#define CORVID_TRANSFER_PEER_H

#include "corvid/transfer_types.h"

/* One transfer, checked by transfer.c: a texture rect to (dst_x, dst_y), or a buffer range. */
typedef struct cv_transfer_peer_region {
    cv_device *src, *dst;
    uint64_t src_id, dst_id;
    bool texture;
    cv_rect src_rect;
    uint32_t dst_x, dst_y;
    uint64_t src_offset, dst_offset, size; /* size: bytes either way */
} cv_transfer_peer_region;

typedef struct cv_transfer_peer_ops {
    const char *backend; /* cv_device_info.backend of its devices */
    /* Whether this device (of that backend) can send to / receive from a peer now. */
    bool (*capable)(cv_device *dev);
    /* Starts the move (returns without waiting for it); transfer_id increases from call to call. */
    cv_result (*move)(const cv_transfer_peer_region *region, uint64_t transfer_id);
} cv_transfer_peer_ops;

/* Idempotent; one backend may register (a second, different one is ignored). */
void cv_transfer_peer_register(const cv_transfer_peer_ops *ops);
/* Two different devices of the registered backend, both capable. */
bool cv_transfer_peer_pair(cv_device *src, cv_device *dst);
/* Runs the move; stats (may be NULL) get bytes, path PEER and the time to start it. */
cv_result cv_transfer_peer_run(const cv_transfer_peer_region *region, cv_transfer_stats *stats);

#endif
