/* What the render graph's bake decides, on mock devices: which passes it culls,
 * which transients share memory, where barriers go, where transfers go, which
 * graphs it rejects and why, and the text dump of a hybrid-renderer frame. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "graph_test_util.h"

static const cv_graph_bake_desc bake64 = { .width = 64, .tile = 8 };

static void test_culling(void) {
    graph_world w;
    world_open(&w, 1);
    cv_graph_resource t = texture(&w, "t"), out = texture(&w, "out"), unused = texture(&w, "unused");
    cv_graph_pass make = add_pass(&w, "make t", CV_MGPU_PRIMARY_ONLY);
    cv_graph_pass use = add_pass(&w, "use t", CV_MGPU_PRIMARY_ONLY);
    cv_graph_pass waste = add_pass(&w, "waste", CV_MGPU_PRIMARY_ONLY);
    CHECK_OK(cv_graph_write(w.graph, make, t, CV_GRAPH_STORAGE_WRITE, CV_GRAPH_TRANSFER_AUTO));
    CHECK_OK(cv_graph_read(w.graph, use, t, CV_GRAPH_SAMPLED));
    CHECK_OK(cv_graph_write(w.graph, use, out, CV_GRAPH_COLOR_TARGET, CV_GRAPH_TRANSFER_AUTO));
    CHECK_OK(cv_graph_read(w.graph, waste, t, CV_GRAPH_SAMPLED));
    CHECK_OK(cv_graph_write(w.graph, waste, unused, CV_GRAPH_STORAGE_WRITE, CV_GRAPH_TRANSFER_AUTO));
    CHECK_OK(cv_graph_output(w.graph, out));
    CHECK_OK(cv_graph_bake(w.graph, &bake64));
    CHECK(cv_graph_pass_kept(w.graph, make)); /* reaches the output through 'use t' */
    CHECK(cv_graph_pass_kept(w.graph, use));
    CHECK(!cv_graph_pass_kept(w.graph, waste));
    cv_graph_stats st;
    CHECK_OK(cv_graph_get_stats(w.graph, &st));
    CHECK_EQ_INT(st.passes, 2);
    CHECK_EQ_INT(st.culled, 1);
    CHECK_EQ_INT(st.steps, 2);
    CHECK_EQ_INT(cv_graph_physical_of(w.graph, unused), -1); /* a culled pass's transient gets no memory */
    world_close(&w);
}

static void test_transient_reuse(void) {
    graph_world w;
    world_open(&w, 1);
    /* a -> b -> c -> out, one step each: a lives over steps 0-1, b 1-2, c 2-3. */
    cv_graph_resource a = texture(&w, "a"), b = texture(&w, "b"), c = texture(&w, "c"), out = texture(&w, "out");
    cv_graph_resource wide;
    CHECK_OK(cv_graph_create_texture(
        w.graph, &(cv_texture_desc){ .width = 128, .height = 16, .format = CV_FORMAT_RGBA16F, .label = "wide" },
        &wide));
    cv_graph_resource chain[] = { a, b, c, wide, out };
    const char *names[] = { "make a", "a to b", "b to c", "c to wide", "wide to out" };
    for (int i = 0; i < 5; i++) {
        cv_graph_pass p = add_pass(&w, names[i], CV_MGPU_PRIMARY_ONLY);
        if (i)
            CHECK_OK(cv_graph_read(w.graph, p, chain[i - 1], CV_GRAPH_SAMPLED));
        CHECK_OK(cv_graph_write(w.graph, p, chain[i], CV_GRAPH_STORAGE_WRITE, CV_GRAPH_TRANSFER_AUTO));
    }
    CHECK_OK(cv_graph_output(w.graph, out));
    CHECK_OK(cv_graph_bake(w.graph, &bake64));
    int32_t pa = cv_graph_physical_of(w.graph, a), pb = cv_graph_physical_of(w.graph, b);
    int32_t pc = cv_graph_physical_of(w.graph, c), pw = cv_graph_physical_of(w.graph, wide);
    int32_t po = cv_graph_physical_of(w.graph, out);
    CHECK(pa >= 0 && pb >= 0);
    CHECK(pa != pb);             /* a and b are both live at step 1 */
    CHECK_EQ_INT(pc, pa);        /* a is dead when c is born */
    CHECK(pw != pa && pw != pb); /* another description never shares */
    CHECK_EQ_INT(po, pa);        /* a's entry is free again after c (step 3): first fit */
    cv_graph_stats st;
    CHECK_OK(cv_graph_get_stats(w.graph, &st));
    CHECK_EQ_INT(st.transients, 5);
    CHECK_EQ_INT(st.physical, 3);
    /* A second bake takes the same pool entries again. */
    CHECK_OK(cv_graph_bake(w.graph, &bake64));
    CHECK_EQ_INT(cv_graph_physical_of(w.graph, c), pa);
    CHECK_EQ_INT(cv_context_live_count(w.ctx, CV_HANDLE_TEXTURE), 3);
    world_close(&w);
}

