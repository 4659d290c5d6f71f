/* Recording-time checks of command lists (client/src/command_list.c): what
 * needs no device is refused when recorded, a failed call records nothing,
 * errors are sticky and name the command, the queue mask accumulates, and
 * lists recorded on 8 threads at once come out identical to serial ones. */
#include <pthread.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "corvid/command_codec.h"
#include "random_list.h"

static const cv_buffer BUF = { 0x1000000100000001ull };
static const cv_texture TEX = { 0x2000000100000002ull };
static const cv_pipeline PIPE = { 0x4000000100000003ull };

static void fresh(cv_command_list *list) {
    cv_command_list_finish(list);
    cv_command_list_init(list);
    cv_command_list_begin(list);
}

static cv_result begin_pass(cv_command_list *list) {
    return cv_cmd_begin_render_pass(list, CV_QUEUE_GRAPHICS, &(cv_begin_render_pass_args){ .color0 = TEX });
}

/* The error is kept on the list, says which command, and the list state is
 * what it was before the failed call. */
static void check_failed(cv_command_list *list, cv_result got, cv_result want, uint32_t count, const char *needle) {
    CHECK_RESULT(got, want);
    CHECK_EQ_INT(list->error, want);
    CHECK_EQ_INT(list->count, count);
    char prefix[32];
    snprintf(prefix, sizeof(prefix), "command %u: ", count);
    if (!strstr(cv_command_list_error(list), prefix) || !strstr(cv_command_list_error(list), needle))
        fprintf(stderr, "message \"%s\" lacks \"%s\" or \"%s\"\n", cv_command_list_error(list), prefix, needle);
    CHECK(strncmp(cv_command_list_error(list), prefix, strlen(prefix)) == 0);
    CHECK(strstr(cv_command_list_error(list), needle) != NULL);
    CHECK(strcmp(cv_last_error(), cv_command_list_error(list)) == 0);
}

static void test_queue_mismatch(void) {
    cv_command_list l;
    cv_command_list_init(&l);
    fresh(&l);
    CHECK_OK(begin_pass(&l));
    check_failed(&l, cv_cmd_draw(&l, CV_QUEUE_COMPUTE, &(cv_draw_args){ .pipeline = PIPE, .vertex_count = 3 }),
                 CV_ERROR_QUEUE_MISMATCH, 1, "draw is not allowed on the compute queue");
    fresh(&l);
    check_failed(&l, cv_cmd_dispatch(&l, CV_QUEUE_COPY, &(cv_dispatch_args){ .pipeline = PIPE }),
                 CV_ERROR_QUEUE_MISMATCH, 0, "copy queue");
    fresh(&l);
    check_failed(&l, cv_cmd_barrier(&l, (cv_queue_type)7, &(cv_barrier_args){ { 0 } }), CV_ERROR_INVALID_ARGUMENT, 0,
                 "unknown queue type 7");
    cv_command_list_finish(&l);
}

static void test_wrong_handle_type(void) {
    cv_command_list l;
    cv_command_list_init(&l);
    fresh(&l);
    check_failed(&l,
                 cv_cmd_copy_buffer(&l, CV_QUEUE_COPY,
                                    &(cv_copy_buffer_args){ .src = BUF, .dst = { TEX.id }, .size = 4 }),
                 CV_ERROR_WRONG_HANDLE_TYPE, 0, "'dst' wants a buffer handle, got a texture handle");
    fresh(&l);
    cv_binding b = { .resource = { BUF.id }, .sampler = { BUF.id } };
    check_failed(&l,
                 cv_cmd_dispatch(&l, CV_QUEUE_COMPUTE,
                                 &(cv_dispatch_args){ .pipeline = PIPE, .bindings = &b, .bindings_count = 1 }),
                 CV_ERROR_WRONG_HANDLE_TYPE, 0, "'binding sampler' wants a sampler handle");
    CHECK_EQ_INT(l.binding_count, 0);
    cv_command_list_finish(&l);
}

