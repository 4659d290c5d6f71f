/* The render graph executed on mock devices: the barriers each pass's list
 * begins with, and a small frame (clear, multicast, copy, stamp, copy-back)
 * on three devices and on CV_MAX_DEVICES, checked byte by byte. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "graph_test_util.h"

/* What a pass's list held before its record callback ran: the graph's barriers. */
typedef struct seen_barriers {
    uint32_t count;
    uint64_t resources[8];
    uint64_t x; /* the pass's handle of resource x */
    cv_graph_resource watch;
} seen_barriers;

static void note_barriers(const cv_graph_pass_context *pc, cv_command_list *list, void *user) {
    seen_barriers *s = user;
    s->count = 0;
    for (uint32_t i = 0; i < list->count; i++)
        if (list->commands[i].type == CV_CMD_BARRIER && s->count < 8)
            s->resources[s->count++] = list->commands[i].u.barrier.resource.id;
    s->x = cv_graph_texture(pc, s->watch).id;
}

static void test_barriers(void) {
    graph_world w;
    world_open(&w, 1);
    cv_graph_resource x = texture(&w, "x"), y = texture(&w, "y"), z = texture(&w, "z"), out = texture(&w, "out");
    seen_barriers seen[5] = { 0 };
    const char *names[5] = { "write x", "read x 1", "read x 2", "rewrite x", "read x 3" };
    cv_graph_pass p[5];
    for (int i = 0; i < 5; i++) {
        seen[i].watch = x;
        CHECK_OK(cv_graph_add_pass(w.graph,
                                   &(cv_graph_pass_desc){ .name = names[i],
                                                          .queue = CV_QUEUE_COMPUTE,
                                                          .policy = CV_MGPU_PRIMARY_ONLY,
                                                          .record = note_barriers,
                                                          .user = &seen[i] },
                                   &p[i]));
    }
    CHECK_OK(cv_graph_write(w.graph, p[0], x, CV_GRAPH_STORAGE_WRITE, CV_GRAPH_TRANSFER_AUTO));
    CHECK_OK(cv_graph_read(w.graph, p[1], x, CV_GRAPH_SAMPLED)); /* write -> read */
    CHECK_OK(cv_graph_write(w.graph, p[1], y, CV_GRAPH_STORAGE_WRITE, CV_GRAPH_TRANSFER_AUTO));
    CHECK_OK(cv_graph_read(w.graph, p[2], x, CV_GRAPH_SAMPLED)); /* read -> read: none */
    CHECK_OK(cv_graph_write(w.graph, p[2], z, CV_GRAPH_STORAGE_WRITE, CV_GRAPH_TRANSFER_AUTO));
    CHECK_OK(cv_graph_read(w.graph, p[3], y, CV_GRAPH_SAMPLED));                                /* write -> read */
    CHECK_OK(cv_graph_read(w.graph, p[3], z, CV_GRAPH_SAMPLED));                                /* write -> read */
    CHECK_OK(cv_graph_write(w.graph, p[3], x, CV_GRAPH_STORAGE_WRITE, CV_GRAPH_TRANSFER_AUTO)); /* read -> write */
    CHECK_OK(cv_graph_read(w.graph, p[4], x, CV_GRAPH_STORAGE_READ));                           /* write -> read */
    CHECK_OK(cv_graph_write(w.graph, p[4], out, CV_GRAPH_STORAGE_WRITE, CV_GRAPH_TRANSFER_AUTO));
    CHECK_OK(cv_graph_output(w.graph, out));
    CHECK_OK(cv_graph_bake(w.graph, &(cv_graph_bake_desc){ .width = 64 }));
    cv_graph_stats st;
    CHECK_OK(cv_graph_get_stats(w.graph, &st));
    /* 'out' is born after y's last read and shares its memory: one more hazard (read -> write). */
    CHECK_EQ_INT(cv_graph_physical_of(w.graph, out), cv_graph_physical_of(w.graph, y));
    CHECK_EQ_INT(st.barriers, 6);
    cv_graph_timing t[8];
    uint32_t n = 0;
    CHECK_OK(cv_graph_execute(w.graph, t, 8, &n));
    CHECK_EQ_INT(n, 5);
    const uint32_t expect_count[5] = { 0, 1, 0, 3, 2 };
    for (int i = 0; i < 5; i++)
        CHECK_EQ_INT(seen[i].count, expect_count[i]);
    CHECK_EQ_INT(seen[1].resources[0], seen[1].x);
    CHECK_EQ_INT(seen[3].resources[2], seen[3].x); /* after y and z, in declaration order */
    CHECK_EQ_INT(seen[4].resources[0], seen[4].x);
    CHECK(seen[4].resources[1] != seen[4].x); /* 'out' over y's memory */
    CHECK(seen[3].resources[0] != seen[3].x && seen[3].resources[1] != seen[3].x);
    CHECK(strcmp(t[3].name, "rewrite x") == 0);
    world_close(&w);
}

