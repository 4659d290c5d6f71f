/* Helpers shared by the render graph tests: mock devices, small passes. */
#ifndef GRAPH_TEST_UTIL_H
#define GRAPH_TEST_UTIL_H

#include "corvid/graph.h"

typedef struct graph_world {
    cv_context *ctx;
    cv_device *devices[CV_MAX_DEVICES];
    uint32_t count;
    cv_graph *graph;
} graph_world;

/* A context, `count` mock devices ("gpu0"...) and a graph over them. */
void world_open(graph_world *w, uint32_t count);
void world_close(graph_world *w);

/* A pass whose record callback records nothing. */
cv_graph_pass add_pass(graph_world *w, const char *name, cv_mgpu_policy policy);
/* A 64x16 RGBA16F transient texture (same description each call). */
cv_graph_resource texture(graph_world *w, const char *name);
/* The text dump as a string (free it). */
char *dump_text(const cv_graph *g);

#endif