static void test_size_limits(void) {
    cv_command_list l;
    cv_command_list_init(&l);
    fresh(&l);
    cv_binding b[CV_MAX_BINDINGS + 1];
    for (int i = 0; i <= CV_MAX_BINDINGS; i++)
        b[i] = (cv_binding){ .resource = { BUF.id } };
    CHECK_OK(
        cv_cmd_dispatch(&l, CV_QUEUE_COMPUTE,
                        &(cv_dispatch_args){ .pipeline = PIPE, .bindings = b, .bindings_count = CV_MAX_BINDINGS }));
    CHECK_EQ_INT(l.binding_count, CV_MAX_BINDINGS);
    check_failed(&l,
                 cv_cmd_dispatch(&l, CV_QUEUE_COMPUTE,
                                 &(cv_dispatch_args){
                                     .pipeline = PIPE, .bindings = b, .bindings_count = CV_MAX_BINDINGS + 1 }),
                 CV_ERROR_LIMIT_EXCEEDED, 1, "17 bindings, limit 16");
    CHECK_EQ_INT(l.binding_count, CV_MAX_BINDINGS);

    static uint8_t data[CV_MAX_UPDATE_BYTES + 1];
    fresh(&l);
    CHECK_OK(cv_cmd_update_buffer(&l, CV_QUEUE_COPY,
                                  &(cv_update_buffer_args){
                                      .buffer = BUF, .data = data, .data_size = CV_MAX_UPDATE_BYTES }));
    uint32_t data_size = l.data_size;
    check_failed(&l,
                 cv_cmd_update_buffer(&l, CV_QUEUE_COPY,
                                      &(cv_update_buffer_args){
                                          .buffer = BUF, .data = data, .data_size = CV_MAX_UPDATE_BYTES + 1 }),
                 CV_ERROR_LIMIT_EXCEEDED, 1, "65537 bytes, limit 65536");
    CHECK_EQ_INT(l.data_size, data_size);

    /* Push constants are stored before the size rule is checked: the failed
     * call must take its bytes back out. */
    fresh(&l);
    CHECK_OK(
        cv_cmd_dispatch(&l, CV_QUEUE_COMPUTE,
                        &(cv_dispatch_args){ .pipeline = PIPE, .push = data, .push_size = CV_MAX_PUSH_CONSTANTS }));
    data_size = l.data_size;
    check_failed(&l,
                 cv_cmd_dispatch(&l, CV_QUEUE_COMPUTE,
                                 &(cv_dispatch_args){
                                     .pipeline = PIPE, .push = data, .push_size = CV_MAX_PUSH_CONSTANTS + 1 }),
                 CV_ERROR_LIMIT_EXCEEDED, 1, "129 bytes of push constants, limit 128");
    CHECK_EQ_INT(l.data_size, data_size);
    cv_command_list_finish(&l);
}