/* 48 columns of one u32 each; three devices get 16 columns each. */
#define COLUMNS 48u

typedef struct frame {
    cv_graph_resource a, b;
    uint32_t columns; /* COLUMNS, or more for more devices */
} frame;

static void clear_a(const cv_graph_pass_context *pc, cv_command_list *list, void *user) {
    const frame *f = user;
    cv_cmd_clear_buffer(list, pc->queue,
                        &(cv_clear_buffer_args){
                            .buffer = cv_graph_buffer(pc, f->a), .size = f->columns * 4, .value = 0x11111111u });
}

/* Even columns of the window get 1000 + column; odd ones keep what the copy put there. */
static void stamp_b(const cv_graph_pass_context *pc, cv_command_list *list, void *user) {
    const frame *f = user;
    for (uint32_t c = pc->x; c < pc->x + pc->width; c += 2) {
        uint32_t value = 1000 + c;
        cv_cmd_update_buffer(list, pc->queue,
                             &(cv_update_buffer_args){ .buffer = cv_graph_buffer(pc, f->b),
                                                       .offset = c * 4,
                                                       .data = &value,
                                                       .data_size = 4 });
    }
}

/* The frame on `count` devices, 16 columns each: with CV_MAX_DEVICES, device
 * bits past 31 (a 32-bit mask loaded device 35's resources on device 3). */
