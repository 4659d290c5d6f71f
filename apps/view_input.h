/* corvid-view: the page's input messages (JSON text on the WebSocket, docs/live-view.md)
 * read into what they ask: new settings (camera, sun, render settings), a frame
 * acknowledged, a display report, a codec. A message with bad JSON, an unknown
 * field or a value out of range is refused whole, naming the field. */
#ifndef CORVID_APPS_VIEW_INPUT_H
#define CORVID_APPS_VIEW_INPUT_H

#include <stdbool.h>
#include <stdint.h>

#include "corvid/encode_types.h"
#include "corvid/render_settings.h"

typedef struct view_input {
    bool has_seq;
    uint64_t seq; /* the page's input event number */
    bool changed; /* camera, sun or settings given: `settings` is the result */
    cv_render_settings settings;
    bool has_ack;
    uint64_t ack;       /* frames up to this index were displayed (or dropped) */
    double bytes_per_s; /* with ack: the page's receive rate (shown; 0 = not given) */
    bool has_shown;
    uint64_t shown; /* input seq of the frame displayed */
    double m2p_ms;  /* its motion-to-photon */
    bool has_codec;
    cv_codec codec; /* "codec": "jpeg" | "h264" */
    bool keyframe;  /* "keyframe": true (an H.264 decoder starts over) */
} view_input;

/* The settings the page may change by name in {"settings": {...}}. */
extern const cv_render_setting_id view_page_settings[];
extern const uint32_t view_page_setting_count;

/* Reads `text` against the current settings. CV_ERROR_INVALID_ARGUMENT (message "input:
 * <field>: <why>") when the message is refused; *out is then not meaningful. */
cv_result view_input_parse(const char *text, const cv_render_settings *current, view_input *out);

#endif
