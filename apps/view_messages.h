/* corvid-view's text messages to the page (docs/live-view.md): "hello" when it
 * connects (the stream, the camera and sun the view starts from, the settings the
 * page may change with their ranges), "stats" about four times a second, and
 * "error" for a refused input. Each is a malloc'd JSON string (NULL: out of memory). */
#ifndef CORVID_APPS_VIEW_MESSAGES_H
#define CORVID_APPS_VIEW_MESSAGES_H

#include "corvid/live.h"
#include "corvid/web_server.h"

char *view_hello_json(const cv_render_settings *s, const cv_scene *scene, cv_codec codec);
/* sent: bytes/s the server wrote to the viewers' sockets; received: what the driving page
 * says it received (0: not said). */
char *view_stats_json(const cv_live_stats *ls, const cv_web_stats *ws, double sent_bytes_per_s,
                      double received_bytes_per_s);
char *view_error_json(const char *message);

#endif
