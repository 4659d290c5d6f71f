/* corvid-view's viewers: the page's WebSocket connections between the web server
 * and the live loop. Frames from the live go to every connection with the frame
 * header of docs/live-view.md; input from a connection becomes cv_live_update;
 * acknowledgements of the newest connection (the one that drives) give the live
 * its credits; stats go out about four times a second.
 *
 *     view_session s;
 *     view_session_init(&s, &settings, CV_CODEC_JPEG);
 *     web.ws_open = view_session_open; ...; web.ws_user = &s;  // the server's callbacks
 *     cv_web_server_start(&web, &server);                      // pages wait for the live
 *     desc.frame = view_session_frame; desc.user = &s;         // the live's callback
 *     cv_live_start(&desc, &live);
 *     view_session_attach(&s, live, scene);
 *     ...
 *     view_session_tick(&s, server);                           // every 250 ms
 *     cv_web_server_stop(server);                              // before the live
 *     cv_live_stop(live);
 *     view_session_finish(&s);
 */
#ifndef CORVID_APPS_VIEW_SESSION_H
#define CORVID_APPS_VIEW_SESSION_H

#include <pthread.h>
#include <stdint.h>

#include "corvid/live.h"
#include "corvid/web_server.h"

/* The page's seq of inputs, mapped to the live's (seqs of several pages never mix). */
#define VIEW_SEQ_MAP 64u
/* Frames sent, remembered for the link estimate from their acknowledgements. */
#define VIEW_SENT_MAP 64u

typedef struct view_peer {
    cv_web_conn *conn;
    struct view_peer *next;
    uint64_t live_seq[VIEW_SEQ_MAP], page_seq[VIEW_SEQ_MAP]; /* ring, newest at (head - 1) */
    uint32_t seq_head, seq_count;
} view_peer;

typedef struct view_session {
    pthread_mutex_t lock;
    cv_live *live;
    const cv_scene *scene;
    cv_render_settings settings; /* as the live has them now */
    cv_codec codec;
    uint64_t seq;        /* the live's input seq, one per accepted input */
    view_peer *peers;    /* newest first: it drives the credits */
    uint64_t last_frame; /* index of the newest frame sent */
    uint64_t acked;      /* frames up to here acknowledged (or given up) */
    double last_ack_ms;
    /* The link: each frame's send time and size; the round trip of its acknowledgement less
     * the shortest recent one is its transfer time (docs/live-view.md). */
    uint64_t sent_index[VIEW_SENT_MAP];
    double sent_ms[VIEW_SENT_MAP];
    size_t sent_bytes[VIEW_SENT_MAP];
    double rtt_ms[VIEW_SENT_MAP]; /* recent round trips, for their minimum */
    uint32_t rtt_count, rtt_head;
    double link_bytes_per_s; /* the estimate reported to the live; 0 = none yet */
    double page_bytes_per_s; /* what the driving page says it received (shown in the stats) */
    uint64_t last_bytes;     /* cv_web_stats.bytes_sent at the last tick */
    double last_tick_ms;
    double sent_bytes_per_s;
} view_session;

void view_session_init(view_session *s, const cv_render_settings *settings, cv_codec codec);
/* The live, once started, and its scene: pages that connected before get their hello and
 * credits now (frames arrive only after credits, which only pages give). */
void view_session_attach(view_session *s, cv_live *live, const cv_scene *scene);
void view_session_finish(view_session *s);

/* cv_live_desc.frame */
void view_session_frame(const cv_live_frame *f, void *user);
/* cv_web_desc.ws_open / ws_text / ws_close */
void view_session_open(void *user, cv_web_conn *c);
void view_session_text(void *user, cv_web_conn *c, const char *text, size_t size);
void view_session_close(void *user, cv_web_conn *c);
/* Stats to every peer, and credits of frames lost on the way given back. */
void view_session_tick(view_session *s, cv_web_server *server);

#endif
