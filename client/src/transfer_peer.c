/* The PEER transfer path (transfer_peer.h): the backend's move, numbered and
 * timed. */
#include "transfer_peer.h"

#include <stdatomic.h>

#include "corvid/clock.h"
#include "device_internal.h"

/* process-wide: transfer ids must increase across every device pair of the process, because a destination
 * session takes its transfers in id order, and the pairs may belong to any context. */
static atomic_uint_fast64_t next_transfer_id;

bool cv_transfer_peer_pair(cv_device *src, cv_device *dst) {
    return src && dst && src != dst && src->backend == dst->backend && src->backend->peer_move &&
           src->backend->peer_capable(src->bd) && dst->backend->peer_capable(dst->bd);
}

cv_result cv_transfer_peer_run(const cv_transfer_peer_region *region, cv_transfer_stats *stats) {
    if (!cv_transfer_peer_pair(region->src, region->dst))
        return cv_error(CV_ERROR_UNSUPPORTED, "transfer from device '%s' to device '%s': no peer path between them",
                        cv_device_label(region->src), cv_device_label(region->dst));
    double start = cv_now_ms();
    cv_result r = region->src->backend->peer_move(region, atomic_fetch_add(&next_transfer_id, 1) + 1);
    double ms = cv_now_ms() - start;
    if (r == CV_OK && stats) {
        *stats = (cv_transfer_stats){ .bytes = region->size, .path = CV_TRANSFER_PEER, .total_ms = ms };
    }
    return r;
}
