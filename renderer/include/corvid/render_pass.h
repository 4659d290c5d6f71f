/* A pass of the renderer's frame as a module: one descriptor saying what the
 * pass is (name, queue, device policy), when it runs, which resources it reads
 * and writes (declared once with the graph's pass builder, corvid/graph.h) and
 * what it records. The frame is a table of them (renderer/src/passes/
 * pass_table.h, in graph order); a program adds its own after the table's
 * with cv_renderer_add_pass (renderer.h). docs/render-graph.md, "Writing a
 * pass", walks through one written from scratch.
 *
 *     enum { USE_IMAGE, USE_VIEW };
 *     static bool on_last(const cv_render_frame *f) { return cv_render_frame_get_view(f)->last; }
 *     static cv_result declare(const cv_render_frame *f, cv_graph_builder *b, cv_graph_use *uses, void *user) {
 *         uses[USE_IMAGE] = cv_graph_pass_read(b, cv_render_frame_target(f, CV_RENDER_TARGET_RADIANCE),
 *                                              CV_GRAPH_STORAGE_READ);
 *         uses[USE_VIEW] = cv_graph_pass_write(b, my_view, CV_GRAPH_STORAGE_WRITE, CV_GRAPH_TRANSFER_AUTO);
 *         return CV_OK;
 *     }
 *     static void record(const cv_render_frame *f, const cv_graph_pass_context *pc, cv_command_list *l,
 *                        const cv_graph_use *uses, void *user) {
 *         cv_binding b[2] = { cv_graph_use_binding(pc, uses[USE_IMAGE]), cv_graph_use_binding(pc, uses[USE_VIEW]) };
 *         ... cv_cmd_dispatch(l, pc->queue, ...) ...
 *     }
 *     const cv_render_pass_module my_pass = { .name = "view", .queue = CV_QUEUE_COMPUTE,
 *                                             .policy = CV_MGPU_PRIMARY_ONLY, .enabled = on_last,
 *                                             .declare = declare, .record = record };
 *     cv_renderer_add_pass(renderer, &my_pass, my_state);
 *
 * The callbacks see the frame through cv_render_frame (the renderer's state
 * for the frame being built or recorded), never the device count: the graph
 * places the pass on its devices and copies what crosses between them. */
#ifndef CORVID_RENDER_PASS_H
#define CORVID_RENDER_PASS_H

#include <stdbool.h>
#include <stdint.h>

#include "corvid/graph.h"
#include "corvid/render_settings.h"

/* The renderer's state for one frame: settings, size, cameras, the textures
 * and scene buffers in the graph. Read through the calls below. */
typedef struct cv_render_frame cv_render_frame;

/* What a pass may ask of the frame. */
typedef struct cv_render_frame_view {
    const cv_render_settings *settings; /* resolved (defaults filled in) */
    uint32_t width, height;             /* of the image */
    uint32_t frame;                     /* of this render call, 0 first (a step: its index in the history) */
    bool first, last;                   /* the render's first / last frame (the composite runs on the last;
                                         * every step is the last frame of its history so far) */
    bool moving;                        /* a moving camera (settings.orbit_degrees): reprojection */
    bool reflections;                   /* reflection passes are in the graph */
    uint32_t filter_iterations;         /* a-trous iterations of the visibility filter */
} cv_render_frame_view;

/* The renderer's textures a pass may read or write (imported into the graph;
 * they keep their contents from frame to frame and call to call). */
typedef enum cv_render_target {
    CV_RENDER_TARGET_RADIANCE = 0, /* the composite's linear HDR image (RGBA32F; written on the last frame) */
    CV_RENDER_TARGET_ALBEDO,       /* RGBA32F */
    CV_RENDER_TARGET_POSITION,     /* the G-buffer's world position (RGBA32F) */
    CV_RENDER_TARGET_NORMAL,       /* the G-buffer's normal (RGBA32F) */
    CV_RENDER_TARGET_COUNT
} cv_render_target;

const cv_render_frame_view *cv_render_frame_get_view(const cv_render_frame *f);
/* The graph resource of target t in the frame's graph. */
cv_graph_resource cv_render_frame_target(const cv_render_frame *f, cv_render_target t);
/* The frame's graph, for a declare that imports resources of its own (a
 * texture its pass writes and the program reads afterwards: import it, and
 * mark it cv_graph_output so the pass is not culled). */
cv_graph *cv_render_frame_graph(const cv_render_frame *f);

/* Uses a pass may declare (slots of the array its declare fills). */
#define CV_RENDER_PASS_MAX_USES 24u

typedef struct cv_render_pass_module {
    const char *name; /* the graph pass's name, unique in the frame */
    cv_queue_type queue;
    cv_mgpu_policy policy;
    /* Whether the pass is in the graph (the graph is built again when the
     * answer changes: settings, not the frame index); NULL = always. */
    bool (*present)(const cv_render_frame *f);
    /* Whether the pass runs on this frame (first / last frame, a moving
     * camera); NULL = every frame. A pass left out is baked as if absent. */
    bool (*enabled)(const cv_render_frame *f);
    /* Declares every resource the pass reads or writes once, with the
     * builder, into uses[0 .. CV_RENDER_PASS_MAX_USES - 1] (the slots are the
     * pass's own). The builder keeps the first error; a declare returns an
     * error of its own calls (imports), else CV_OK. */
    cv_result (*declare)(const cv_render_frame *f, cv_graph_builder *b, cv_graph_use *uses, void *user);
    /* Records the pass for one device (pc's window) from the uses declared.
     * Called on the graph's worker threads; calls for different devices may
     * run at once. */
    void (*record)(const cv_render_frame *f, const cv_graph_pass_context *pc, cv_command_list *l,
                   const cv_graph_use *uses, void *user);
} cv_render_pass_module;

#endif
