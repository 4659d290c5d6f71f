/* dispatch_indirect: the group counts are read when the list runs. Counts past
 * the device's max_dispatch dispatch nothing (they used to run for hours and
 * wedge the device), the wait covering the submission says which command, once,
 * and the device goes on. */
#include <string.h>

#include "check.h"
#include "conformance.h"

#define OUT_OFFSET 4096u
#define OUT_WORDS 128u
#define WAIT_NS (30ull * 1000 * 1000 * 1000) /* a runaway dispatch fails the test instead of hanging it */

/* Clears the output words, then fills them (test.fill_u32: value + i) with the
 * counts at args_offset of w->big; submits. */
static cv_result run_fill(world *w, uint64_t args_offset, uint32_t value, uint64_t *ticket) {
    cv_command_list *l = world_begin(w);
    cv_cmd_clear_buffer(l, CV_QUEUE_COMPUTE,
                        &(cv_clear_buffer_args){ .buffer = w->big, .offset = OUT_OFFSET, .size = OUT_WORDS * 4 });
    cv_binding b = { .resource = cv_any(w->big), .offset = OUT_OFFSET, .range = OUT_WORDS * 4 };
    const uint32_t push[2] = { value, OUT_WORDS };
    cv_cmd_dispatch_indirect(l, CV_QUEUE_COMPUTE,
                             &(cv_dispatch_indirect_args){ .pipeline = w->fill,
                                                           .bindings = &b,
                                                           .bindings_count = 1,
                                                           .push = push,
                                                           .push_size = sizeof(push),
                                                           .args = w->big,
                                                           .args_offset = args_offset });
    cv_result r = cv_command_list_end(l);
    return r == CV_OK ? cv_device_submit(w->dev, w->list, ticket) : r;
}

/* The output words hold value + i (a device that runs shaders) or zeros. */
static void check_output(world *w, bool filled, uint32_t value) {
    uint32_t words[OUT_WORDS];
    CHECK_OK(cv_device_read_buffer(w->dev, w->big, OUT_OFFSET, sizeof(words), words));
    uint32_t wrong = 0;
    for (uint32_t i = 0; i < OUT_WORDS; i++)
        wrong += words[i] != (filled && w->fx->executes_shaders ? value + i : 0u);
    CHECK_EQ_INT(wrong, 0);
}

static void refused(world *w, uint64_t args_offset, const char *counts_text) {
    uint64_t t = 0;
    CHECK_OK(run_fill(w, args_offset, 7, &t));
    CHECK_RESULT(cv_device_wait(w->dev, t, WAIT_NS), CV_ERROR_OUT_OF_RANGE);
    const char *why = cv_last_error();
    CHECK(strstr(why, "command 1 (dispatch_indirect)") != NULL);
    CHECK(strstr(why, counts_text) != NULL);
    CHECK(strstr(why, "the dispatch was skipped") != NULL);
    CHECK_OK(cv_device_wait(w->dev, t, WAIT_NS)); /* reported once */
    check_output(w, false, 0);                    /* the clear before it ran, the dispatch did not */
}

void conformance_indirect(world *w) {
    const cv_device_info *info = cv_device_get_info(w->dev);
    const uint32_t good[3] = { 2, 1, 1 }, runaway[3] = { UINT32_MAX, UINT32_MAX, UINT32_MAX },
                   past_z[3] = { 1, 1, info->max_dispatch[2] + 1 }, none[3] = { 0, 1, 1 };
    CHECK_OK(cv_device_write_buffer(w->dev, w->big, 0, sizeof(good), good));
    CHECK_OK(cv_device_write_buffer(w->dev, w->big, 16, sizeof(runaway), runaway));
    CHECK_OK(cv_device_write_buffer(w->dev, w->big, 32, sizeof(past_z), past_z));
    CHECK_OK(cv_device_write_buffer(w->dev, w->big, 48, sizeof(none), none));

    uint64_t t = 0;
    CHECK_OK(run_fill(w, 0, 100, &t));
    CHECK_OK(cv_device_wait(w->dev, t, WAIT_NS));
    check_output(w, true, 100);

    refused(w, 16, "group counts (4294967295, 4294967295, 4294967295)");
    char text[96];
    snprintf(text, sizeof(text), "group counts (1, 1, %u)", info->max_dispatch[2] + 1);
    refused(w, 32, text);

    CHECK_OK(run_fill(w, 48, 5, &t)); /* zero groups: legal, dispatches nothing */
    CHECK_OK(cv_device_wait(w->dev, t, WAIT_NS));
    check_output(w, false, 0);

    CHECK_OK(run_fill(w, 0, 200, &t)); /* the device goes on */
    CHECK_OK(cv_device_wait(w->dev, t, WAIT_NS));
    check_output(w, true, 200);
}