static void test_execute_devices(uint32_t count) {
    enum { MAX_COLUMNS = CV_MAX_DEVICES * 16, MAX_TIMINGS = 2 * CV_MAX_DEVICES + 4 };
    graph_world w;
    world_open(&w, count);
    const uint32_t columns = count * 16;
    cv_buffer result_h;
    CHECK_OK(cv_buffer_create(w.ctx, &(cv_buffer_desc){ .size = columns * 4, .label = "result" }, &result_h));
    frame f = { .columns = columns };
    cv_graph_resource result;
    CHECK_OK(cv_graph_create_buffer(w.graph, &(cv_buffer_desc){ .size = columns * 4, .label = "a" }, 4, &f.a));
    CHECK_OK(cv_graph_create_buffer(w.graph, &(cv_buffer_desc){ .size = columns * 4, .label = "b" }, 4, &f.b));
    CHECK_OK(cv_graph_import_buffer(w.graph, result_h, 4, &result));
    cv_graph_pass clear, copy, stamp, gather;
    CHECK_OK(cv_graph_add_pass(w.graph,
                               &(cv_graph_pass_desc){ .name = "clear",
                                                      .queue = CV_QUEUE_COMPUTE,
                                                      .policy = CV_MGPU_PRIMARY_ONLY,
                                                      .record = clear_a,
                                                      .user = &f },
                               &clear));
    CHECK_OK(cv_graph_write(w.graph, clear, f.a, CV_GRAPH_TRANSFER_DST, CV_GRAPH_TRANSFER_AUTO));
    CHECK_OK(cv_graph_add_copy_pass(w.graph, "copy a to b", CV_MGPU_ALL_DEVICES, f.a, f.b, &copy));
    CHECK_OK(cv_graph_add_pass(w.graph,
                               &(cv_graph_pass_desc){ .name = "stamp",
                                                      .queue = CV_QUEUE_COMPUTE,
                                                      .policy = CV_MGPU_ALL_DEVICES,
                                                      .record = stamp_b,
                                                      .user = &f },
                               &stamp));
    CHECK_OK(cv_graph_read(w.graph, stamp, f.b, CV_GRAPH_TRANSFER_SRC));
    CHECK_OK(cv_graph_write(w.graph, stamp, f.b, CV_GRAPH_TRANSFER_DST, CV_GRAPH_TRANSFER_AUTO));
    CHECK_OK(cv_graph_add_copy_pass(w.graph, "gather", CV_MGPU_PRIMARY_ONLY, f.b, result, &gather));
    CHECK_OK(cv_graph_output(w.graph, result));
    CHECK_OK(cv_graph_bake(w.graph, &(cv_graph_bake_desc){ .width = columns, .tile = 8 }));
    cv_graph_stats st;
    CHECK_OK(cv_graph_get_stats(w.graph, &st));
    CHECK_EQ_INT(st.transfers, 2); /* a multicast, b copied back */
    CHECK_EQ_INT(st.copies, 2 * (count - 1));

    for (int frame_no = 0; frame_no < 2; frame_no++) {
        static uint32_t zero[MAX_COLUMNS];
        CHECK_OK(cv_device_write_buffer(w.devices[0], result_h, 0, columns * 4, zero));
        cv_graph_timing t[MAX_TIMINGS];
        uint32_t n = 0;
        CHECK_OK(cv_graph_execute(w.graph, t, MAX_TIMINGS, &n));
        /* The first frame splits evenly; later splits follow measured times (a
         * device may get no columns, and no instance), so only bytes are checked. */
        if (frame_no == 0)
            CHECK_EQ_INT(n, 1 + 2 + count + count + 1); /* clear, 2 transfers, copy and stamp on each, gather */
        static uint32_t got[MAX_COLUMNS];
        CHECK_OK(cv_device_read_buffer(w.devices[0], result_h, 0, columns * 4, got));
        int wrong = 0;
        for (uint32_t c = 0; c < columns; c++)
            wrong += got[c] != (c % 2 ? 0x11111111u : 1000 + c); /* odd: cleared on dev0, multicast */
        CHECK_EQ_INT(wrong, 0);
        /* Rebake from the balancer's measurements: still the same bytes. */
        CHECK_OK(cv_graph_bake(w.graph, &(cv_graph_bake_desc){ .width = columns, .tile = 8 }));
    }
    /* A new split of the same devices runs the partition step only: new
     * windows and copy plans, still the same bytes. */
    double weights[CV_MAX_DEVICES];
    for (uint32_t d = 0; d < count; d++)
        weights[d] = 1.0 + d % 3;
    cv_partition even, uneven;
    CHECK_OK(cv_partition_split(columns, 8, count, NULL, &even));
    CHECK_OK(cv_partition_split(columns, 8, count, weights, &uneven));
    CHECK_OK(cv_graph_bake(w.graph, &(cv_graph_bake_desc){ .width = columns, .partition = &even }));
    CHECK_OK(cv_graph_get_stats(w.graph, &st));
    uint32_t structure_bakes = st.structure_bakes;
    CHECK_OK(cv_graph_bake(w.graph, &(cv_graph_bake_desc){ .width = columns, .partition = &uneven }));
    CHECK_OK(cv_graph_get_stats(w.graph, &st));
    CHECK_EQ_INT(st.structure_bakes, structure_bakes);
    static uint32_t zero[MAX_COLUMNS], got[MAX_COLUMNS];
    CHECK_OK(cv_device_write_buffer(w.devices[0], result_h, 0, columns * 4, zero));
    CHECK_OK(cv_graph_execute(w.graph, NULL, 0, NULL));
    CHECK_OK(cv_device_read_buffer(w.devices[0], result_h, 0, columns * 4, got));
    int wrong = 0;
    for (uint32_t c = 0; c < columns; c++)
        wrong += got[c] != (c % 2 ? 0x11111111u : 1000 + c);
    CHECK_EQ_INT(wrong, 0);
    CHECK_OK(cv_buffer_destroy(w.ctx, result_h));
    world_close(&w);
}

