/* WebSocket connections on "/ws": their outgoing messages (one frame slot that a
 * newer frame replaces, a bounded text queue), incoming text assembled from
 * fragments, and the wake-up of the service thread when another thread sends. */
#ifndef CORVID_WEB_WS_H
#define CORVID_WEB_WS_H

#include "web_state.h"

/* After the upgrade (service thread): a connection, listed, its open callback called. */
cv_web_conn *web_ws_open(cv_web_server *s, struct lws *wsi);
/* The connection closed: its close callback, then it is freed. */
void web_ws_close(cv_web_conn *c);
/* Asks lws for a write callback on every connection that has new messages. */
void web_ws_wake(cv_web_server *s);
/* Writes one waiting message; <0 = close the connection. */
int web_ws_writeable(cv_web_conn *c);
/* One piece of an incoming message; a complete text message goes to ws_text. <0 = close. */
int web_ws_receive(cv_web_conn *c, const void *in, size_t len);

#endif