/* Three devices, width 64, tile 8: gbuffer (primary) -> trace (all) -> resolve (primary). */
static void check_edges(uint32_t devices) {
    graph_world w;
    world_open(&w, devices);
    cv_graph_resource g = texture(&w, "g"), v = texture(&w, "v"), out = texture(&w, "out");
    cv_graph_resource local = texture(&w, "local");
    cv_graph_pass gbuffer = add_pass(&w, "gbuffer", CV_MGPU_PRIMARY_ONLY);
    cv_graph_pass trace = add_pass(&w, "trace", CV_MGPU_ALL_DEVICES);
    cv_graph_pass shade = add_pass(&w, "shade", CV_MGPU_ALL_DEVICES);
    cv_graph_pass resolve = add_pass(&w, "resolve", CV_MGPU_PRIMARY_ONLY);
    CHECK_OK(cv_graph_write(w.graph, gbuffer, g, CV_GRAPH_COLOR_TARGET, CV_GRAPH_TRANSFER_AUTO));
    CHECK_OK(cv_graph_read(w.graph, trace, g, CV_GRAPH_SAMPLED));
    CHECK_OK(cv_graph_write(w.graph, trace, local, CV_GRAPH_STORAGE_WRITE, CV_GRAPH_TRANSFER_AUTO));
    /* all -> all: each device keeps its own columns, nothing moves */
    CHECK_OK(cv_graph_read(w.graph, shade, local, CV_GRAPH_STORAGE_READ));
    CHECK_OK(cv_graph_write(w.graph, shade, v, CV_GRAPH_STORAGE_WRITE, CV_GRAPH_TRANSFER_AUTO));
    CHECK_OK(cv_graph_read(w.graph, resolve, v, CV_GRAPH_STORAGE_READ));
    CHECK_OK(cv_graph_read(w.graph, resolve, g, CV_GRAPH_SAMPLED)); /* primary -> primary: nothing moves */
    CHECK_OK(cv_graph_write(w.graph, resolve, out, CV_GRAPH_STORAGE_WRITE, CV_GRAPH_TRANSFER_AUTO));
    CHECK_OK(cv_graph_output(w.graph, out));
    cv_partition part;
    CHECK_OK(cv_partition_split(64, 8, devices, NULL, &part));
    CHECK_OK(cv_graph_bake(w.graph, &(cv_graph_bake_desc){ .width = 64, .partition = &part }));
    cv_graph_stats st;
    CHECK_OK(cv_graph_get_stats(w.graph, &st));
    CHECK_EQ_INT(st.transfers, 2);
    CHECK_EQ_INT(st.copies, 2 * (devices - 1));
    CHECK_EQ_INT(st.steps, 6);
    char expect[512], line[128];
    /* The multicast: the whole width to every secondary, right after the writer. */
    snprintf(expect, sizeof(expect), "  1 transfer 'g' after 'gbuffer': MULTICAST:");
    for (uint32_t d = 1; d < devices; d++) {
        snprintf(line, sizeof(line), " dev0->dev%u [0,64)", d);
        strcat(expect, line);
    }
    strcat(expect, "\n");
    char *text = dump_text(w.graph);
    CHECK(text && strstr(text, expect));
    /* The copy-back: only the secondaries' windows, after the all-devices writer. */
    snprintf(expect, sizeof(expect), "  4 transfer 'v' after 'shade': ISOLATED_TO_ISOLATED:");
    for (uint32_t d = 1; d < devices; d++) {
        snprintf(line, sizeof(line), " dev%u->dev0 [%u,%u)", d, part.ranges[d].x,
                 part.ranges[d].x + part.ranges[d].width);
        strcat(expect, line);
    }
    strcat(expect, "\n");
    CHECK(text && strstr(text, expect));
    if (text && !strstr(text, expect))
        fprintf(stderr, "expected:\n%s\nin:\n%s", expect, text);
    free(text);
    world_close(&w);
}

