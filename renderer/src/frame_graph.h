/* The frame as a render graph (corvid/graph.h): built by walking the pass
 * table (passes/pass_table.h) and then the program's passes, each declared
 * with the graph's pass builder; built again only when its shape changes. */
#ifndef CORVID_RENDER_FRAME_GRAPH_H
#define CORVID_RENDER_FRAME_GRAPH_H

#include "frame.h"

/* The graph for f's targets and settings (f->settings, f->info's moving,
 * reflections and filter iterations set from them), with ray buffers of
 * `rays` rays; kept when nothing it depends on changed. On failure f has no
 * graph. */
cv_result render_graph_build(cv_render_frame *f, uint64_t rays);
/* Builds the graph again for the devices f has now (a device added or lost). */
cv_result render_graph_rebuild(cv_render_frame *f);
void render_graph_destroy(cv_render_frame *f);
/* Appends a program's pass after the table's (cv_renderer_add_pass); the
 * next render builds the graph with it. */
cv_result render_graph_add_pass(cv_render_frame *f, const cv_render_pass_module *m, void *user);
/* The bake of f's graph over `part` (NULL: the graph's balancer splits the
 * width), with the settings' zero-copy choice and transfer mode. */
cv_graph_bake_desc render_graph_bake_desc(const cv_render_frame *f, const cv_partition *part);
/* Which passes run on the frame f->info describes (each module's enabled). */
cv_result render_graph_enable_passes(cv_render_frame *f);
/* f's graph as text and/or dot: every pass (the first frame of a one-frame
 * render) over the last frame's columns. */
cv_result render_graph_dump(cv_render_frame *f, FILE *text, FILE *dot);

#endif
