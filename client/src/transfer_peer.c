/* The PEER transfer path (transfer_peer.h): the registered backend's move,
 * numbered and timed. */
#include "transfer_peer.h"

#include <stdatomic.h>
#include <string.h>

#include "corvid/clock.h"
#include "device_internal.h"

/* Process-wide on purpose: one backend (the proxy) registers its table once, from any thread that creates one
 * of its devices; transfer ids must increase across every device pair of the process, because a destination
 * session takes its transfers in id order. */
static _Atomic(const cv_transfer_peer_ops *) registered;
static atomic_uint_fast64_t next_transfer_id;

void cv_transfer_peer_register(const cv_transfer_peer_ops *ops) {
    const cv_transfer_peer_ops *none = NULL;
    atomic_compare_exchange_strong(&registered, &none, ops);
}

bool cv_transfer_peer_pair(cv_device *src, cv_device *dst) {
    const cv_transfer_peer_ops *ops = atomic_load(&registered);
    return ops && src && dst && src != dst && strcmp(cv_device_get_info(src)->backend, ops->backend) == 0 &&
           strcmp(cv_device_get_info(dst)->backend, ops->backend) == 0 && ops->capable(src) && ops->capable(dst);
}

cv_result cv_transfer_peer_run(const cv_transfer_peer_region *region, cv_transfer_stats *stats) {
    const cv_transfer_peer_ops *ops = atomic_load(&registered);
    if (!ops || !cv_transfer_peer_pair(region->src, region->dst))
        return cv_error(CV_ERROR_UNSUPPORTED, "transfer from device '%s' to device '%s': no peer path between them",
                        cv_device_label(region->src), cv_device_label(region->dst));
    double start = cv_now_ms();
    cv_result r = ops->move(region, atomic_fetch_add(&next_transfer_id, 1) + 1);
    double ms = cv_now_ms() - start;
    if (r == CV_OK && stats) {
        *stats = (cv_transfer_stats){ .bytes = region->size, .path = CV_TRANSFER_PEER, .total_ms = ms };
    }
    return r;
}
