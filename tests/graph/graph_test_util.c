#include "graph_test_util.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"

void world_open(graph_world *w, uint32_t count) {
    memset(w, 0, sizeof(*w));
    CHECK_OK(cv_context_create(NULL, &w->ctx));
    for (uint32_t d = 0; d < count; d++) {
        cv_device_desc desc = { 0 };
        snprintf(desc.label, sizeof(desc.label), "gpu%u", d);
        CHECK_OK(cv_device_create(w->ctx, cv_mock_backend(), &desc, &w->devices[d]));
    }
    w->count = count;
    CHECK_OK(cv_graph_create(w->ctx, w->devices, count, &w->graph));
}

void world_close(graph_world *w) {
    cv_graph_destroy(w->graph);
    cv_context_destroy(w->ctx);
}

static void record_nothing(const cv_graph_pass_context *pc, cv_command_list *list, void *user) {
    (void)pc, (void)list, (void)user;
}

cv_graph_pass add_pass(graph_world *w, const char *name, cv_mgpu_policy policy) {
    cv_graph_pass p = { 0 };
    CHECK_OK(cv_graph_add_pass(
        w->graph,
        &(cv_graph_pass_desc){ .name = name, .queue = CV_QUEUE_COMPUTE, .policy = policy, .record = record_nothing },
        &p));
    return p;
}

cv_graph_resource texture(graph_world *w, const char *name) {
    cv_texture_desc desc = { .width = 64, .height = 16, .format = CV_FORMAT_RGBA16F };
    snprintf(desc.label, sizeof(desc.label), "%s", name);
    cv_graph_resource r = { 0 };
    CHECK_OK(cv_graph_create_texture(w->graph, &desc, &r));
    return r;
}

char *dump_text(const cv_graph *g) {
    char *text = NULL;
    size_t size = 0;
    FILE *f = open_memstream(&text, &size);
    CHECK(f != NULL);
    if (!f)
        return NULL;
    CHECK_OK(cv_graph_dump_text(g, f));
    fclose(f);
    return text;
}