/* A pass that runs on some frames only (cv_graph_enable_pass) and frames
 * submitted without waiting (cv_graph_submit), as the renderer uses them: a
 * primary pass fills an imported buffer the all-devices copy reads. */
typedef struct fill_frame {
    cv_graph_resource src;
    uint32_t value;
} fill_frame;

static void fill_src(const cv_graph_pass_context *pc, cv_command_list *list, void *user) {
    const fill_frame *f = user;
    cv_cmd_clear_buffer(list, pc->queue,
                        &(cv_clear_buffer_args){
                            .buffer = cv_graph_buffer(pc, f->src), .size = COLUMNS * 4, .value = f->value });
}

static int count_wrong(graph_world *w, cv_buffer result_h, uint32_t expect) {
    uint32_t got[COLUMNS];
    CHECK_OK(cv_device_read_buffer(w->devices[0], result_h, 0, sizeof(got), got));
    int wrong = 0;
    for (uint32_t c = 0; c < COLUMNS; c++)
        wrong += got[c] != expect;
    return wrong;
}

static void test_enable_and_submit(void) {
    graph_world w;
    world_open(&w, 3);
    cv_buffer src_h, result_h;
    CHECK_OK(cv_buffer_create(w.ctx, &(cv_buffer_desc){ .size = COLUMNS * 4, .label = "src" }, &src_h));
    CHECK_OK(cv_buffer_create(w.ctx, &(cv_buffer_desc){ .size = COLUMNS * 4, .label = "result" }, &result_h));
    fill_frame f = { .value = 0x22222222u };
    cv_graph_resource b, result;
    CHECK_OK(cv_graph_import_buffer(w.graph, src_h, 4, &f.src));
    CHECK_OK(cv_graph_create_buffer(w.graph, &(cv_buffer_desc){ .size = COLUMNS * 4, .label = "b" }, 4, &b));
    CHECK_OK(cv_graph_import_buffer(w.graph, result_h, 4, &result));
    cv_graph_pass fill, spread, gather;
    CHECK_OK(cv_graph_add_pass(w.graph,
                               &(cv_graph_pass_desc){ .name = "fill",
                                                      .queue = CV_QUEUE_COMPUTE,
                                                      .policy = CV_MGPU_PRIMARY_ONLY,
                                                      .record = fill_src,
                                                      .user = &f },
                               &fill));
    CHECK_OK(cv_graph_write(w.graph, fill, f.src, CV_GRAPH_TRANSFER_DST, CV_GRAPH_TRANSFER_AUTO));
    CHECK_OK(cv_graph_add_copy_pass(w.graph, "spread", CV_MGPU_ALL_DEVICES, f.src, b, &spread));
    CHECK_OK(cv_graph_add_copy_pass(w.graph, "gather", CV_MGPU_PRIMARY_ONLY, b, result, &gather));
    CHECK_OK(cv_graph_output(w.graph, result));
    CHECK(cv_graph_enable_pass(w.graph, (cv_graph_pass){ 99 }, false) != CV_OK);

    /* Frame 1: fill runs, its buffer is multicast, b is copied back. */
    CHECK_OK(cv_graph_bake(w.graph, &(cv_graph_bake_desc){ .width = COLUMNS, .tile = 8 }));
    cv_graph_stats st;
    CHECK_OK(cv_graph_get_stats(w.graph, &st));
    CHECK_EQ_INT(st.transfers, 2);
    cv_partition part;
    CHECK_OK(cv_graph_get_partition(w.graph, &part));
    CHECK_EQ_INT(part.width, COLUMNS);
    CHECK_EQ_INT(part.device_count, 3);
    cv_graph_timing t[16];
    uint32_t n = 0;
    CHECK_OK(cv_graph_execute(w.graph, t, 16, &n));
    uint64_t moved = 0;
    for (uint32_t i = 0; i < n && i < 16; i++)
        moved += strncmp(t[i].name, "transfer ", 9) == 0 ? t[i].bytes : 0;
    CHECK_EQ_INT(moved, 2 * COLUMNS * 4 + 2 * (COLUMNS / 3) * 4); /* whole buffer to 2 devices, 2 windows back */
    CHECK_EQ_INT(count_wrong(&w, result_h, 0x22222222u), 0);

    /* Frame 2: fill disabled: no multicast; every device reads what it holds. */
    CHECK_OK(cv_graph_enable_pass(w.graph, fill, false));
    f.value = 0x33333333u; /* would show if fill still ran */
    CHECK_OK(cv_graph_bake(w.graph, &(cv_graph_bake_desc){ .width = COLUMNS, .tile = 8 }));
    CHECK(!cv_graph_pass_kept(w.graph, fill));
    CHECK(cv_graph_pass_kept(w.graph, spread));
    CHECK_OK(cv_graph_get_stats(w.graph, &st));
    CHECK_EQ_INT(st.transfers, 1);
    CHECK_EQ_INT(st.culled, 1);
    char *text = dump_text(w.graph);
    CHECK(text && strstr(text, "culled: 'fill'\n") && !strstr(text, "pass 'fill'"));
    free(text);
    /* Submitted without waiting: the last ticket per device covers the frame. */
    uint64_t tickets[CV_MAX_DEVICES];
    CHECK_OK(cv_graph_submit(w.graph, tickets));
    /* (The balancer may give a device no columns when the machine is busy:
     * the mock's timings are CPU times. Such a device has no work this frame.) */
    cv_partition used;
    CHECK_OK(cv_graph_get_partition(w.graph, &used));
    for (uint32_t d = 0; d < 3; d++) {
        CHECK(tickets[d] > 0 || used.ranges[d].width == 0);
        if (tickets[d])
            CHECK_OK(cv_device_wait(w.devices[d], tickets[d], UINT64_MAX));
    }
    CHECK_EQ_INT(tickets[3], 0);
    CHECK_EQ_INT(count_wrong(&w, result_h, 0x22222222u), 0);

    /* Enabled again: it runs, and multicasts, once more. */
    CHECK_OK(cv_graph_enable_pass(w.graph, fill, true));
    CHECK_OK(cv_graph_bake(w.graph, &(cv_graph_bake_desc){ .width = COLUMNS, .tile = 8 }));
    CHECK_OK(cv_graph_execute(w.graph, t, 16, &n));
    CHECK_EQ_INT(count_wrong(&w, result_h, 0x33333333u), 0);
    CHECK_OK(cv_buffer_destroy(w.ctx, src_h));
    CHECK_OK(cv_buffer_destroy(w.ctx, result_h));
    world_close(&w);
}

