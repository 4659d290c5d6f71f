/* bench_live's synthetic viewer: what corvid-view's page does with the live's
 * frames (credits, decode, input, motion-to-photon), and the figures of a run
 * (its own and the raw-planes peer's), printed as one row each. */
#ifndef CORVID_BENCH_LIVE_VIEWER_H
#define CORVID_BENCH_LIVE_VIEWER_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "corvid/live.h"
#include "corvid/live_trace.h"
#include "corvid/renderer.h"

/* Frames in flight to the viewer: corvid-view's page rule (apps/view_session.c, VIEW_START_CREDITS: two
 * at the start, one back per frame displayed), mirrored: it is not factored out of corvid-view. */
#define VIEWER_CREDITS 2u
/* Degrees the camera turns about its target per input event. */
#define VIEWER_ORBIT_DEGREES 2.0f

/* One displayed frame's figures (ms; arrive and shown on cv_now_ms's clock). */
typedef struct viewer_frame {
    double arrive_ms, shown_ms;
    size_t bytes;
    double render_ms, read_ms, encode_ms, transfer_ms, decode_ms;
} viewer_frame;

typedef struct viewer_figures {
    const char *name;
    viewer_frame *frame;
    size_t frames, capacity;
    double *m2p;
    size_t m2p_count, m2p_capacity;
    double start_ms, end_ms; /* the measured window */
    uint64_t rendered, presented, spoiled, inputs_unseen;
    bool failed; /* no memory for a figure: the row says so */
} viewer_figures;

void viewer_figures_init(viewer_figures *f, const char *name);
void viewer_figures_add(viewer_figures *f, const viewer_frame *frame);
void viewer_figures_m2p(viewer_figures *f, double ms);
void viewer_figures_print_header(void);
/* Prints the row and frees the figures. */
void viewer_figures_print(viewer_figures *f);

/* The first 20% of a run, at most 1 s, is not measured (pipelines, the first keyframe). */
double viewer_warmup_ms(double seconds);

/* The orbit input: the settings' camera made explicit, then turned a step at a time. */
typedef struct viewer_camera {
    float eye[3], target[3];
} viewer_camera;
void viewer_camera_init(viewer_camera *c, cv_render_settings *s, const cv_scene *scene);
void viewer_camera_step(viewer_camera *c, cv_render_settings *s);

/* Bytes of the planes of a cv_render_output. */
size_t viewer_output_bytes(const cv_render_output *out);

typedef struct viewer_desc {
    cv_renderer *renderer;
    cv_device *primary;
    const cv_scene *scene;
    cv_codec codec;
    uint32_t width, height;
    double seconds;
    uint32_t input_every;
    cv_live_trace *trace; /* NULL: none; else the live's spans and the viewer's "decode" */
} viewer_desc;

/* A live over the renderer for d->seconds, consumed as the page does; fills *fig (print it). */
cv_result viewer_run(const viewer_desc *d, viewer_figures *fig);

#endif
