/* The live loop between the renderer and a viewer: frames as they are made,
 * encoded on the primary's machine, against the viewer's credit.
 *
 * A cv_live runs two threads over the caller's renderer:
 *
 *   render thread   takes the newest settings (cv_live_update: input is never
 *                   queued behind frames, the newest settings win and their seq
 *                   is recorded) and calls cv_renderer_step; a still view keeps
 *                   accumulating until max_accumulate frames, then the thread
 *                   sleeps until an update comes (no busy loop).
 *   encode thread   when the consumer has credit (cv_live_credit), reads the
 *                   newest finished display slot through a cv_frame_reader
 *                   (corvid/frame_reader.h: on a proxy device the node reads
 *                   and encodes, so only the encoded bytes cross the link) and
 *                   calls desc.frame with it.
 *
 * Frames are never queued: a frame rendered while there is no credit, or
 * superseded by a newer frame before the encoder got to it, is spoiled
 * (counted in stats). The renderer's CV_RENDER_DISPLAY_SLOTS display textures
 * form a ring; the render thread never runs more than slots - 1 steps ahead of
 * the slot the encoder is reading, so that slot is never overwritten under it.
 * With H.264 spoiling happens before the encoder (it only sees the frames it
 * sends), so the stream stays decodable; a keyframe is sent first, after a
 * codec or size change, and on request (cv_live_set_codec with
 * encode.keyframe).
 *
 * Bandwidth: from the consumer's measured link (cv_live_report_link) the
 * live keeps frame bytes * fps under 80% of it: JPEG quality (40..90) moves
 * with the measured size of the last frames, the H.264 bitrate is set to 80%
 * of the link (docs/live.md has the rule); stats say what was chosen.
 *
 * Motion-to-photon: each frame carries input_age_ms, from the cv_live_update
 * of its input_seq to its callback (the server's part); the viewer reports the
 * end-to-end figure with cv_live_report_display.
 *
 * Stats (cv_live_get_stats): counts, rates and means over the last second,
 * and the passes of the last measured frame: one step in 250 ms is measured
 * (a measured step waits for its timings instead of pipelining), every step
 * when the settings carry an observer of their own, which is still called.
 *
 * Trace: with desc.trace, every step, read, encode and frame callback is a
 * span, every spoiled step an instant (corvid/live_trace.h).
 *
 * Errors: a step or read that fails (a lost device) ends the live: no more
 * frames, stats.error says what failed, updates and snapshots return
 * CV_ERROR_BAD_STATE with it; every call still returns and cv_live_stop joins.
 * Calls other than start and stop may come from any thread, the frame
 * callback's included (stop not: it joins that thread).
 *
 *     static void on_frame(const cv_live_frame *f, void *user) {
 *         send_to_viewer(user, f->data, f->size);  // copy: data is valid during the call only
 *     }
 *
 *     cv_live_desc d = { .renderer = r, .primary = devices[0],
 *                        .settings = { .width = 640, .height = 360 },
 *                        .codec = CV_CODEC_JPEG, .frame = on_frame, .user = conn };
 *     cv_live *live;
 *     if (cv_live_start(&d, &live) != CV_OK) fprintf(stderr, "%s\n", cv_last_error());
 *     cv_live_credit(live, 2);                     // the viewer can take two frames
 *     ...
 *     s.camera_eye[0] += 0.1f;                     // on input from the viewer
 *     cv_live_update(live, &s, ++seq);
 *     cv_live_credit(live, 1);                     // for each frame the viewer displayed
 *     cv_live_report_display(live, seq_shown, m2p_ms);
 *     ...
 *     cv_encoded png = { 0 };
 *     cv_live_snapshot(live, CV_CODEC_PNG, &png);  // the newest frame, lossless
 *     cv_encoded_free(&png);
 *     cv_live_stop(live);
 */
#ifndef CORVID_LIVE_H
#define CORVID_LIVE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "corvid/encode_types.h"
#include "corvid/live_trace.h"
#include "corvid/renderer.h"

typedef struct cv_live cv_live;

