/* The pass builder (graph.h): a chain builds the same graph as the older
 * calls, keeps its first error and reports it at the end naming the pass and
 * the resource, a failed end adds nothing, and uses resolve to the pass's
 * handles in record callbacks on mock devices. */
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "graph_test_util.h"

static void record_nothing(const cv_graph_pass_context *pc, cv_command_list *list, void *user) {
    (void)pc, (void)list, (void)user;
}

static cv_graph_pass_desc pass_desc(const char *name, cv_mgpu_policy policy) {
    return (
        cv_graph_pass_desc){ .name = name, .queue = CV_QUEUE_COMPUTE, .policy = policy, .record = record_nothing };
}

static cv_graph_builder *begin(graph_world *w, const char *name, cv_mgpu_policy policy) {
    cv_graph_pass_desc desc = pass_desc(name, policy);
    return cv_graph_pass_begin(w->graph, &desc);
}

static const cv_texture_desc position_desc = {
    .width = 64, .height = 16, .format = CV_FORMAT_RGBA32F, .label = "position"
};
static const cv_texture_desc visibility_desc = {
    .width = 64, .height = 16, .format = CV_FORMAT_RGBA16F, .label = "visibility"
};
static const cv_texture_desc accumulated_desc = {
    .width = 64, .height = 16, .format = CV_FORMAT_RGBA16F, .label = "accumulated"
};
static const cv_texture_desc image_desc = {
    .width = 64, .height = 16, .format = CV_FORMAT_RGBA16F, .label = "image"
};
static const cv_buffer_desc rays_desc = { .size = 64 * 16 * 32, .label = "rays" };

/* A small hybrid frame with the older calls: a G-buffer multicast, rays and
 * visibility on every device, a gathered accumulation with history. */
static void build_with_calls(graph_world *w) {
    cv_graph *g = w->graph;
    cv_graph_resource accumulated, history, position, rays, visibility, image;
    CHECK_OK(cv_graph_create_texture(g, &accumulated_desc, &accumulated));
    CHECK_OK(cv_graph_history(g, accumulated, &history));
    CHECK_OK(cv_graph_create_texture(g, &position_desc, &position));
    CHECK_OK(cv_graph_create_buffer(g, &rays_desc, 16 * 32, &rays));
    CHECK_OK(cv_graph_create_texture(g, &visibility_desc, &visibility));
    CHECK_OK(cv_graph_create_texture(g, &image_desc, &image));
    cv_graph_pass p;
    CHECK_OK(cv_graph_add_pass(
        g, &(cv_graph_pass_desc){ "gbuffer", CV_QUEUE_GRAPHICS, CV_MGPU_PRIMARY_ONLY, record_nothing, NULL }, &p));
    CHECK_OK(cv_graph_write(g, p, position, CV_GRAPH_COLOR_TARGET, CV_GRAPH_TRANSFER_AUTO));
    CHECK_OK(cv_graph_add_pass(
        g, &(cv_graph_pass_desc){ "raygen", CV_QUEUE_COMPUTE, CV_MGPU_ALL_DEVICES, record_nothing, NULL }, &p));
    CHECK_OK(cv_graph_read(g, p, position, CV_GRAPH_STORAGE_READ));
    CHECK_OK(cv_graph_write(g, p, rays, CV_GRAPH_STORAGE_WRITE, CV_GRAPH_TRANSFER_AUTO));
    CHECK_OK(cv_graph_add_pass(
        g, &(cv_graph_pass_desc){ "trace", CV_QUEUE_COMPUTE, CV_MGPU_ALL_DEVICES, record_nothing, NULL }, &p));
    CHECK_OK(cv_graph_read(g, p, rays, CV_GRAPH_STORAGE_READ));
    CHECK_OK(cv_graph_write(g, p, visibility, CV_GRAPH_STORAGE_WRITE, CV_GRAPH_TRANSFER_AUTO));
    CHECK_OK(cv_graph_add_pass(
        g, &(cv_graph_pass_desc){ "accumulate", CV_QUEUE_COMPUTE, CV_MGPU_PRIMARY_ONLY, record_nothing, NULL }, &p));
    CHECK_OK(cv_graph_read(g, p, visibility, CV_GRAPH_STORAGE_READ));
    CHECK_OK(cv_graph_read(g, p, history, CV_GRAPH_SAMPLED));
    CHECK_OK(cv_graph_write(g, p, accumulated, CV_GRAPH_STORAGE_WRITE, CV_GRAPH_TRANSFER_AUTO));
    CHECK_OK(cv_graph_add_pass(
        g, &(cv_graph_pass_desc){ "resolve", CV_QUEUE_COMPUTE, CV_MGPU_PRIMARY_ONLY, record_nothing, NULL }, &p));
    CHECK_OK(cv_graph_read(g, p, accumulated, CV_GRAPH_STORAGE_READ));
    CHECK_OK(cv_graph_write(g, p, image, CV_GRAPH_STORAGE_WRITE, CV_GRAPH_TRANSFER_AUTO));
    CHECK_OK(cv_graph_output(g, image));
}

