/* The proxy's PEER transfer path (transfer_peer.h): a transfer between two
 * proxy devices is two messages, one in each session's ordered stream. The
 * source session gets PushTransfer (after the work that writes the region: the
 * node reads it once that is done, compresses it and sends it to the
 * destination node, addressed by the destination session's key); the
 * destination session gets AwaitTransfer (before the work that reads it: the
 * node holds that session's later messages until the bytes are written, or
 * fails them after its peer deadline). Neither waits for an answer, and no
 * partition byte passes through the client. */
#include <stdio.h>
#include <string.h>

#include "../transfer_peer.h"
#include "proxy_internal.h"

static bool peer_capable(cv_device *dev) {
    proxy_device *p = cv_device_backend_data(dev);
    pthread_mutex_lock(&p->lock);
    bool ok = p->has_session_key && p->dead == CV_OK && p->async_error == CV_OK;
    pthread_mutex_unlock(&p->lock);
    return ok;
}

static cv_result peer_move(const cv_transfer_peer_region *g, uint64_t transfer_id) {
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

static const cv_transfer_peer_ops ops = { .backend = "proxy", .capable = peer_capable, .move = peer_move };

void proxy_peer_register(void) { cv_transfer_peer_register(&ops); }