typedef struct cv_live_frame {
    uint64_t index;     /* frames presented to the consumer, from 1 */
    uint64_t input_seq; /* newest cv_live_update seq this frame reflects */
    uint32_t accumulated, width, height;
    cv_codec codec;
    bool keyframe;
    const uint8_t *data; /* valid during the callback */
    size_t size;
    double render_ms, read_ms, encode_ms; /* this frame's: step, device read, encode */
    double input_age_ms;                  /* from the cv_live_update of input_seq to now (server side m2p part) */
    /* The whole frame reader call: read + encode, plus for a proxy device the request and reply on the
     * link (so fetch_ms - read_ms - encode_ms is the link's part, with the node's overhead). */
    double fetch_ms;
} cv_live_frame;

typedef struct cv_live_desc {
    cv_renderer *renderer;       /* the caller's; outlives the live, which alone steps it until stopped */
    cv_device *primary;          /* the renderer's devices[0] */
    cv_render_settings settings; /* the first frame's */
    cv_codec codec;              /* JPEG or H264 */
    cv_encode_params encode;     /* starting quality / bitrate (adapted from measurements) */
    uint32_t max_accumulate;     /* a still view stops rendering after this many frames; 0 = 256 */
    void (*frame)(const cv_live_frame *f, void *user); /* on the live's encode thread */
    void *user;
    cv_live_trace *trace; /* optional (corvid/live_trace.h): the frames' spans are recorded into it */
} cv_live_desc;

cv_result cv_live_start(const cv_live_desc *desc, cv_live **out);

/* New settings from the viewer's input, applied to the next frame submitted; checked here
 * (a bad one returns the error and changes nothing). seq increases per input event. */
cv_result cv_live_update(cv_live *l, const cv_render_settings *s, uint64_t seq);

/* The consumer can take n more frames: frames are encoded only against credit; a frame
 * rendered while there is none is spoiled (counted), never queued. */
void cv_live_credit(cv_live *l, uint32_t n);

/* JPEG or H264 from the next frame on (encode: its starting quality / bitrate,
 * NULL = defaults; keyframe = true asks for a keyframe, with the same codec
 * too). The same codec with quality and bitrate 0 keeps what the adaptation
 * chose (a keyframe request alone). */
cv_result cv_live_set_codec(cv_live *l, cv_codec codec, const cv_encode_params *encode);

/* The consumer's measured link bandwidth (bytes/s) and display report (input seq shown,
 * motion-to-photon measured by the viewer, ms). */
void cv_live_report_link(cv_live *l, double bytes_per_s);
void cv_live_report_display(cv_live *l, uint64_t input_seq, double motion_to_photon_ms);

/* A lossless copy of the newest frame: CV_CODEC_PNG (8-bit display) or
 * CV_CODEC_ZSTD of the radiance (RGBA32F; *out's width/height set). The newest
 * step finished: on a still view the frame presented last, while the view
 * moves possibly a step the consumer has not been sent yet (rendering holds
 * while it is read, so its display and radiance are one frame's). Read on the
 * primary's machine (a frame reader of its own). Waits at most 10 s for a
 * step to finish. */
cv_result cv_live_snapshot(cv_live *l, cv_codec codec, cv_encoded *out);

typedef struct cv_live_stats {
    uint64_t rendered, presented, spoiled;
    double fps;                                          /* presented per second, last second */
    double render_ms, read_ms, encode_ms;                /* means over the last second; with no frame in it
                                                          * (a view at rest), the last frame's */
    uint64_t bytes;                                      /* encoded bytes presented, total */
    double link_bytes_per_s;                             /* last reported */
    double motion_to_photon_ms, motion_to_photon_max_ms; /* last, max reported */
    uint32_t quality, bitrate_kbps;                      /* what the adaptation chose */
    uint32_t accumulated;
    char passes[2048]; /* "gbuffer dev0 1.20 ms\ntrace dev1 3.40 ms\n..." of the last frame */
    /* Beyond the brief's figures: */
    cv_codec codec;
    uint32_t width, height; /* of the last presented frame */
    uint64_t input_seq;     /* of the last presented frame */
    uint64_t displayed_seq; /* last reported by cv_live_report_display */
    /* The server's part of motion-to-photon: input_age_ms of the first frame presented for each
     * input (a still view's later frames are not counted), last and max. */
    double input_age_ms, input_age_max_ms;
    bool still;      /* the view reached max_accumulate with no newer input: rendering waits for one */
    bool failed;     /* a step or read failed: the live renders no more */
    char error[256]; /* what failed ("" while running) */
} cv_live_stats;

void cv_live_get_stats(cv_live *l, cv_live_stats *out);
void cv_live_stop(cv_live *l); /* joins its threads; the renderer is idle afterwards */

#endif