/* The same frame as chains, each pass creating what it writes first. */
static void build_with_builder(graph_world *w) {
    cv_graph *g = w->graph;
    cv_graph_resource accumulated, history, position, rays, visibility, image;
    CHECK_OK(cv_graph_create_texture(g, &accumulated_desc, &accumulated));
    CHECK_OK(cv_graph_history(g, accumulated, &history));
    cv_graph_builder *b = cv_graph_pass_begin(g, &(cv_graph_pass_desc){ "gbuffer", CV_QUEUE_GRAPHICS,
                                                                        CV_MGPU_PRIMARY_ONLY, record_nothing, NULL });
    cv_graph_use u = cv_graph_pass_create_texture(b, &position_desc, CV_GRAPH_COLOR_TARGET, CV_GRAPH_TRANSFER_AUTO,
                                                  &position);
    CHECK_EQ_INT(u.resource, position.id);
    CHECK_EQ_INT(u.access, 1);
    CHECK_OK(cv_graph_pass_end(b, NULL));
    b = cv_graph_pass_begin(g, &(cv_graph_pass_desc){ "raygen", CV_QUEUE_COMPUTE, CV_MGPU_ALL_DEVICES, record_nothing,
                                                      NULL });
    cv_graph_pass_read(b, position, CV_GRAPH_STORAGE_READ);
    u = cv_graph_pass_create_buffer(b, &rays_desc, 16 * 32, CV_GRAPH_STORAGE_WRITE, CV_GRAPH_TRANSFER_AUTO, &rays);
    CHECK_EQ_INT(u.access, 2);
    CHECK_OK(cv_graph_pass_end(b, NULL));
    b = cv_graph_pass_begin(g, &(cv_graph_pass_desc){ "trace", CV_QUEUE_COMPUTE, CV_MGPU_ALL_DEVICES, record_nothing,
                                                      NULL });
    cv_graph_pass_read(b, rays, CV_GRAPH_STORAGE_READ);
    cv_graph_pass_create_texture(b, &visibility_desc, CV_GRAPH_STORAGE_WRITE, CV_GRAPH_TRANSFER_AUTO, &visibility);
    CHECK_OK(cv_graph_pass_end(b, NULL));
    b = cv_graph_pass_begin(g, &(cv_graph_pass_desc){ "accumulate", CV_QUEUE_COMPUTE, CV_MGPU_PRIMARY_ONLY,
                                                      record_nothing, NULL });
    cv_graph_pass_read(b, visibility, CV_GRAPH_STORAGE_READ);
    cv_graph_pass_read(b, history, CV_GRAPH_SAMPLED);
    cv_graph_pass_write(b, accumulated, CV_GRAPH_STORAGE_WRITE, CV_GRAPH_TRANSFER_AUTO);
    CHECK_OK(cv_graph_pass_end(b, NULL));
    b = cv_graph_pass_begin(g, &(cv_graph_pass_desc){ "resolve", CV_QUEUE_COMPUTE, CV_MGPU_PRIMARY_ONLY,
                                                      record_nothing, NULL });
    cv_graph_pass_read(b, accumulated, CV_GRAPH_STORAGE_READ);
    cv_graph_pass_create_texture(b, &image_desc, CV_GRAPH_STORAGE_WRITE, CV_GRAPH_TRANSFER_AUTO, &image);
    cv_graph_pass p;
    CHECK_OK(cv_graph_pass_end(b, &p));
    CHECK_EQ_INT(p.id, 5);
    CHECK_OK(cv_graph_output(g, image));
}

static char *baked_dump(graph_world *w) {
    cv_partition part;
    CHECK_OK(cv_partition_split(64, 8, w->count, NULL, &part));
    CHECK_OK(cv_graph_bake(w->graph, &(cv_graph_bake_desc){ .width = 64, .partition = &part }));
    return dump_text(w->graph);
}

