/* The one lws protocol of the server: its callback routes each lws event to the
 * HTTP or WebSocket part. */
#ifndef CORVID_WEB_PROTOCOL_H
#define CORVID_WEB_PROTOCOL_H

#include "web_state.h"

int web_protocol_callback(struct lws *wsi, enum lws_callback_reasons reason, void *user, void *in, size_t len);

#endif
