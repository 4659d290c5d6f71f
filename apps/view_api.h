/* corvid-view's HTTP API (a cv_http_handler, user: a view_api):
 *   GET /api/v1/view                the view's job defaults: {"scene": "default" | sha256 | null, "width",
 *                                   "height", "note"}: the gateway scene a job from the page renders (null:
 *                                   none, "note" says why)
 *   GET /api/v1/view/snapshot.png   the newest frame, lossless 8-bit (what the page shows, before its codec)
 *   GET /api/v1/view/snapshot.exr   its radiance, linear half-float RGBA
 *   GET /api/v1/view/stats          the live's figures, as the page's stats message
 * and every other /api/ request goes to the REST gateway (corvid/gateway.h), so that the page
 * and scripts reach both on one port. A snapshot waits for the frame being rendered
 * (cv_live_snapshot), which holds the server's thread that long: a few frame times.
 *
 *     view_api api;
 *     view_api_init(&api, &session, gateway, width, height);
 *     web.api = view_api_handle; web.api_user = &api;
 *     view_api_register_scene(&api, "model.glb");   // or NULL: the gateway's built-in room
 *     ...
 *     view_api_finish(&api);                        // after the server stopped
 */
#ifndef CORVID_APPS_VIEW_API_H
#define CORVID_APPS_VIEW_API_H

#include <pthread.h>

#include "corvid/gateway.h"
#include "corvid/sha256.h"
#include "corvid/web_server.h"
#include "view_session.h"

typedef struct view_api {
    view_session *session;
    cv_gateway *gateway;
    uint32_t width, height;
    pthread_mutex_t lock;           /* the scene is set while the server runs */
    char scene[CV_SHA256_HEX_SIZE]; /* "" = none for jobs */
    char note[256];                 /* why there is none */
} view_api;

void view_api_init(view_api *a, view_session *session, cv_gateway *gateway, uint32_t width, uint32_t height);
void view_api_finish(view_api *a);

/* The view's scene for jobs: `model` (a file) uploaded into the gateway's store, or the built-in room for
 * NULL. A model the gateway refuses leaves jobs without a scene; the reason is the API's "note" (and the
 * result, for the caller to log). */
cv_result view_api_register_scene(view_api *a, const char *model);
/* Jobs have no scene of the view's (a procedural scene the gateway does not make): `why`. */
void view_api_no_scene(view_api *a, const char *why);

void view_api_handle(void *user, const cv_http_request *req, cv_http_response *resp);

#endif