static void test_same_graph(void) {
    graph_world a, b;
    world_open(&a, 3);
    world_open(&b, 3);
    build_with_calls(&a);
    build_with_builder(&b);
    char *calls = baked_dump(&a), *chain = baked_dump(&b);
    CHECK(calls && chain && strcmp(calls, chain) == 0);
    if (calls && chain && strcmp(calls, chain) != 0)
        fprintf(stderr, "older calls:\n%s\nbuilder:\n%s", calls, chain);
    CHECK(chain && strstr(chain, "transfer 'visibility'"));
    free(calls);
    free(chain);
    world_close(&a);
    world_close(&b);
}

/* The first failing declaration is kept: later calls do nothing, and the
 * end reports it (again, though other calls failed since). */
static void test_first_error(void) {
    graph_world w;
    world_open(&w, 2);
    cv_graph_resource rays, vis = texture(&w, "vis"), made = { 99 };
    CHECK_OK(cv_graph_create_buffer(w.graph, &rays_desc, 0, &rays));
    cv_graph_pass_desc desc = pass_desc("trace", CV_MGPU_ALL_DEVICES);
    cv_graph_builder *b = cv_graph_pass_begin(w.graph, &desc);
    cv_graph_use ok = cv_graph_pass_read(b, vis, CV_GRAPH_STORAGE_READ);
    CHECK_EQ_INT(ok.resource, vis.id);
    cv_graph_use bad = cv_graph_pass_write(b, rays, CV_GRAPH_COLOR_TARGET, CV_GRAPH_TRANSFER_AUTO);
    CHECK_EQ_INT(bad.resource, 0);
    CHECK_EQ_INT(bad.access, 0);
    cv_graph_use later = cv_graph_pass_read(b, vis, CV_GRAPH_SAMPLED);
    CHECK_EQ_INT(later.resource, 0);
    later = cv_graph_pass_create_texture(b, &image_desc, CV_GRAPH_STORAGE_WRITE, CV_GRAPH_TRANSFER_AUTO, &made);
    CHECK_EQ_INT(later.resource, 0);
    CHECK_EQ_INT(made.id, 0);
    CHECK_RESULT(cv_graph_output(w.graph, (cv_graph_resource){ 77 }), CV_ERROR_INVALID_ARGUMENT);
    cv_graph_pass p = { 5 };
    CHECK_RESULT(cv_graph_pass_end(b, &p), CV_ERROR_WRONG_HANDLE_TYPE);
    CHECK_EQ_INT(p.id, 0);
    CHECK(strstr(cv_last_error(), "graph: pass 'trace': write of 'rays': ") != NULL);
    /* Each kind of declaration error names the pass and the resource. */
    struct {
        cv_graph_access access;
        cv_graph_transfer rule;
        cv_result code;
        const char *words;
    } cases[] = {
        { CV_GRAPH_STORAGE_READ, CV_GRAPH_TRANSFER_AUTO, CV_ERROR_INVALID_ARGUMENT, "write of 'vis': access" },
        { CV_GRAPH_STORAGE_WRITE, CV_GRAPH_TRANSFER_MULTICAST, CV_ERROR_INVALID_ARGUMENT,
          "write of 'vis': transfer" },
        { CV_GRAPH_STORAGE_WRITE, (cv_graph_transfer)9, CV_ERROR_INVALID_ARGUMENT,
          "write of 'vis': transfer rule 9" },
    };
    for (size_t i = 0; i < sizeof(cases) / sizeof(cases[0]); i++) {
        b = cv_graph_pass_begin(w.graph, &desc);
        cv_graph_pass_write(b, vis, cases[i].access, cases[i].rule);
        CHECK_RESULT(cv_graph_pass_end(b, NULL), cases[i].code);
        CHECK(strstr(cv_last_error(), cases[i].words) != NULL);
    }
    b = cv_graph_pass_begin(w.graph, &desc);
    cv_graph_pass_write(b, vis, CV_GRAPH_STORAGE_WRITE, CV_GRAPH_TRANSFER_AUTO);
    cv_graph_pass_write(b, vis, CV_GRAPH_STORAGE_WRITE, CV_GRAPH_TRANSFER_AUTO);
    CHECK_RESULT(cv_graph_pass_end(b, NULL), CV_ERROR_INVALID_ARGUMENT);
    CHECK(strstr(cv_last_error(), "graph: pass 'trace': write of 'vis': written twice") != NULL);
    b = cv_graph_pass_begin(w.graph, &desc);
    cv_graph_pass_read(b, (cv_graph_resource){ 40 }, CV_GRAPH_STORAGE_READ);
    CHECK_RESULT(cv_graph_pass_end(b, NULL), CV_ERROR_NOT_FOUND);
    CHECK(strstr(cv_last_error(), "graph: pass 'trace': read of unknown resource #40") != NULL);
    b = cv_graph_pass_begin(w.graph, &(cv_graph_pass_desc){ .name = "no callback" });
    CHECK_RESULT(cv_graph_pass_end(b, NULL), CV_ERROR_INVALID_ARGUMENT);
    CHECK(strstr(cv_last_error(), "'no callback'") != NULL);
    b = cv_graph_pass_begin(NULL, &desc);
    CHECK_EQ_INT(cv_graph_pass_read(b, vis, CV_GRAPH_STORAGE_READ).resource, 0);
    CHECK_RESULT(cv_graph_pass_end(b, NULL), CV_ERROR_INVALID_ARGUMENT);
    world_close(&w);
}

