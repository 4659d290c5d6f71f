/* The PEER transfer path (transfer.h): two devices whose backend can move data
 * between its own devices without the client, such as proxy devices on different
 * corvid-node sessions (the nodes send the bytes to each other; docs/node.md,
 * "Clusters"). The backend offers it in its table (backend.h: peer_capable,
 * peer_move); this file numbers and times the moves.
 *
 *     if (cv_transfer_peer_pair(src, dst))       // transfer_path.c: path PEER
 *         cv_transfer_peer_run(&region, &stats);  // transfer.c */
#ifndef CORVID_TRANSFER_PEER_H
#define CORVID_TRANSFER_PEER_H

#include "corvid/backend.h"
#include "corvid/transfer_types.h"

/* Two different devices of one backend that has the peer path, both capable now. */
bool cv_transfer_peer_pair(cv_device *src, cv_device *dst);
/* Runs the move; stats (may be NULL) get bytes, path PEER and the time to start it. */
cv_result cv_transfer_peer_run(const cv_transfer_peer_region *region, cv_transfer_stats *stats);

#endif
