/* The graph's pass builder (corvid/graph.h) over cv_graph_add_pass,
 * cv_graph_read and cv_graph_write, until the graph's own builder lands: the
 * first error is kept, and the end reports it. */
#include <stdlib.h>

#include "corvid/graph.h"

struct cv_graph_builder {
    cv_graph *graph;
    cv_graph_pass pass;
    cv_result result;
};

cv_graph_builder *cv_graph_pass_begin(cv_graph *g, const cv_graph_pass_desc *desc) {
    cv_graph_builder *b = calloc(1, sizeof(*b));
    if (b) {
        b->graph = g;
        b->result = cv_graph_add_pass(g, desc, &b->pass);
    }
    return b;
}

static cv_graph_use declared(cv_graph_builder *b, cv_result res, cv_graph_resource r, cv_graph_access a) {
    b->result = res;
    return res == CV_OK ? (cv_graph_use){ r.id, (uint32_t)a } : (cv_graph_use){ 0, 0 };
}

cv_graph_use cv_graph_pass_read(cv_graph_builder *b, cv_graph_resource r, cv_graph_access a) {
    if (!b || b->result != CV_OK)
        return (cv_graph_use){ 0, 0 };
    return declared(b, cv_graph_read(b->graph, b->pass, r, a), r, a);
}

cv_graph_use cv_graph_pass_write(cv_graph_builder *b, cv_graph_resource r, cv_graph_access a,
                                 cv_graph_transfer rule) {
    if (!b || b->result != CV_OK)
        return (cv_graph_use){ 0, 0 };
    return declared(b, cv_graph_write(b->graph, b->pass, r, a, rule), r, a);
}

cv_result cv_graph_pass_end(cv_graph_builder *b, cv_graph_pass *out) {
    if (!b)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "graph: pass builder");
    cv_result res = b->result;
    if (res == CV_OK && out)
        *out = b->pass;
    free(b);
    return res;
}

cv_texture cv_graph_use_texture(const cv_graph_pass_context *pc, cv_graph_use u) {
    return cv_graph_texture(pc, (cv_graph_resource){ u.resource });
}

cv_buffer cv_graph_use_buffer(const cv_graph_pass_context *pc, cv_graph_use u) {
    return cv_graph_buffer(pc, (cv_graph_resource){ u.resource });
}

cv_binding cv_graph_use_binding(const cv_graph_pass_context *pc, cv_graph_use u) {
    cv_texture t = cv_graph_use_texture(pc, u);
    return (cv_binding){ .resource = t.id ? cv_any(t) : cv_any(cv_graph_use_buffer(pc, u)) };
}