/* Whether a and b hold the same text from `from` to `to`. */
static bool same_section(const char *a, const char *b, const char *from, const char *to) {
    const char *a0 = strstr(a, from), *b0 = strstr(b, from);
    const char *a1 = a0 ? strstr(a0, to) : NULL, *b1 = b0 ? strstr(b0, to) : NULL;
    return a1 && b1 && a1 - a0 == b1 - b0 && memcmp(a0, b0, (size_t)(a1 - a0)) == 0;
}

/* A failed end leaves the graph as it was: same dump and stats after a bake,
 * no pass and no transient of the builder. */
static void test_failed_end(void) {
    graph_world w;
    world_open(&w, 2);
    build_with_builder(&w);
    char *before = baked_dump(&w);
    cv_graph_stats stats_before, stats_after;
    CHECK_OK(cv_graph_get_stats(w.graph, &stats_before));
    cv_graph_resource made, image = { 5 };
    /* A declaration fails after a transient was created. */
    cv_graph_builder *b = begin(&w, "extra", CV_MGPU_PRIMARY_ONLY);
    cv_graph_pass_create_texture(b, &image_desc, CV_GRAPH_STORAGE_WRITE, CV_GRAPH_TRANSFER_AUTO, &made);
    CHECK_EQ_INT(made.id, 6);
    cv_graph_pass_write(b, made, CV_GRAPH_SAMPLED, CV_GRAPH_TRANSFER_AUTO);
    CHECK_RESULT(cv_graph_pass_end(b, NULL), CV_ERROR_INVALID_ARGUMENT);
    /* The end itself fails: a pass of the same name came first. */
    b = begin(&w, "late", CV_MGPU_PRIMARY_ONLY);
    cv_graph_pass_read(b, image, CV_GRAPH_STORAGE_READ);
    cv_graph_pass_create_texture(b, &image_desc, CV_GRAPH_STORAGE_WRITE, CV_GRAPH_TRANSFER_AUTO, &made);
    cv_graph_pass late;
    cv_graph_pass_desc late_desc = pass_desc("late", CV_MGPU_PRIMARY_ONLY);
    CHECK_OK(cv_graph_add_pass(w.graph, &late_desc, &late));
    CHECK_RESULT(cv_graph_pass_end(b, NULL), CV_ERROR_ALREADY_EXISTS);
    CHECK(strstr(cv_last_error(), "graph: pass 'late' already exists") != NULL);
    CHECK_OK(cv_graph_enable_pass(w.graph, late, false));
    /* A resource added while a builder that creates one is open. */
    b = begin(&w, "racing", CV_MGPU_PRIMARY_ONLY);
    cv_graph_pass_create_texture(b, &image_desc, CV_GRAPH_STORAGE_WRITE, CV_GRAPH_TRANSFER_AUTO, &made);
    cv_graph_resource other = texture(&w, "other");
    CHECK_RESULT(cv_graph_pass_end(b, NULL), CV_ERROR_BAD_STATE);
    CHECK(strstr(cv_last_error(), "graph: pass 'racing': 1 resources were added") != NULL);
    CHECK_EQ_INT(other.id, 6);
    char *after = baked_dump(&w);
    CHECK_OK(cv_graph_get_stats(w.graph, &stats_after));
    /* Only the pass and texture added with the older calls show (culled and unused). */
    CHECK(after && strstr(after, "culled: 'late'") && strstr(after, "'other'") && !strstr(after, "'extra'") &&
          !strstr(after, "'racing'"));
    CHECK_EQ_INT(stats_after.passes, stats_before.passes);
    CHECK_EQ_INT(stats_after.transients, stats_before.transients);
    CHECK_EQ_INT(stats_after.steps, stats_before.steps);
    CHECK(before && after && same_section(before, after, "steps:", "stats:"));
    free(before);
    free(after);
    world_close(&w);
}

