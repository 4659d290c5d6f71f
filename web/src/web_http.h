/* HTTP on the web server: the token check, routing (assets, "/api/" to the
 * handler, refusals), request bodies and writing the response. All on the
 * service thread. */
#ifndef CORVID_WEB_HTTP_H
#define CORVID_WEB_HTTP_H

#include "web_state.h"

/* LWS_CALLBACK_HTTP: a request's headers arrived. Returns lws' verdict (<0 = close). */
int web_http_request(cv_web_server *s, struct lws *wsi, web_session *ss);
/* LWS_CALLBACK_HTTP_BODY: a piece of the request body. */
int web_http_body(cv_web_server *s, struct lws *wsi, web_session *ss, const void *in, size_t len);
/* LWS_CALLBACK_HTTP_BODY_COMPLETION: the body is complete: the handler runs. */
int web_http_body_done(cv_web_server *s, struct lws *wsi, web_session *ss);
/* LWS_CALLBACK_HTTP_WRITEABLE: the next piece of the response body. */
int web_http_writeable(cv_web_server *s, struct lws *wsi, web_session *ss);
/* LWS_CALLBACK_HTTP_CONFIRM_UPGRADE: only "/ws", with the token. >0 = refused (answered). */
int web_http_confirm_upgrade(cv_web_server *s, struct lws *wsi);
/* Frees the transaction's request and response (the connection may serve another). */
void web_http_reset(web_session *ss);

#endif
