/* The frame as a table of pass modules, in graph order (the order the graph
 * is declared in, and the order a frame runs them where the graph does not
 * reorder). X(name) names the module render_pass_<name> of passes/<name>.c.
 * frame_graph.c walks it to build the graph; a program's passes
 * (cv_renderer_add_pass) follow the table's. */
#ifndef CORVID_RENDER_PASS_TABLE_H
#define CORVID_RENDER_PASS_TABLE_H

#define CV_RENDER_PASS_TABLE(X) \
    X(gbuffer) \
    X(trace) \
    X(reproject) \
    X(reflect) \
    X(reflect_reproject) \
    X(reflect_filter) \
    X(accumulate) \
    X(reflect_denoise) \
    X(filter) \
    X(composite) \
    X(present)

#endif