static void test_structure(void) {
    cv_command_list l;
    cv_command_list_init(&l);
    fresh(&l);
    CHECK_OK(cv_cmd_barrier(&l, CV_QUEUE_GRAPHICS, &(cv_barrier_args){ { 0 } }));
    check_failed(&l, cv_cmd_draw(&l, CV_QUEUE_GRAPHICS, &(cv_draw_args){ .pipeline = PIPE }), CV_ERROR_BAD_STATE, 1,
                 "draw outside a render pass");

    fresh(&l);
    CHECK_OK(begin_pass(&l));
    check_failed(&l, begin_pass(&l), CV_ERROR_BAD_STATE, 1, "begin_render_pass inside a render pass");

    fresh(&l);
    CHECK_OK(begin_pass(&l));
    check_failed(&l, cv_cmd_dispatch(&l, CV_QUEUE_GRAPHICS, &(cv_dispatch_args){ .pipeline = PIPE }),
                 CV_ERROR_BAD_STATE, 1, "dispatch inside a render pass");

    fresh(&l);
    check_failed(&l, cv_cmd_end_marker(&l, CV_QUEUE_COPY, &(cv_end_marker_args){ 0 }), CV_ERROR_BAD_STATE, 0,
                 "end_marker without begin_marker");

    fresh(&l);
    check_failed(&l, cv_cmd_end_render_pass(&l, CV_QUEUE_GRAPHICS, &(cv_end_render_pass_args){ 0 }),
                 CV_ERROR_BAD_STATE, 0, "end_render_pass without begin_render_pass");

    fresh(&l);
    CHECK_OK(begin_pass(&l));
    CHECK_OK(cv_cmd_draw(&l, CV_QUEUE_GRAPHICS, &(cv_draw_args){ .pipeline = PIPE, .vertex_count = 3 }));
    CHECK_RESULT(cv_command_list_end(&l), CV_ERROR_BAD_STATE);
    CHECK(strstr(cv_command_list_error(&l), "ends inside a render pass") != NULL);
    CHECK(!l.ended_ok);

    fresh(&l);
    CHECK_OK(cv_cmd_begin_marker(&l, CV_QUEUE_COMPUTE, &(cv_begin_marker_args){ .label = "outer" }));
    CHECK_OK(cv_cmd_begin_marker(&l, CV_QUEUE_COMPUTE, &(cv_begin_marker_args){ .label = "inner" }));
    CHECK_OK(cv_cmd_end_marker(&l, CV_QUEUE_COMPUTE, &(cv_end_marker_args){ 0 }));
    CHECK_RESULT(cv_command_list_end(&l), CV_ERROR_BAD_STATE);
    CHECK(strstr(cv_command_list_error(&l), "1 open begin_marker") != NULL);

    /* Markers and barriers are fine inside a pass; a clean pass ends well. */
    fresh(&l);
    CHECK_OK(begin_pass(&l));
    CHECK_OK(cv_cmd_begin_marker(&l, CV_QUEUE_GRAPHICS, &(cv_begin_marker_args){ .label = "shadow" }));
    CHECK_OK(cv_cmd_draw(&l, CV_QUEUE_GRAPHICS, &(cv_draw_args){ .pipeline = PIPE, .vertex_count = 3 }));
    CHECK_OK(cv_cmd_barrier(&l, CV_QUEUE_GRAPHICS, &(cv_barrier_args){ { TEX.id } }));
    CHECK_OK(cv_cmd_end_marker(&l, CV_QUEUE_GRAPHICS, &(cv_end_marker_args){ 0 }));
    CHECK_OK(cv_cmd_end_render_pass(&l, CV_QUEUE_GRAPHICS, &(cv_end_render_pass_args){ 0 }));
    CHECK_OK(cv_command_list_end(&l));
    CHECK(l.ended_ok);
    CHECK_EQ_INT(l.count, 6);
    cv_command_list_finish(&l);
}

static void test_sticky_error(void) {
    cv_command_list l;
    cv_command_list_init(&l);
    fresh(&l);
    CHECK_OK(cv_cmd_barrier(&l, CV_QUEUE_COPY, &(cv_barrier_args){ { 0 } }));
    CHECK_OK(cv_cmd_timestamp(&l, CV_QUEUE_COPY, &(cv_timestamp_args){ .label = "t0" }));
    check_failed(&l, cv_cmd_draw(&l, CV_QUEUE_COMPUTE, &(cv_draw_args){ .pipeline = PIPE }), CV_ERROR_QUEUE_MISMATCH,
                 2, "draw is not allowed on the compute queue");
    uint32_t data_size = l.data_size, mask = l.queue_mask;
    /* Valid calls now return the first error and record nothing. */
    CHECK_RESULT(cv_cmd_timestamp(&l, CV_QUEUE_COPY, &(cv_timestamp_args){ .label = "later" }),
                 CV_ERROR_QUEUE_MISMATCH);
    CHECK_RESULT(cv_cmd_copy_buffer(&l, CV_QUEUE_COMPUTE, &(cv_copy_buffer_args){ .src = BUF, .dst = { TEX.id } }),
                 CV_ERROR_QUEUE_MISMATCH);
    CHECK_EQ_INT(l.count, 2);
    CHECK_EQ_INT(l.data_size, data_size);
    CHECK_EQ_INT(l.queue_mask, mask);
    CHECK(strncmp(cv_command_list_error(&l), "command 2: draw", 15) == 0);
    CHECK_RESULT(cv_command_list_end(&l), CV_ERROR_QUEUE_MISMATCH);
    CHECK(strncmp(cv_last_error(), "command 2: draw", 15) == 0);
    CHECK(!l.ended_ok);
    uint8_t *bytes = NULL;
    size_t size = 0;
    CHECK_RESULT(cv_command_list_encode(&l, &bytes, &size), CV_ERROR_BAD_STATE);
    /* A new begin clears the error. */
    cv_command_list_begin(&l);
    CHECK_OK(cv_cmd_barrier(&l, CV_QUEUE_COPY, &(cv_barrier_args){ { 0 } }));
    CHECK_OK(cv_command_list_end(&l));
    CHECK_EQ_INT(l.count, 1);
    CHECK(cv_command_list_error(&l)[0] == '\0');

    /* Recording into a list that is not recording is itself an error. */
    CHECK_RESULT(cv_cmd_barrier(&l, CV_QUEUE_COPY, &(cv_barrier_args){ { 0 } }), CV_ERROR_BAD_STATE);
    CHECK_EQ_INT(l.count, 1);
    cv_command_list_finish(&l);
}

