/* The proxy's PEER transfer path (proxy_peer.c): moves between proxy devices
 * on different node sessions, and the process's registry of proxy devices
 * that names an await's source. It sits above the session (proxy_session.h)
 * and hooks into it with the device's before_send.
 *
 *     proxy_peer_register(p);      // device create: a serial, and the hook
 *     ...                          // backend.h peer_capable / peer_move
 *     proxy_peer_unregister(p);    // before freeing the device */
#ifndef CORVID_PROXY_PEER_H
#define CORVID_PROXY_PEER_H

#include "proxy_internal.h"

/* Registers the device in the process's registry and sets its before_send to proxy_peer_settle; unregister
 * before freeing it. */
void proxy_peer_register(proxy_device *p);
void proxy_peer_unregister(proxy_device *p);
/* The backend's PEER path (backend.h: peer_capable, peer_move). */
bool proxy_peer_capable(cv_backend_device *p);
cv_result proxy_peer_move(const cv_transfer_peer_region *region, uint64_t transfer_id);
/* Gives up awaits of this session whose source the caller knows is lost: tells the node (so a held await
 * fails at once) and resumes the session after them, in its stream. Runs before every send. */
void proxy_peer_settle(proxy_device *p);
/* Tells the node to fail at once the held awaits whose source device died (without resuming: a wait that
 * then meets the skipped work reports it). Safe at any time. */
void proxy_peer_abort_dead(proxy_device *p);

#endif
