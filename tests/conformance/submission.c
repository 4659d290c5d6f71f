/* Compile once, submit many times; re-recording; in-flight lifetimes; timings. */
#include <string.h>

#include "check.h"
#include "conformance.h"

void conformance_resubmit(world *w) {
    cv_command_list *l = world_begin(w);
    cv_cmd_copy_buffer(l, CV_QUEUE_COPY,
                       &(cv_copy_buffer_args){
                           .src = w->big, .src_offset = 0, .dst = w->big, .dst_offset = 512, .size = 16 });
    CHECK_OK(cv_command_list_end(l));
    CHECK(!cv_device_has(w->dev, cv_any(w->list)));
    CHECK_OK(cv_device_compile(w->dev, w->list));
    CHECK(cv_device_has(w->dev, cv_any(w->list)));
    uint32_t loaded = cv_device_loaded_count(w->dev);

    /* Each submission of the same compiled list copies the source as it is then. */
    for (uint32_t round = 1; round <= 3; round++) {
        uint32_t src[4] = { round, round * 10, round * 100, round * 1000 }, dst[4] = { 0 };
        CHECK_OK(cv_device_write_buffer(w->dev, w->big, 0, sizeof(src), src));
        uint64_t t1 = 0, t2 = 0;
        CHECK_OK(cv_device_submit(w->dev, w->list, &t1));
        CHECK_OK(cv_device_wait(w->dev, t1, UINT64_MAX));
        CHECK_OK(cv_device_read_buffer(w->dev, w->big, 512, sizeof(dst), dst));
        CHECK(memcmp(src, dst, sizeof(src)) == 0);
        CHECK_OK(cv_device_submit(w->dev, w->list, &t2));
        CHECK(t2 == t1 + 1); /* tickets count submissions */
        CHECK_OK(cv_device_wait_idle(w->dev));
    }
    CHECK_EQ_INT(cv_device_loaded_count(w->dev), loaded); /* no recompiles piled up */
    CHECK_RESULT(cv_device_wait(w->dev, 1u << 30, 0), CV_ERROR_INVALID_ARGUMENT);

    /* Re-recording the list changes what it does on its next submission. */
    l = world_begin(w);
    CHECK_RESULT(cv_device_submit(w->dev, w->list, NULL), CV_ERROR_BAD_STATE); /* still recording */
    cv_cmd_clear_buffer(l, CV_QUEUE_COPY,
                        &(cv_clear_buffer_args){ .buffer = w->big, .offset = 512, .size = 16, .value = 7 });
    CHECK_OK(world_end_and_run(w));
    uint32_t dst[4];
    CHECK_OK(cv_device_read_buffer(w->dev, w->big, 512, sizeof(dst), dst));
    CHECK(dst[0] == 7 && dst[3] == 7);

    /* Unloading a resource the compiled list uses makes the next submit fail
     * cleanly instead of touching a dead object; reloading makes it work again. */
    CHECK_OK(cv_device_unload(w->dev, cv_any(w->big)));
    CHECK_RESULT(cv_device_submit(w->dev, w->list, NULL), CV_ERROR_NOT_LOADED);
    CHECK_OK(cv_device_load(w->dev, cv_any(w->big)));
    uint64_t t = 0;
    CHECK_OK(cv_device_submit(w->dev, w->list, &t));
    CHECK_OK(cv_device_wait(w->dev, t, UINT64_MAX));
    CHECK_OK(cv_device_read_buffer(w->dev, w->big, 512, sizeof(dst), dst));
    CHECK(dst[0] == 7);
}