/* A copy waits for the first pass that touches what it moves: 'v' goes back
 * to the primary after 'other' (which does not read it), just before
 * 'resolve'; 'w' (an output written on all devices, read by no later pass)
 * at the end of the frame. */
static void test_late_transfers(void) {
    graph_world w;
    world_open(&w, 2);
    cv_graph_resource g = texture(&w, "g"), v = texture(&w, "v"), wr = texture(&w, "w"), out = texture(&w, "out");
    cv_graph_pass gbuffer = add_pass(&w, "gbuffer", CV_MGPU_PRIMARY_ONLY);
    cv_graph_pass trace = add_pass(&w, "trace", CV_MGPU_ALL_DEVICES);
    cv_graph_pass other = add_pass(&w, "other", CV_MGPU_ALL_DEVICES);
    cv_graph_pass resolve = add_pass(&w, "resolve", CV_MGPU_PRIMARY_ONLY);
    CHECK_OK(cv_graph_write(w.graph, gbuffer, g, CV_GRAPH_COLOR_TARGET, CV_GRAPH_TRANSFER_AUTO));
    CHECK_OK(cv_graph_read(w.graph, trace, g, CV_GRAPH_SAMPLED));
    CHECK_OK(cv_graph_write(w.graph, trace, v, CV_GRAPH_STORAGE_WRITE, CV_GRAPH_TRANSFER_AUTO));
    CHECK_OK(cv_graph_read(w.graph, other, g, CV_GRAPH_SAMPLED));
    CHECK_OK(cv_graph_write(w.graph, other, wr, CV_GRAPH_STORAGE_WRITE, CV_GRAPH_TRANSFER_AUTO));
    CHECK_OK(cv_graph_read(w.graph, resolve, v, CV_GRAPH_STORAGE_READ));
    CHECK_OK(cv_graph_write(w.graph, resolve, out, CV_GRAPH_STORAGE_WRITE, CV_GRAPH_TRANSFER_AUTO));
    CHECK_OK(cv_graph_output(w.graph, out));
    CHECK_OK(cv_graph_output(w.graph, wr));
    CHECK_OK(cv_graph_bake(w.graph, &bake64));
    char *text = dump_text(w.graph);
    static const char *const order[] = { "  0 pass 'gbuffer'",
                                         "  1 transfer 'g' after 'gbuffer'",
                                         "  2 pass 'trace'",
                                         "  3 pass 'other'",
                                         "  4 transfer 'v' after 'trace'",
                                         "  5 pass 'resolve'",
                                         "  6 transfer 'w' after 'other'" };
    for (uint32_t i = 0; i < sizeof(order) / sizeof(order[0]); i++) {
        CHECK(text && strstr(text, order[i]));
        if (text && !strstr(text, order[i]))
            fprintf(stderr, "expected '%s' in:\n%s", order[i], text);
    }
    free(text);
    world_close(&w);
}

static void test_cross_device_edges(void) {
    check_edges(2);
    check_edges(3);
    test_late_transfers();
    /* One device: nothing ever crosses. */
    graph_world w;
    world_open(&w, 1);
    cv_graph_resource g = texture(&w, "g"), out = texture(&w, "out");
    cv_graph_pass a = add_pass(&w, "a", CV_MGPU_PRIMARY_ONLY), b = add_pass(&w, "b", CV_MGPU_ALL_DEVICES);
    CHECK_OK(cv_graph_write(w.graph, a, g, CV_GRAPH_COLOR_TARGET, CV_GRAPH_TRANSFER_AUTO));
    CHECK_OK(cv_graph_read(w.graph, b, g, CV_GRAPH_SAMPLED));
    CHECK_OK(cv_graph_write(w.graph, b, out, CV_GRAPH_STORAGE_WRITE, CV_GRAPH_TRANSFER_AUTO));
    CHECK_OK(cv_graph_output(w.graph, out));
    CHECK_OK(cv_graph_bake(w.graph, &bake64));
    cv_graph_stats st;
    CHECK_OK(cv_graph_get_stats(w.graph, &st));
    CHECK_EQ_INT(st.transfers, 0);
    world_close(&w);
}

/* Bakes a graph expected to fail with `code` and a message holding each of `words`;
 * the previous bake must survive. */
