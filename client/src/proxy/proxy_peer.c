/* The proxy's PEER transfer path (proxy_peer.h, backend.h): a transfer between two
 * proxy devices is two messages, one in each session's ordered stream. The
 * source session gets PushTransfer (after the work that writes the region: the
 * node reads it once that is done, compresses it and sends it to the
 * destination node, addressed by the destination session's key); the
 * destination session gets AwaitTransfer (before the work that reads it: the
 * node holds that session's later messages until the bytes are written, or
 * fails them after its peer deadline). Neither waits for an answer, and no
 * partition byte passes through the client.
 *
 * A source that dies: once a call has told the caller that the source's
 * session is lost (so the caller knows its frame failed and has sent all of
 * it), the next message to a destination that awaits from that source first
 * gives those awaits up: a PeerPiece with `abort` to the destination node
 * (the client holds the session key), so a held await fails at once instead
 * of at the deadline, then ResumeAfterFailure{transfer_id} in the session's
 * stream, so what the caller sends next (the frame again) runs. */
#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "proxy_peer.h"
#include "proxy_session.h"

/* Every live proxy device of the process, by serial: an await names its source by serial, because the
 * source device may be destroyed first. The lock guards the list and the serials.
 * process-wide: a serial must name one device among all that a destination may hear of, and proxy devices
 * of every context in the process reach nodes through the same peer path. */
static pthread_mutex_t registry_lock = PTHREAD_MUTEX_INITIALIZER;
static proxy_device *registry;
static uint64_t next_serial;

/* Whether device `serial` is lost (reported: and the caller was told so); false for one that is gone. */
static bool source_lost(uint64_t serial, bool reported) {
    bool lost = false;
    pthread_mutex_lock(&registry_lock);
    for (proxy_device *d = registry; d; d = d->registry_next)
        if (d->serial == serial) {
            pthread_mutex_lock(&d->lock);
            lost = reported ? d->loss_reported : d->dead != CV_OK;
            pthread_mutex_unlock(&d->lock);
            break;
        }
    pthread_mutex_unlock(&registry_lock);
    return lost;
}

/* Tells the destination node to give the transfer up (a unary call with the session key). */
static void abort_transfer(proxy_device *p, uint64_t transfer_id) {
    Corvid__PeerPiece piece = CORVID__PEER_PIECE__INIT;
    piece.session_key = (ProtobufCBinaryData){ CV_NODE_SESSION_KEY_BYTES, p->session_key };
    piece.transfer_id = transfer_id;
    piece.abort = true;
    size_t n = corvid__peer_piece__get_packed_size(&piece);
    uint8_t *buf = malloc(n ? n : 1);
    if (!buf)
        return; /* the await then fails at its deadline */
    corvid__peer_piece__pack(&piece, buf);
    void *resp = NULL;
    size_t resp_size = 0;
    cv_rpc_client_unary(p->client, CV_NODE_METHOD_PEER_PIECE, buf, n, 5000, &resp, &resp_size, NULL);
    free(resp);
    free(buf);
}

void proxy_peer_abort_dead(proxy_device *p) {
    for (uint32_t i = 0; i < PROXY_AWAITS; i++) {
        pthread_mutex_lock(&p->lock);
        struct proxy_await a = p->awaits[i];
        pthread_mutex_unlock(&p->lock);
        if (!a.source || a.aborted || !source_lost(a.source, false))
            continue;
        pthread_mutex_lock(&p->lock);
        p->awaits[i].aborted = true;
        pthread_mutex_unlock(&p->lock);
        abort_transfer(p, a.transfer_id);
    }
}

