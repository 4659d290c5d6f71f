/* corvid-view's small HTTP API (a cv_http_handler, user: the view_session):
 *   GET /api/v1/view/snapshot.png   the newest frame, lossless 8-bit (what the page shows, before its codec)
 *   GET /api/v1/view/snapshot.exr   its radiance, linear half-float RGBA
 *   GET /api/v1/view/stats          the live's figures, as the page's stats message
 * A snapshot waits for the frame being rendered (cv_live_snapshot), which holds the
 * server's thread that long: a few frame times. */
#ifndef CORVID_APPS_VIEW_API_H
#define CORVID_APPS_VIEW_API_H

#include "corvid/web_server.h"

void view_api_handle(void *user, const cv_http_request *req, cv_http_response *resp);

#endif
