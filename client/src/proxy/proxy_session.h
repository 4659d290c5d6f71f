/* The proxy device's session with its node (proxy_session.c): one gRPC stream,
 * a receiver thread, requests and their answers, and the failures the node
 * reports. The peer path (proxy_peer.h) and the backend table sit above it.
 *
 *     proxy_session_open(p, info);                 // connect, hello
 *     proxy_send(p, &message);                     // no answer awaited
 *     proxy_request(p, &message, &pending);        // waits for the answer
 *     proxy_session_close(p); */
#ifndef CORVID_PROXY_SESSION_H
#define CORVID_PROXY_SESSION_H

#include "proxy_internal.h"

/* Connects, says hello, fills *info. */
cv_result proxy_session_open(proxy_device *p, cv_device_info *info);
/* Closes the stream (waiting a little for the node to finish what was sent). */
void proxy_session_close(proxy_device *p);

/* Sends a message, after the device's before_send hook; fails if the session is dead or an earlier request
 * was refused. */
cv_result proxy_send(proxy_device *p, Corvid__ClientMessage *m);
/* proxy_send without the before_send hook. */
cv_result proxy_send_now(proxy_device *p, Corvid__ClientMessage *m);
/* Sends a request and waits for its answer. `pending` (seq is set here) says
 * where the answer goes. */
cv_result proxy_request(proxy_device *p, Corvid__ClientMessage *m, proxy_pending *pending);
/* A request whose answer is taken later, by another call (encoded reads: the device lock is not held while
 * the node reads and encodes). One at a time per device: a second start waits until the first finished.
 * Every successful start is followed by one finish. */
cv_result proxy_request_start(proxy_device *p, Corvid__ClientMessage *m, proxy_pending *pending);
cv_result proxy_request_finish(proxy_device *p, proxy_pending *pending);
/* The error every call returns once the session is unusable, or CV_OK. */
cv_result proxy_health(proxy_device *p);

/* Records a transfer failure the node reported (lock held): in the Reply to request `seq` (0: in the Completed
 * of `ticket`); see soft_failure. */
void proxy_note_failure(proxy_device *p, uint64_t failure, uint64_t seq, uint64_t ticket, cv_result result,
                        const char *message);
/* If a transfer failure waits to be reported to a wait for `ticket`: returns its error (naming the node) and
 * tells the node the client knows (ResumeAfterFailure); else CV_OK. Lock not held. */
cv_result proxy_report_failure(proxy_device *p, uint64_t ticket);

#endif