void proxy_peer_settle(proxy_device *p) {
    for (uint32_t i = 0; i < PROXY_AWAITS; i++) {
        pthread_mutex_lock(&p->lock);
        struct proxy_await a = p->awaits[i];
        pthread_mutex_unlock(&p->lock);
        if (!a.source || a.given_up || !source_lost(a.source, true))
            continue;
        pthread_mutex_lock(&p->lock);
        p->awaits[i].given_up = p->awaits[i].aborted = true;
        if (p->soft_failure && p->soft_seq && p->soft_seq >= a.seq) {
            p->resumed = p->soft_failure; /* that failure came from this frame, which the caller knows failed */
            p->soft_failure = 0;
        }
        pthread_mutex_unlock(&p->lock);
        if (!a.aborted)
            abort_transfer(p, a.transfer_id);
        Corvid__ResumeAfterFailure resume = CORVID__RESUME_AFTER_FAILURE__INIT;
        resume.transfer_id = a.transfer_id;
        Corvid__ClientMessage m = CORVID__CLIENT_MESSAGE__INIT;
        m.msg_case = CORVID__CLIENT_MESSAGE__MSG_RESUME;
        m.resume = &resume;
        proxy_send_now(p, &m);
    }
}

void proxy_peer_register(proxy_device *p) {
    p->before_send = proxy_peer_settle;
    pthread_mutex_lock(&registry_lock);
    p->serial = ++next_serial;
    p->registry_next = registry;
    registry = p;
    pthread_mutex_unlock(&registry_lock);
}

void proxy_peer_unregister(proxy_device *p) {
    pthread_mutex_lock(&registry_lock);
    for (proxy_device **at = &registry; *at; at = &(*at)->registry_next)
        if (*at == p) {
            *at = p->registry_next;
            break;
        }
    pthread_mutex_unlock(&registry_lock);
}

bool proxy_peer_capable(cv_backend_device *p) {
    pthread_mutex_lock(&p->lock);
    bool ok = p->has_session_key && p->dead == CV_OK && p->async_error == CV_OK;
    pthread_mutex_unlock(&p->lock);
    return ok;
}

cv_result proxy_peer_move(const cv_transfer_peer_region *g, uint64_t transfer_id) {
    proxy_device *src = cv_device_backend_data(g->src), *dst = cv_device_backend_data(g->dst);
    Corvid__PushTransfer push = CORVID__PUSH_TRANSFER__INIT;
    push.transfer_id = transfer_id;
    push.id = g->src_id;
    Corvid__AwaitTransfer wait = CORVID__AWAIT_TRANSFER__INIT;
    wait.transfer_id = transfer_id;
    wait.id = g->dst_id;
    wait.deadline_ms = dst->peer_deadline_ms;
    if (g->texture) {
        push.x = g->src_rect.x;
        push.y = g->src_rect.y;
        push.width = wait.width = g->src_rect.width;
        push.height = wait.height = g->src_rect.height;
        wait.x = g->dst_x;
        wait.y = g->dst_y;
    } else {
        push.offset = g->src_offset;
        wait.offset = g->dst_offset;
        push.size = wait.size = g->size;
    }
    push.destination = dst->endpoint;
    push.session_key = (ProtobufCBinaryData){ CV_NODE_SESSION_KEY_BYTES, dst->session_key };
    Corvid__ClientMessage m = CORVID__CLIENT_MESSAGE__INIT;
    m.msg_case = CORVID__CLIENT_MESSAGE__MSG_PUSH_TRANSFER;
    m.push_transfer = &push;
    cv_result r = proxy_send(src, &m);
    if (r != CV_OK) /* nothing was asked of the destination: it changes nothing */
        return r;
    Corvid__ClientMessage a = CORVID__CLIENT_MESSAGE__INIT;
    a.msg_case = CORVID__CLIENT_MESSAGE__MSG_AWAIT_TRANSFER;
    a.await_transfer = &wait;
    r = proxy_send(dst, &a);
    if (r == CV_OK) {
        pthread_mutex_lock(&dst->lock);
        dst->awaits[dst->awaits_next++ % PROXY_AWAITS] = (struct proxy_await){ .transfer_id = transfer_id,
                                                                               .seq = a.seq,
                                                                               .source = src->serial };
        pthread_mutex_unlock(&dst->lock);
    }
    pthread_mutex_lock(&src->lock);
    src->stats.peer_pushes++;
    src->stats.peer_push_bytes += g->size;
    pthread_mutex_unlock(&src->lock);
    if (r == CV_OK) {
        pthread_mutex_lock(&dst->lock);
        dst->stats.peer_awaits++;
        dst->stats.peer_await_bytes += g->size;
        pthread_mutex_unlock(&dst->lock);
    }
    return r;
}