static void test_queue_mask(void) {
    cv_command_list l;
    cv_command_list_init(&l);
    fresh(&l);
    CHECK_EQ_INT(l.queue_mask, 0);
    CHECK_OK(cv_cmd_copy_buffer(&l, CV_QUEUE_COPY, &(cv_copy_buffer_args){ .src = BUF, .dst = BUF, .size = 4 }));
    CHECK_EQ_INT(l.queue_mask, CV_QUEUE_BIT_COPY);
    CHECK_OK(cv_cmd_copy_buffer(&l, CV_QUEUE_COPY, &(cv_copy_buffer_args){ .src = BUF, .dst = BUF, .size = 4 }));
    CHECK_EQ_INT(l.queue_mask, CV_QUEUE_BIT_COPY);
    CHECK_OK(cv_cmd_dispatch(&l, CV_QUEUE_COMPUTE, &(cv_dispatch_args){ .pipeline = PIPE, .groups_x = 1 }));
    CHECK_EQ_INT(l.queue_mask, CV_QUEUE_BIT_COPY | CV_QUEUE_BIT_COMPUTE);
    CHECK_OK(begin_pass(&l));
    CHECK_OK(cv_cmd_end_render_pass(&l, CV_QUEUE_GRAPHICS, &(cv_end_render_pass_args){ 0 }));
    CHECK_EQ_INT(l.queue_mask, CV_QUEUE_BIT_ALL);
    CHECK_OK(cv_command_list_end(&l));
    cv_command_list_begin(&l);
    CHECK_EQ_INT(l.queue_mask, 0);
    cv_command_list_finish(&l);
}

/* ---- Parallel recording ---- */

#define THREADS 8
#define BLOCKS 1500

typedef struct job {
    uint64_t seed;
    cv_command_list list;
    cv_result recorded, encoded;
    uint8_t *bytes;
    size_t size;
} job;

static void run_job(job *j) {
    cv_command_list_init(&j->list);
    j->recorded = random_list_record(&j->list, j->seed, BLOCKS);
    j->encoded = cv_command_list_encode(&j->list, &j->bytes, &j->size);
}

static void *job_thread(void *arg) {
    run_job(arg);
    return NULL;
}

static void test_parallel_recording(void) {
    static job parallel[THREADS], serial[THREADS];
    pthread_t threads[THREADS];
    for (int i = 0; i < THREADS; i++) {
        parallel[i].seed = serial[i].seed = 0xC0FFEEull + (uint64_t)i;
        CHECK_EQ_INT(pthread_create(&threads[i], NULL, job_thread, &parallel[i]), 0);
    }
    for (int i = 0; i < THREADS; i++)
        CHECK_EQ_INT(pthread_join(threads[i], NULL), 0);
    for (int i = 0; i < THREADS; i++)
        run_job(&serial[i]);
    for (int i = 0; i < THREADS; i++) {
        CHECK_OK(parallel[i].recorded);
        CHECK_OK(parallel[i].encoded);
        CHECK(parallel[i].list.count >= 3000);
        CHECK(lists_equal(&serial[i].list, &parallel[i].list, "parallel vs serial"));
        CHECK(parallel[i].size == serial[i].size && memcmp(parallel[i].bytes, serial[i].bytes, serial[i].size) == 0);
        /* Different seeds really are different lists. */
        if (i > 0)
            CHECK(parallel[i].size != parallel[i - 1].size ||
                  memcmp(parallel[i].bytes, parallel[i - 1].bytes, parallel[i].size) != 0);
    }
    for (int i = 0; i < THREADS; i++) {
        free(parallel[i].bytes);
        free(serial[i].bytes);
        cv_command_list_finish(&parallel[i].list);
        cv_command_list_finish(&serial[i].list);
    }
}

int main(void) {
    test_queue_mismatch();
    test_wrong_handle_type();
    test_size_limits();
    test_structure();
    test_sticky_error();
    test_queue_mask();
    test_parallel_recording();
    return check_report("codec_record");
}
