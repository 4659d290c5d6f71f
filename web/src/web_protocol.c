/* The lws callback: one switch over lws' events (lws calls it on the service thread). */
#include "web_protocol.h"

#include "web_http.h"
#include "web_ws.h"

int web_protocol_callback(struct lws *wsi, enum lws_callback_reasons reason, void *user, void *in, size_t len) {
    cv_web_server *s = lws_context_user(lws_get_context(wsi));
    web_session *ss = user;
    switch (reason) {
    case LWS_CALLBACK_HTTP: return web_http_request(s, wsi, ss);
    case LWS_CALLBACK_HTTP_BODY: return web_http_body(s, wsi, ss, in, len);
    case LWS_CALLBACK_HTTP_BODY_COMPLETION: return web_http_body_done(s, wsi, ss);
    case LWS_CALLBACK_HTTP_WRITEABLE: return web_http_writeable(s, wsi, ss);
    case LWS_CALLBACK_HTTP_CONFIRM_UPGRADE: return web_http_confirm_upgrade(s, wsi);
    case LWS_CALLBACK_HTTP_DROP_PROTOCOL:
    case LWS_CALLBACK_CLOSED_HTTP:
        if (ss)
            web_http_reset(ss);
        return 0;
    case LWS_CALLBACK_ESTABLISHED:
        web_http_reset(ss);
        ss->conn = web_ws_open(s, wsi);
        return ss->conn ? 0 : -1;
    case LWS_CALLBACK_SERVER_WRITEABLE: return ss && ss->conn ? web_ws_writeable(ss->conn) : 0;
    case LWS_CALLBACK_RECEIVE: return ss && ss->conn ? web_ws_receive(ss->conn, in, len) : -1;
    case LWS_CALLBACK_CLOSED:
        if (ss && ss->conn) {
            web_ws_close(ss->conn);
            ss->conn = NULL;
        }
        return 0;
    case LWS_CALLBACK_EVENT_WAIT_CANCELLED: web_ws_wake(s); return 0;
    default: return lws_callback_http_dummy(wsi, reason, user, in, len);
    }
}
