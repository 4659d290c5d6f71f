/* The live's shared state (corvid/live.h): what the caller's calls, the
 * render thread (live_render.c), the encode thread (live_encode.c) and
 * snapshots (live_snapshot.c) hand each other, all under one lock.
 *
 * Steps are numbered from 1 in the order the render thread finished them.
 * The display of step n lives in one of the renderer's
 * CV_RENDER_DISPLAY_SLOTS textures until step n + CV_RENDER_DISPLAY_SLOTS
 * rewrites it, so while the encoder reads step `reading` the render thread
 * starts no step past reading + CV_RENDER_DISPLAY_SLOTS - 1; a step that
 * changes the image size (the renderer may make new textures) starts only
 * when the encoder reads nothing, and no read starts during it. */
#ifndef CORVID_LIVE_INTERNAL_H
#define CORVID_LIVE_INTERNAL_H

#include <pthread.h>

#include "corvid/live.h"
#include "live_rate.h"
#include "live_window.h"

/* The newest finished step, which the encoder presents when it has credit. */
typedef struct live_published {
    uint64_t step; /* 0: none yet */
    cv_render_step info;
    uint64_t input_seq; /* the update its settings came from */
    double input_ms;    /* when that update came (cv_now_ms) */
    bool taken;         /* the encoder took it (a newer step spoils it otherwise) */
} live_published;

struct cv_live {
    cv_live_desc desc; /* as started; settings, codec and encode: the first ones */
    uint32_t max_accumulate;
    pthread_t render_thread, encode_thread;
    bool render_started, encode_started;
    /* Called by the renderer on the render thread: fills passes, then calls
     * the user's observer of the settings being rendered. */
    cv_render_observer observer;
    const cv_render_observer *user_observer; /* render thread only */

    pthread_mutex_t lock;
    pthread_cond_t render_cond;   /* render thread: input, a read done, a hold released, stop */
    pthread_cond_t encode_cond;   /* encode thread: a step finished, credit, stop */
    pthread_cond_t snapshot_cond; /* snapshots: the render thread paused */

    /* Everything below under lock. */
    bool stopping, failed;
    char error[256];

    /* Input: the newest update not yet taken by the render thread. */
    bool has_pending;
    cv_render_settings pending;
    uint64_t pending_seq;
    double pending_ms;
    uint32_t width, height; /* of the newest settings accepted */

    /* Render side. */
    uint64_t steps; /* finished */
    bool stepping, resizing;
    bool still;    /* the view reached max_accumulate with no newer input: the render thread sleeps */
    uint32_t hold; /* snapshots reading: no step starts */
    uint64_t last_ticket;
    live_published published;

    /* Encode side. */
    uint64_t reading; /* the step the encoder reads; 0: none */
    uint32_t credit;
    cv_codec codec;
    cv_encode_params encode; /* as last set (fps, zstd level; quality and bitrate start the rate) */
    bool keyframe_request;
    live_rate rate;

    /* Stats. */
    uint64_t rendered, presented, spoiled, bytes;
    live_window presented_window, rendered_window;
    double motion_to_photon_ms, motion_to_photon_max_ms;
    double input_age_ms, input_age_max_ms;
    uint64_t input_seq;     /* of the last presented frame */
    uint64_t displayed_seq; /* the viewer's last display report */
    uint32_t accumulated, frame_width, frame_height;
    char passes[2048];
};

/* Ends the live after a failure (lock held): keeps the first message, wakes
 * every waiter. */
void live_fail_locked(cv_live *l, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

/* The threads' bodies (pthread start routines; arg: the cv_live). */
void *live_render_main(void *arg);
void *live_encode_main(void *arg);

#endif