void conformance_lifetimes(world *w) {
    /* Destroy resources and the list right after submitting work that uses
     * them: the device must keep them until the work is done, then free them. */
    uint32_t before = cv_device_loaded_count(w->dev);
    cv_buffer a, b;
    CHECK_OK(cv_buffer_create(w->ctx, &(cv_buffer_desc){ .size = 1 << 20, .label = "a" }, &a));
    CHECK_OK(cv_buffer_create(w->ctx, &(cv_buffer_desc){ .size = 1 << 20, .label = "b" }, &b));
    CHECK_OK(cv_device_load(w->dev, cv_any(a)));
    CHECK_OK(cv_device_load(w->dev, cv_any(b)));
    cv_cmdlist list;
    cv_command_list *l;
    CHECK_OK(cv_cmdlist_create(w->ctx, &list));
    CHECK_OK(cv_cmdlist_begin(w->ctx, list, &l));
    cv_cmd_clear_buffer(l, CV_QUEUE_COMPUTE, &(cv_clear_buffer_args){ .buffer = a, .size = 1 << 20, .value = 3 });
    cv_cmd_copy_buffer(l, CV_QUEUE_COPY, &(cv_copy_buffer_args){ .src = a, .dst = b, .size = 1 << 20 });
    CHECK_OK(cv_command_list_end(l));
    uint64_t t;
    CHECK_OK(cv_device_submit(w->dev, list, &t));
    CHECK_OK(cv_buffer_destroy(w->ctx, a));
    CHECK_OK(cv_cmdlist_destroy(w->ctx, list));
    uint32_t word = 0;
    CHECK_OK(cv_device_read_buffer(w->dev, b, (1 << 20) - 4, 4, &word)); /* waits for the copy */
    CHECK_EQ_INT(word, 3);
    CHECK_OK(cv_device_wait(w->dev, t, UINT64_MAX));
    CHECK_OK(cv_buffer_destroy(w->ctx, b));
    CHECK_EQ_INT(cv_device_loaded_count(w->dev), before);
    CHECK(!cv_device_has(w->dev, cv_any(list)));
    CHECK_RESULT(cv_device_submit(w->dev, list, NULL), CV_ERROR_STALE_HANDLE);

    /* Churn: many create/load/destroy cycles leave nothing behind. */
    uint32_t live = cv_context_live_count(w->ctx, CV_HANDLE_BUFFER);
    for (int i = 0; i < 2000; i++) {
        cv_buffer x;
        CHECK_OK(cv_buffer_create(w->ctx, &(cv_buffer_desc){ .size = 256 + (uint64_t)(i % 7) * 256 }, &x));
        CHECK_OK(cv_device_load(w->dev, cv_any(x)));
        CHECK_OK(cv_buffer_destroy(w->ctx, x));
    }
    CHECK_EQ_INT(cv_context_live_count(w->ctx, CV_HANDLE_BUFFER), live);
    CHECK_EQ_INT(cv_device_loaded_count(w->dev), before);
}

void conformance_timings(world *w) {
    cv_command_list *l = world_begin(w);
    cv_cmd_begin_marker(l, CV_QUEUE_COMPUTE, &(cv_begin_marker_args){ .label = "outer" });
    cv_cmd_clear_buffer(l, CV_QUEUE_COMPUTE, &(cv_clear_buffer_args){ .buffer = w->big, .size = 65536, .value = 1 });
    cv_cmd_begin_marker(l, CV_QUEUE_COMPUTE, &(cv_begin_marker_args){ .label = "inner" });
    cv_cmd_copy_buffer(l, CV_QUEUE_COMPUTE,
                       &(cv_copy_buffer_args){ .src = w->big, .dst = w->big, .dst_offset = 32768, .size = 32768 });
    cv_cmd_end_marker(l, CV_QUEUE_COMPUTE, &(cv_end_marker_args){ 0 });
    cv_cmd_timestamp(l, CV_QUEUE_COMPUTE, &(cv_timestamp_args){ .label = "point" });
    cv_cmd_end_marker(l, CV_QUEUE_COMPUTE, &(cv_end_marker_args){ 0 });
    CHECK_OK(cv_command_list_end(l));
    uint64_t t;
    CHECK_OK(cv_device_submit(w->dev, w->list, &t));
    CHECK_OK(cv_device_wait(w->dev, t, UINT64_MAX));
    cv_pass_timing timings[8];
    uint32_t n = 0;
    CHECK_OK(cv_device_timings(w->dev, t, timings, 8, &n));
    CHECK_EQ_INT(n, 3);
    if (n == 3) {
        CHECK(strcmp(timings[0].label, "outer") == 0);
        CHECK(strcmp(timings[1].label, "inner") == 0);
        CHECK(strcmp(timings[2].label, "point") == 0);
        CHECK(timings[0].duration_ms >= 0 && timings[1].duration_ms >= 0);
        CHECK(timings[1].start_ms >= timings[0].start_ms);
        CHECK(timings[2].start_ms >= timings[1].start_ms);
        CHECK(timings[2].duration_ms == 0);
        /* nesting: inner lies within outer */
        CHECK(timings[1].start_ms + timings[1].duration_ms <= timings[0].start_ms + timings[0].duration_ms + 1e-3);
    }
    CHECK_RESULT(cv_device_timings(w->dev, t + 100, timings, 8, &n), CV_ERROR_NOT_FOUND);
}
