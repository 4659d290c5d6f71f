/* Handles are tied to their context: a handle of context A used on context B
 * (or on one of B's devices, or inside a list validated on B's device) is
 * rejected with CV_ERROR_FOREIGN_HANDLE and changes nothing of B's. A node holds
 * one context per client session, so this is what keeps sessions apart. */
#include <string.h>

#include "check.h"
#include "corvid/context.h"
#include "corvid/backend.h"
#include "corvid/device.h"

typedef struct session {
    cv_context *ctx;
    cv_device *dev;
    cv_buffer buf; /* 64 bytes, loaded, filled with `fill` */
    cv_cmdlist list;
} session;

static void session_init(session *s, uint8_t fill) {
    memset(s, 0, sizeof(*s));
    CHECK_OK(cv_context_create(NULL, &s->ctx));
    CHECK_OK(cv_device_create(s->ctx, cv_mock_backend(), NULL, &s->dev));
    CHECK_OK(cv_buffer_create(s->ctx, &(cv_buffer_desc){ .size = 64, .label = "session" }, &s->buf));
    CHECK_OK(cv_device_load(s->dev, cv_any(s->buf)));
    uint8_t bytes[64];
    memset(bytes, fill, sizeof(bytes));
    CHECK_OK(cv_device_write_buffer(s->dev, s->buf, 0, sizeof(bytes), bytes));
    CHECK_OK(cv_cmdlist_create(s->ctx, &s->list));
}

/* B's buffer still holds its own bytes. */
static bool holds(session *s, uint8_t fill) {
    uint8_t bytes[64], want[64];
    memset(want, fill, sizeof(want));
    return cv_device_read_buffer(s->dev, s->buf, 0, sizeof(bytes), bytes) == CV_OK &&
           memcmp(bytes, want, sizeof(want)) == 0;
}

static void expect_foreign(cv_result r) {
    CHECK_RESULT(r, CV_ERROR_FOREIGN_HANDLE);
    CHECK(strstr(cv_last_error(), "belongs to another context") != NULL);
}

static void test_foreign_handles_are_rejected(void) {
    session a, b;
    session_init(&a, 0xAA);
    session_init(&b, 0xBB);
    CHECK(a.buf.id != b.buf.id); /* same slot, same generation, different context */

    cv_resource_desc d;
    expect_foreign(cv_context_check(b.ctx, cv_any(a.buf)));
    expect_foreign(cv_context_describe(b.ctx, cv_any(a.buf), &d));
    expect_foreign(cv_buffer_destroy(b.ctx, a.buf));
    CHECK_OK(cv_context_check(b.ctx, cv_any(b.buf)));
    CHECK_EQ_INT(cv_context_live_count(b.ctx, CV_HANDLE_BUFFER), 1);

    const uint8_t evil[64] = { 0x66 };
    uint8_t out[64];
    expect_foreign(cv_device_write_buffer(b.dev, a.buf, 0, sizeof(evil), evil));
    expect_foreign(cv_device_read_buffer(b.dev, a.buf, 0, sizeof(out), out));
    expect_foreign(cv_device_load(b.dev, cv_any(a.buf)));
    expect_foreign(cv_device_unload(b.dev, cv_any(a.buf)));
    CHECK(!cv_device_has(b.dev, cv_any(a.buf)));
    CHECK(cv_device_lookup(b.dev, a.buf.id) == NULL);

    /* A list of B's that names A's buffer fails validation on B's device. */
    cv_command_list *l = NULL;
    CHECK_OK(cv_cmdlist_begin(b.ctx, b.list, &l));
    cv_cmd_update_buffer(l, CV_QUEUE_COPY, &(cv_update_buffer_args){ .buffer = b.buf, .data = evil, .data_size = 4 });
    cv_cmd_copy_buffer(l, CV_QUEUE_COPY, &(cv_copy_buffer_args){ .src = a.buf, .dst = b.buf, .size = 64 });
    CHECK_OK(cv_command_list_end(l));
    uint64_t ticket = 0;
    expect_foreign(cv_device_submit(b.dev, b.list, &ticket));
    CHECK(strstr(cv_last_error(), "command 1") != NULL);
    CHECK_EQ_INT(ticket, 0);

    /* A's own list handle is no list of B's. */
    expect_foreign(cv_device_submit(b.dev, a.list, &ticket));
    expect_foreign(cv_cmdlist_begin(b.ctx, a.list, &l));
    expect_foreign(cv_cmdlist_get(b.ctx, a.list, &l));

    CHECK(holds(&b, 0xBB));
    CHECK(holds(&a, 0xAA));
    CHECK_OK(cv_context_check(a.ctx, cv_any(a.buf)));
    cv_context_destroy(a.ctx);
    cv_context_destroy(b.ctx);
    CHECK_NOTHING_LIVE();
}

/* Contexts alive at the same time never share a tag. */
static void test_live_contexts_have_distinct_tags(void) {
    enum { N = 40 };
    cv_context *ctx[N];
    uint64_t ids[N];
    for (int i = 0; i < N; i++) {
        CHECK_OK(cv_context_create(&(cv_context_desc){ .max_buffers = 1 }, &ctx[i]));
        cv_buffer b = { 0 };
        CHECK_OK(cv_buffer_create(ctx[i], &(cv_buffer_desc){ .size = 4 }, &b));
        ids[i] = b.id;
        for (int j = 0; j < i; j++)
            CHECK(ids[j] != ids[i]);
    }
    for (int i = 0; i < N; i++)
        for (int j = 0; j < N; j++)
            CHECK_RESULT(cv_context_check(ctx[i], (cv_handle){ ids[j] }), i == j ? CV_OK : CV_ERROR_FOREIGN_HANDLE);
    for (int i = 0; i < N; i++)
        cv_context_destroy(ctx[i]);
    CHECK_NOTHING_LIVE();
}

int main(void) {
    test_foreign_handles_are_rejected();
    test_live_contexts_have_distinct_tags();
    CHECK_NOTHING_LIVE();
    return check_report("isolation");
}