static void expect_rejected_by(graph_world *w, const cv_graph_bake_desc *desc, cv_result code,
                               const char *const *words) {
    cv_graph_stats before, after;
    bool had = cv_graph_get_stats(w->graph, &before) == CV_OK;
    CHECK_RESULT(cv_graph_bake(w->graph, desc), code);
    for (; *words; words++) {
        CHECK(strstr(cv_last_error(), *words) != NULL);
        if (!strstr(cv_last_error(), *words))
            fprintf(stderr, "'%s' not in: %s\n", *words, cv_last_error());
    }
    if (had) {
        CHECK_OK(cv_graph_get_stats(w->graph, &after));
        CHECK(memcmp(&before, &after, sizeof(before)) == 0);
    }
}

static void expect_rejected(graph_world *w, cv_result code, const char *const *words) {
    expect_rejected_by(w, &bake64, code, words);
}

static void test_bad_graphs(void) {
    graph_world w;
    /* A cycle: 'a' reads what 'b' writes and 'b' reads what 'a' writes. A good
     * bake first, to show that the failed one changes nothing. */
    world_open(&w, 1);
    cv_graph_resource t1 = texture(&w, "t1"), t2 = texture(&w, "t2"), out = texture(&w, "out");
    cv_graph_pass ok = add_pass(&w, "ok", CV_MGPU_PRIMARY_ONLY);
    CHECK_OK(cv_graph_write(w.graph, ok, out, CV_GRAPH_STORAGE_WRITE, CV_GRAPH_TRANSFER_AUTO));
    CHECK_OK(cv_graph_output(w.graph, out));
    CHECK_OK(cv_graph_bake(w.graph, &bake64));
    cv_graph_pass a = add_pass(&w, "a", CV_MGPU_PRIMARY_ONLY), b = add_pass(&w, "b", CV_MGPU_PRIMARY_ONLY);
    CHECK_OK(cv_graph_read(w.graph, a, t2, CV_GRAPH_SAMPLED));
    CHECK_OK(cv_graph_write(w.graph, a, t1, CV_GRAPH_STORAGE_WRITE, CV_GRAPH_TRANSFER_AUTO));
    CHECK_OK(cv_graph_read(w.graph, b, t1, CV_GRAPH_SAMPLED));
    CHECK_OK(cv_graph_write(w.graph, b, t2, CV_GRAPH_STORAGE_WRITE, CV_GRAPH_TRANSFER_AUTO));
    expect_rejected(&w, CV_ERROR_INVALID_ARGUMENT, (const char *[]){ "cycle", "'a' -> 'b' -> 'a'", NULL });
    world_close(&w);

    /* A resource the graph does not have. */
    world_open(&w, 1);
    out = texture(&w, "out");
    cv_graph_pass p = add_pass(&w, "lookup", CV_MGPU_PRIMARY_ONLY);
    CHECK_OK(cv_graph_read(w.graph, p, (cv_graph_resource){ 99 }, CV_GRAPH_STORAGE_READ));
    CHECK_OK(cv_graph_write(w.graph, p, out, CV_GRAPH_STORAGE_WRITE, CV_GRAPH_TRANSFER_AUTO));
    CHECK_OK(cv_graph_output(w.graph, out));
    expect_rejected(&w, CV_ERROR_NOT_FOUND, (const char *[]){ "pass 'lookup'", "unknown resource #99", NULL });
    world_close(&w);

    /* A transient nobody writes. */
    world_open(&w, 1);
    cv_graph_resource never = texture(&w, "never");
    out = texture(&w, "out");
    p = add_pass(&w, "reader", CV_MGPU_PRIMARY_ONLY);
    CHECK_OK(cv_graph_read(w.graph, p, never, CV_GRAPH_SAMPLED));
    CHECK_OK(cv_graph_write(w.graph, p, out, CV_GRAPH_STORAGE_WRITE, CV_GRAPH_TRANSFER_AUTO));
    CHECK_OK(cv_graph_output(w.graph, out));
    expect_rejected(&w, CV_ERROR_BAD_STATE, (const char *[]){ "pass 'reader'", "'never'", "no pass writes", NULL });
    world_close(&w);

    /* Two writes of one resource in one pass with no read between. */
    world_open(&w, 1);
    out = texture(&w, "out");
    p = add_pass(&w, "twice", CV_MGPU_PRIMARY_ONLY);
    CHECK_OK(cv_graph_write(w.graph, p, out, CV_GRAPH_COLOR_TARGET, CV_GRAPH_TRANSFER_AUTO));
    CHECK_OK(cv_graph_write(w.graph, p, out, CV_GRAPH_STORAGE_WRITE, CV_GRAPH_TRANSFER_AUTO));
    CHECK_OK(cv_graph_output(w.graph, out));
    expect_rejected(&w, CV_ERROR_INVALID_ARGUMENT, (const char *[]){ "pass 'twice'", "'out' twice", NULL });
    world_close(&w);

    /* A multicast of what all devices wrote (each holds only its columns). */
    world_open(&w, 2);
    cv_graph_resource v = texture(&w, "v");
    out = texture(&w, "out");
    p = add_pass(&w, "trace", CV_MGPU_ALL_DEVICES);
    cv_graph_pass q = add_pass(&w, "use", CV_MGPU_PRIMARY_ONLY);
    CHECK_OK(cv_graph_write(w.graph, p, v, CV_GRAPH_STORAGE_WRITE, CV_GRAPH_TRANSFER_MULTICAST));
    CHECK_OK(cv_graph_read(w.graph, q, v, CV_GRAPH_SAMPLED));
    CHECK_OK(cv_graph_write(w.graph, q, out, CV_GRAPH_STORAGE_WRITE, CV_GRAPH_TRANSFER_AUTO));
    CHECK_OK(cv_graph_output(w.graph, out));
    expect_rejected(&w, CV_ERROR_INVALID_ARGUMENT, (const char *[]){ "pass 'trace'", "'v'", "MULTICAST", NULL });
    world_close(&w);

    /* Construction refuses what it can see at once, and changes nothing. */
    world_open(&w, 1);
    add_pass(&w, "same", CV_MGPU_PRIMARY_ONLY);
    cv_graph_pass dup;
    CHECK_RESULT(cv_graph_add_pass(
                     w.graph, &(cv_graph_pass_desc){ .name = "same", .policy = CV_MGPU_PRIMARY_ONLY, .record = NULL },
                     &dup),
                 CV_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(cv_graph_read(w.graph, (cv_graph_pass){ 7 }, out, CV_GRAPH_SAMPLED), CV_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(cv_graph_read(w.graph, (cv_graph_pass){ 1 }, out, CV_GRAPH_STORAGE_WRITE),
                 CV_ERROR_INVALID_ARGUMENT);
    world_close(&w);
}

static void record_nothing(const cv_graph_pass_context *pc, cv_command_list *list, void *user) {
    (void)pc, (void)list, (void)user;
}

/* The hybrid renderer's frame (renderer/src/renderer.c) as a graph. */
static void build_hybrid(graph_world *w) {
    cv_graph *g = w->graph;
    cv_buffer vertices_h;
    CHECK_OK(cv_buffer_create(w->ctx, &(cv_buffer_desc){ .size = 4096, .label = "scene vertices" }, &vertices_h));
    cv_graph_resource vertices, position, normal, depth, rays, visibility, accumulated, history, ping, pong, ping2;
    cv_graph_resource radiance, debug;
    CHECK_OK(cv_graph_import_buffer(g, vertices_h, 0, &vertices));
    cv_texture_desc rgba32 = { .width = 64, .height = 16, .format = CV_FORMAT_RGBA32F };
    cv_texture_desc rgba16 = { .width = 64, .height = 16, .format = CV_FORMAT_RGBA16F };
    cv_texture_desc d32 = { .width = 64, .height = 16, .format = CV_FORMAT_D32F };
#define NAMED(desc, name) (snprintf((desc).label, CV_LABEL_MAX, "%s", name), &(desc))
    CHECK_OK(cv_graph_create_texture(g, NAMED(rgba32, "gbuffer position"), &position));
    CHECK_OK(cv_graph_create_texture(g, NAMED(rgba32, "gbuffer normal"), &normal));
    CHECK_OK(cv_graph_create_texture(g, NAMED(d32, "depth"), &depth));
    CHECK_OK(cv_graph_create_buffer(g, &(cv_buffer_desc){ .size = 64 * 16 * 5 * CV_RAY_BYTES, .label = "rays" },
                                    16 * 5 * CV_RAY_BYTES, &rays));
    CHECK_OK(cv_graph_create_texture(g, NAMED(rgba16, "visibility"), &visibility));
    CHECK_OK(cv_graph_create_texture(g, NAMED(rgba16, "accumulated"), &accumulated));
    CHECK_OK(cv_graph_history(g, accumulated, &history));
    CHECK_OK(cv_graph_create_texture(g, NAMED(rgba16, "filter ping"), &ping));
    CHECK_OK(cv_graph_create_texture(g, NAMED(rgba16, "filter pong"), &pong));
    CHECK_OK(cv_graph_create_texture(g, NAMED(rgba16, "filter ping 2"), &ping2));
    CHECK_OK(cv_graph_create_texture(g, NAMED(rgba32, "radiance"), &radiance));
    CHECK_OK(cv_graph_create_texture(g, NAMED(rgba32, "debug normals"), &debug));
#undef NAMED
    cv_graph_pass p;
#define PASS(name, queue, policy) \
    CHECK_OK(cv_graph_add_pass(g, &(cv_graph_pass_desc){ name, queue, policy, record_nothing, NULL }, &p))
#define READ(r, a) CHECK_OK(cv_graph_read(g, p, r, a))
#define WRITE(r, a) CHECK_OK(cv_graph_write(g, p, r, a, CV_GRAPH_TRANSFER_AUTO))
    PASS("gbuffer", CV_QUEUE_GRAPHICS, CV_MGPU_PRIMARY_ONLY);
    READ(vertices, CV_GRAPH_STORAGE_READ);
    WRITE(position, CV_GRAPH_COLOR_TARGET);
    WRITE(normal, CV_GRAPH_COLOR_TARGET);
    WRITE(depth, CV_GRAPH_DEPTH_TARGET);
    PASS("raygen", CV_QUEUE_COMPUTE, CV_MGPU_ALL_DEVICES);
    READ(position, CV_GRAPH_STORAGE_READ);
    READ(normal, CV_GRAPH_STORAGE_READ);
    WRITE(rays, CV_GRAPH_STORAGE_WRITE);
    PASS("trace", CV_QUEUE_COMPUTE, CV_MGPU_ALL_DEVICES);
    READ(rays, CV_GRAPH_STORAGE_READ);
    WRITE(visibility, CV_GRAPH_STORAGE_WRITE);
    PASS("accumulate", CV_QUEUE_COMPUTE, CV_MGPU_PRIMARY_ONLY);
    READ(visibility, CV_GRAPH_STORAGE_READ);
    READ(history, CV_GRAPH_STORAGE_READ);
    WRITE(accumulated, CV_GRAPH_STORAGE_WRITE);
    cv_graph_resource steps[] = { accumulated, ping, pong, ping2 };
    const char *names[] = { "filter 1", "filter 2", "filter 3" };
    for (int i = 0; i < 3; i++) {
        PASS(names[i], CV_QUEUE_COMPUTE, CV_MGPU_PRIMARY_ONLY);
        READ(position, CV_GRAPH_STORAGE_READ);
        READ(normal, CV_GRAPH_STORAGE_READ);
        READ(steps[i], CV_GRAPH_STORAGE_READ);
        WRITE(steps[i + 1], CV_GRAPH_STORAGE_WRITE);
    }
    PASS("composite", CV_QUEUE_COMPUTE, CV_MGPU_PRIMARY_ONLY);
    READ(position, CV_GRAPH_STORAGE_READ);
    READ(normal, CV_GRAPH_STORAGE_READ);
    READ(ping2, CV_GRAPH_STORAGE_READ);
    READ(vertices, CV_GRAPH_STORAGE_READ);
    WRITE(radiance, CV_GRAPH_STORAGE_WRITE);
    PASS("debug view", CV_QUEUE_COMPUTE, CV_MGPU_PRIMARY_ONLY);
    READ(normal, CV_GRAPH_SAMPLED);
    WRITE(debug, CV_GRAPH_STORAGE_WRITE);
#undef PASS
#undef READ
#undef WRITE
    CHECK_OK(cv_graph_output(g, radiance));
}

static void test_hybrid_dump(void) {
    graph_world w;
    world_open(&w, 3);
    build_hybrid(&w);
    cv_partition part;
    CHECK_OK(cv_partition_split(64, 8, 3, NULL, &part));
    CHECK_OK(cv_graph_bake(w.graph, &(cv_graph_bake_desc){ .width = 64, .partition = &part }));
    char *text = dump_text(w.graph);
    const char *path = GRAPH_EXPECTED_DIR "/hybrid_3_devices.txt";
    if (getenv("CORVID_UPDATE_EXPECTED")) {
        FILE *f = fopen(path, "w");
        CHECK(f != NULL);
        if (f) {
            fputs(text, f);
            fclose(f);
        }
    }
    FILE *f = fopen(path, "r");
    CHECK(f != NULL);
    char expected[16384] = { 0 };
    if (f) {
        size_t n = fread(expected, 1, sizeof(expected) - 1, f);
        expected[n] = 0;
        fclose(f);
    }
    CHECK(text && strcmp(text, expected) == 0);
    if (text && strcmp(text, expected) != 0)
        fprintf(stderr, "dump differs from %s (CORVID_UPDATE_EXPECTED=1 rewrites it); got:\n%s", path, text);
    char *dot = NULL;
    size_t size = 0;
    FILE *df = open_memstream(&dot, &size);
    CHECK_OK(cv_graph_dump_dot(w.graph, df));
    fclose(df);
    CHECK(dot && strstr(dot, "digraph") && strstr(dot, "[label=\"visibility\"]"));
    free(dot);
    free(text);
    world_close(&w);
}

/* Zero-copy gathers (graph.h): mock devices cannot share memory, so auto
 * copies, on is refused naming the pair, a bad value is refused, and every
 * refusal keeps the previous bake. */
static void test_zero_copy_choice(void) {
    graph_world w;
    world_open(&w, 2);
    cv_graph_resource v = texture(&w, "v"), out = texture(&w, "out");
    cv_graph_pass trace = add_pass(&w, "trace", CV_MGPU_ALL_DEVICES);
    cv_graph_pass resolve = add_pass(&w, "resolve", CV_MGPU_PRIMARY_ONLY);
    CHECK_OK(cv_graph_write(w.graph, trace, v, CV_GRAPH_STORAGE_WRITE, CV_GRAPH_TRANSFER_AUTO));
    CHECK_OK(cv_graph_read(w.graph, resolve, v, CV_GRAPH_STORAGE_READ));
    CHECK_OK(cv_graph_write(w.graph, resolve, out, CV_GRAPH_STORAGE_WRITE, CV_GRAPH_TRANSFER_AUTO));
    CHECK_OK(cv_graph_output(w.graph, out));
    CHECK_OK(cv_graph_bake(w.graph, &bake64));
    cv_graph_stats st;
    CHECK_OK(cv_graph_get_stats(w.graph, &st));
    CHECK_EQ_INT(st.transfers, 1);
    CHECK_EQ_INT(st.copies, 1);
    CHECK_EQ_INT(st.zero_copy, 0);
    expect_rejected_by(&w, &(cv_graph_bake_desc){ .width = 64, .tile = 8, .zero_copy = CV_GRAPH_ZERO_COPY_ON },
                       CV_ERROR_UNSUPPORTED,
                       (const char *const[]){ "zero_copy is ON", "'gpu1'", "'gpu0'",
                                              "mock backend cannot share memory", NULL });
    expect_rejected_by(&w, &(cv_graph_bake_desc){ .width = 64, .tile = 8, .zero_copy = (cv_graph_zero_copy)7 },
                       CV_ERROR_INVALID_ARGUMENT, (const char *const[]){ "zero_copy 7", NULL });
    CHECK_OK(cv_graph_bake(w.graph, &(cv_graph_bake_desc){ .width = 64, .zero_copy = CV_GRAPH_ZERO_COPY_OFF }));
    CHECK_OK(cv_graph_get_stats(w.graph, &st));
    CHECK_EQ_INT(st.copies, 1);
    world_close(&w);
    /* One device: nothing to share, on or not. */
    world_open(&w, 1);
    v = texture(&w, "v");
    trace = add_pass(&w, "trace", CV_MGPU_ALL_DEVICES);
    CHECK_OK(cv_graph_write(w.graph, trace, v, CV_GRAPH_STORAGE_WRITE, CV_GRAPH_TRANSFER_AUTO));
    CHECK_OK(cv_graph_output(w.graph, v));
    CHECK_OK(cv_graph_bake(w.graph, &(cv_graph_bake_desc){ .width = 64, .zero_copy = CV_GRAPH_ZERO_COPY_ON }));
    world_close(&w);
}

/* The dump of a graph baked with partition p; *structure_bakes its count. */
static char *bake_with(graph_world *w, const cv_partition *p, uint32_t *structure_bakes) {
    CHECK_OK(cv_graph_bake(w->graph, &(cv_graph_bake_desc){ .width = p->width, .partition = p }));
    cv_graph_stats st = { 0 };
    CHECK_OK(cv_graph_get_stats(w->graph, &st));
    *structure_bakes = st.structure_bakes;
    return dump_text(w->graph);
}

/* The same dump as a fresh graph baked once with p. */
static bool same_as_fresh(const char *dump, const cv_partition *p) {
    graph_world fresh;
    world_open(&fresh, p->device_count);
    build_hybrid(&fresh);
    uint32_t bakes = 0;
    char *text = bake_with(&fresh, p, &bakes);
    bool same = dump && text && strcmp(dump, text) == 0;
    if (!same)
        fprintf(stderr, "rebaked:\n%s\nfresh:\n%s", dump ? dump : "", text ? text : "");
    free(text);
    world_close(&fresh);
    return same && bakes == 1;
}

/* A bake with a new split of the same devices keeps the structure and runs
 * the partition step only, giving what a fresh bake gives; a construction
 * call, a width or the devices with columns changing bakes it again; a
 * failing bake changes nothing, the count included. */
static void test_split_bake(void) {
    graph_world w;
    world_open(&w, 3);
    build_hybrid(&w);
    cv_partition even, uneven, two, narrow;
    CHECK_OK(cv_partition_split(64, 8, 3, NULL, &even));
    CHECK_OK(cv_partition_split(64, 8, 3, (const double[]){ 1.0, 3.0, 2.0 }, &uneven));
    CHECK_OK(cv_partition_split(64, 8, 3, (const double[]){ 1.0, 0.0, 1.0 }, &two));
    CHECK_OK(cv_partition_split(48, 8, 3, NULL, &narrow));
    CHECK(uneven.ranges[1].width != even.ranges[1].width && two.ranges[1].width == 0);
    uint32_t bakes = 0;
    free(bake_with(&w, &even, &bakes));
    CHECK_EQ_INT(bakes, 1);
    char *text = bake_with(&w, &uneven, &bakes);
    CHECK_EQ_INT(bakes, 1);
    CHECK(same_as_fresh(text, &uneven));
    free(text);
    text = bake_with(&w, &even, &bakes);
    CHECK_EQ_INT(bakes, 1);
    CHECK(same_as_fresh(text, &even));
    free(text);
    /* The balancer's split, and synchronous transfers, keep it too. */
    CHECK_OK(cv_graph_bake(w.graph, &(cv_graph_bake_desc){ .width = 64, .tile = 8, .sync_transfers = true }));
    cv_graph_stats st;
    CHECK_OK(cv_graph_get_stats(w.graph, &st));
    CHECK_EQ_INT(st.structure_bakes, 1);
    /* A failing bake (a partition for two devices) changes nothing. */
    cv_partition wrong;
    CHECK_OK(cv_partition_split(64, 8, 2, NULL, &wrong));
    CHECK_RESULT(cv_graph_bake(w.graph, &(cv_graph_bake_desc){ .width = 64, .partition = &wrong }),
                 CV_ERROR_INVALID_ARGUMENT);
    CHECK_OK(cv_graph_get_stats(w.graph, &st));
    CHECK_EQ_INT(st.structure_bakes, 1);
    /* Another set of devices with columns, another width: baked again. */
    text = bake_with(&w, &two, &bakes);
    CHECK_EQ_INT(bakes, 2);
    CHECK(same_as_fresh(text, &two));
    free(text);
    free(bake_with(&w, &narrow, &bakes));
    CHECK_EQ_INT(bakes, 3);
    free(bake_with(&w, &narrow, &bakes));
    CHECK_EQ_INT(bakes, 3);
    /* Construction calls: an enabled pass, a declaration. */
    cv_graph_pass debug = { 9 };
    CHECK_OK(cv_graph_enable_pass(w.graph, debug, true)); /* no change: kept */
    free(bake_with(&w, &narrow, &bakes));
    CHECK_EQ_INT(bakes, 3);
    CHECK_OK(cv_graph_enable_pass(w.graph, debug, false));
    free(bake_with(&w, &narrow, &bakes));
    CHECK_EQ_INT(bakes, 4);
    CHECK_OK(cv_graph_read(w.graph, (cv_graph_pass){ 8 }, (cv_graph_resource){ 6 }, CV_GRAPH_STORAGE_READ));
    text = bake_with(&w, &narrow, &bakes);
    CHECK_EQ_INT(bakes, 5);
    CHECK(text && strstr(text, "'scene vertices' (storage read), 'visibility' (storage read)\n"));
    free(text);
    world_close(&w);
}

int main(void) {
    test_culling();
    test_zero_copy_choice();
    test_transient_reuse();
    test_cross_device_edges();
    test_bad_graphs();
    test_hybrid_dump();
    test_split_bake();
    CHECK_NOTHING_LIVE();
    return check_report("graph_bake_test");
}