/* Frames submitted without waiting, collected later (cv_graph_collect): ids
 * count evaluations; a collect gives the same timings as an execute would
 * (one per pass instance and transfer, the bytes moved) and feeds the
 * balancer with the partition that frame used; a frame is collected once,
 * only while among the last CV_GRAPH_FRAMES_KEPT, never before it ran. */
static void test_collect(void) {
    graph_world w;
    world_open(&w, 3);
    cv_buffer src_h, result_h;
    CHECK_OK(cv_buffer_create(w.ctx, &(cv_buffer_desc){ .size = COLUMNS * 4, .label = "src" }, &src_h));
    CHECK_OK(cv_buffer_create(w.ctx, &(cv_buffer_desc){ .size = COLUMNS * 4, .label = "result" }, &result_h));
    fill_frame f = { .value = 0x44444444u };
    cv_graph_resource b, result;
    CHECK_OK(cv_graph_import_buffer(w.graph, src_h, 4, &f.src));
    CHECK_OK(cv_graph_create_buffer(w.graph, &(cv_buffer_desc){ .size = COLUMNS * 4, .label = "b" }, 4, &b));
    CHECK_OK(cv_graph_import_buffer(w.graph, result_h, 4, &result));
    cv_graph_pass fill, spread, gather;
    CHECK_OK(cv_graph_add_pass(w.graph,
                               &(cv_graph_pass_desc){ .name = "fill",
                                                      .queue = CV_QUEUE_COMPUTE,
                                                      .policy = CV_MGPU_PRIMARY_ONLY,
                                                      .record = fill_src,
                                                      .user = &f },
                               &fill));
    CHECK_OK(cv_graph_write(w.graph, fill, f.src, CV_GRAPH_TRANSFER_DST, CV_GRAPH_TRANSFER_AUTO));
    CHECK_OK(cv_graph_add_copy_pass(w.graph, "spread", CV_MGPU_ALL_DEVICES, f.src, b, &spread));
    CHECK_OK(cv_graph_add_copy_pass(w.graph, "gather", CV_MGPU_PRIMARY_ONLY, b, result, &gather));
    CHECK_OK(cv_graph_output(w.graph, result));
    CHECK_EQ_INT(cv_graph_frame_id(w.graph), 0);
    cv_graph_timing t[16];
    uint32_t n = 99;
    CHECK_RESULT(cv_graph_collect(w.graph, 1, t, 16, &n), CV_ERROR_BAD_STATE);
    CHECK(strstr(cv_last_error(), "not evaluated yet") != NULL);
    CHECK_RESULT(cv_graph_collect(w.graph, 0, t, 16, &n), CV_ERROR_INVALID_ARGUMENT);
    CHECK_EQ_INT(n, 99);
    uint64_t ids[CV_GRAPH_FRAMES_KEPT + 2];
    for (uint32_t k = 0; k < CV_GRAPH_FRAMES_KEPT + 2; k++) {
        CHECK_OK(cv_graph_bake(w.graph, &(cv_graph_bake_desc){ .width = COLUMNS, .tile = 8 }));
        uint64_t tickets[CV_MAX_DEVICES];
        CHECK_OK(cv_graph_submit(w.graph, tickets));
        ids[k] = cv_graph_frame_id(w.graph);
        CHECK_EQ_INT(ids[k], k + 1);
    }
    /* The first two were evaluated more than CV_GRAPH_FRAMES_KEPT frames ago. */
    CHECK_RESULT(cv_graph_collect(w.graph, ids[0], t, 16, &n), CV_ERROR_BAD_STATE);
    CHECK(strstr(cv_last_error(), "no longer kept") != NULL);
    CHECK_RESULT(cv_graph_collect(w.graph, ids[1], t, 16, &n), CV_ERROR_BAD_STATE);
    uint64_t moved = 0;
    uint32_t traced = 0;
    CHECK_OK(cv_graph_collect(w.graph, ids[2], t, 16, &n));
    for (uint32_t i = 0; i < n && i < 16; i++) {
        moved += strncmp(t[i].name, "transfer ", 9) == 0 ? t[i].bytes : 0;
        traced += strcmp(t[i].name, "spread") == 0;
    }
    CHECK_EQ_INT(traced, 3); /* one timing per device of the all-devices pass */
    CHECK_EQ_INT(moved, 2 * COLUMNS * 4 + 2 * (COLUMNS / 3) * 4);
    CHECK_RESULT(cv_graph_collect(w.graph, ids[2], t, 16, &n), CV_ERROR_BAD_STATE);
    CHECK(strstr(cv_last_error(), "already collected") != NULL);
    for (uint32_t k = 3; k < CV_GRAPH_FRAMES_KEPT + 2; k++)
        CHECK_OK(cv_graph_collect(w.graph, ids[k], t, 16, &n));
    CHECK_EQ_INT(count_wrong(&w, result_h, 0x44444444u), 0);
    CHECK_OK(cv_buffer_destroy(w.ctx, src_h));
    CHECK_OK(cv_buffer_destroy(w.ctx, result_h));
    world_close(&w);
}

int main(void) {
    test_barriers();
    test_execute_devices(3);
    test_execute_devices(CV_MAX_DEVICES);
    test_enable_and_submit();
    test_collect();
    CHECK_NOTHING_LIVE();
    return check_report("graph_execute_test");
}