/* What the record callbacks saw: every use resolved as cv_graph_texture and
 * cv_graph_buffer resolve the same resources; wrong uses gave 0. */
typedef struct use_check {
    cv_graph_use own, buffer, other_pass;
    cv_graph_resource own_resource, buffer_resource;
    atomic_int calls, wrong;
} use_check;

static void check_uses(const cv_graph_pass_context *pc, cv_command_list *list, void *user) {
    (void)list;
    use_check *c = user;
    atomic_fetch_add(&c->calls, 1);
    cv_texture t = cv_graph_use_texture(pc, c->own);
    cv_buffer buf = cv_graph_use_buffer(pc, c->buffer);
    bool right = t.id && t.id == cv_graph_texture(pc, c->own_resource).id && buf.id &&
                 buf.id == cv_graph_buffer(pc, c->buffer_resource).id &&
                 cv_graph_use_binding(pc, c->own).resource.id == t.id &&
                 cv_graph_use_binding(pc, c->buffer).resource.id == buf.id &&
                 cv_graph_use_buffer(pc, c->own).id == 0 && cv_graph_use_texture(pc, c->buffer).id == 0 &&
                 cv_graph_use_texture(pc, c->other_pass).id == 0 &&
                 cv_graph_use_texture(pc, (cv_graph_use){ 0, 0 }).id == 0;
    if (!right)
        atomic_fetch_add(&c->wrong, 1);
}

static void test_uses_in_record(void) {
    graph_world w;
    world_open(&w, 2);
    use_check c = { 0 };
    atomic_init(&c.calls, 0);
    atomic_init(&c.wrong, 0);
    cv_graph_resource tex, buf, out;
    cv_graph_builder *b = begin(&w, "produce", CV_MGPU_PRIMARY_ONLY);
    c.other_pass = cv_graph_pass_create_texture(b, &position_desc, CV_GRAPH_STORAGE_WRITE, CV_GRAPH_TRANSFER_AUTO,
                                                &tex);
    cv_graph_pass_create_buffer(b, &rays_desc, 0, CV_GRAPH_STORAGE_WRITE, CV_GRAPH_TRANSFER_AUTO, &buf);
    CHECK_OK(cv_graph_pass_end(b, NULL));
    cv_graph_pass_desc desc = pass_desc("consume", CV_MGPU_ALL_DEVICES);
    desc.record = check_uses;
    desc.user = &c;
    b = cv_graph_pass_begin(w.graph, &desc);
    c.buffer = cv_graph_pass_read(b, buf, CV_GRAPH_STORAGE_READ);
    c.own = cv_graph_pass_read(b, tex, CV_GRAPH_STORAGE_READ);
    cv_graph_pass_create_texture(b, &image_desc, CV_GRAPH_STORAGE_WRITE, CV_GRAPH_TRANSFER_AUTO, &out);
    CHECK_OK(cv_graph_pass_end(b, NULL));
    c.own_resource = tex;
    c.buffer_resource = buf;
    CHECK_EQ_INT(c.own.access, 2);
    CHECK_EQ_INT(c.other_pass.access, 1);
    CHECK_OK(cv_graph_output(w.graph, out));
    CHECK_OK(cv_graph_bake(w.graph, &(cv_graph_bake_desc){ .width = 64 }));
    cv_graph_timing t[8];
    uint32_t n = 0;
    CHECK_OK(cv_graph_execute(w.graph, t, 8, &n));
    CHECK_EQ_INT(atomic_load(&c.calls), 2);
    CHECK_EQ_INT(atomic_load(&c.wrong), 0);
    /* Outside a record callback nothing resolves. */
    CHECK_EQ_INT(cv_graph_use_texture(NULL, c.own).id, 0);
    world_close(&w);
}

int main(void) {
    test_same_graph();
    test_first_error();
    test_failed_end();
    test_uses_in_record();
    CHECK_NOTHING_LIVE();
    return check_report("graph_builder_test");
}
