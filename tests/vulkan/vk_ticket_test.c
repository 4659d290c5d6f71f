/* Tickets and the timeline semaphore behind them: one list (y = 2x + y)
 * submitted many times back to back without waiting must run in order, each
 * submission seeing the previous one's writes (y ends at y0 + 2kx exactly);
 * tickets increase by one; waiting for any finished ticket returns at once;
 * completed() never goes backwards; a waiter thread blocked on the last ticket
 * is released while the main thread keeps submitting; host writes between
 * submissions are seen by the next submission. */
#include <pthread.h>
#include <string.h>

#include "corvid/backend.h"
#include "vk_test.h"

enum { N = 1024, REPEAT = 12 };

typedef struct waiter {
    cv_device *dev;
    uint64_t ticket;
    cv_result result;
} waiter;

static void *wait_for(void *arg) {
    waiter *w = arg;
    w->result = cv_device_wait(w->dev, w->ticket, UINT64_MAX);
    return NULL;
}

int main(void) {
    cv_context *ctx;
    cv_device *dev = NULL;
    CHECK_OK(cv_context_create(NULL, &ctx));
    CHECK_OK(vkt_device(ctx, NULL, "tickets", &dev));
    if (!dev) {
        cv_context_destroy(ctx); /* with any device it made */
        return check_report("vk_ticket");
    }
    cv_pipeline saxpy = vkt_pipeline(ctx, dev, "test.saxpy");
    cv_buffer x = vkt_buffer(ctx, dev, 4 * N, 0, "x"), y = vkt_buffer(ctx, dev, 4 * N, 0, "y");
    float hx[N], hy[N], out[N];
    for (int i = 0; i < N; i++) {
        hx[i] = (float)(i % 100);
        hy[i] = (float)i;
    }
    CHECK_OK(cv_device_write_buffer(dev, x, 0, sizeof(hx), hx));
    CHECK_OK(cv_device_write_buffer(dev, y, 0, sizeof(hy), hy));

    cv_cmdlist list;
    cv_command_list *l;
    CHECK_OK(cv_cmdlist_create(ctx, &list));
    CHECK_OK(cv_cmdlist_begin(ctx, list, &l));
    struct {
        float a;
        uint32_t count;
    } push = { 2.0f, N };
    cv_binding b[2] = { { .resource = cv_any(x) }, { .resource = cv_any(y) } };
    cv_cmd_dispatch(l, CV_QUEUE_COMPUTE,
                    &(cv_dispatch_args){ .pipeline = saxpy,
                                         .bindings = b,
                                         .bindings_count = 2,
                                         .push = &push,
                                         .push_size = 8,
                                         .groups_x = N / 64,
                                         .groups_y = 1,
                                         .groups_z = 1 });
    CHECK_OK(cv_command_list_end(l));

    uint64_t tickets[REPEAT];
    for (int k = 0; k < REPEAT; k++) {
        CHECK_OK(cv_device_submit(dev, list, &tickets[k]));
        if (k > 0)
            CHECK_EQ_INT(tickets[k], tickets[k - 1] + 1);
    }
    waiter w = { .dev = dev, .ticket = tickets[REPEAT - 1], .result = CV_ERROR_BAD_STATE };
    pthread_t thread;
    pthread_create(&thread, NULL, wait_for, &w);
    /* The backend's completed() climbs to the last ticket and never goes back. */
    const cv_backend *backend = cv_vulkan_backend();
    cv_backend_device *bd = cv_device_backend_data(dev);
    uint64_t seen = 0, polls = 0;
    bool monotonic = true;
    while (seen < tickets[REPEAT - 1]) {
        uint64_t now = backend->completed(bd);
        monotonic &= now >= seen && now <= tickets[REPEAT - 1];
        seen = now;
        polls++;
    }
    CHECK(monotonic);
    CHECK(polls > 0);
    CHECK_OK(cv_device_wait(dev, tickets[REPEAT / 2], UINT64_MAX));
    pthread_join(thread, NULL);
    CHECK_OK(w.result);
    CHECK_OK(cv_device_read_buffer(dev, y, 0, sizeof(out), out));
    int wrong = 0;
    for (int i = 0; i < N; i++)
        wrong += out[i] != hy[i] + 2.0f * REPEAT * hx[i];
    CHECK_EQ_INT(wrong, 0);
    /* Finished tickets: immediate, in any order, with any timeout. */
    CHECK_OK(cv_device_wait(dev, tickets[0], 0));
    CHECK_OK(cv_device_wait(dev, tickets[REPEAT - 1], 0));
    CHECK_OK(cv_device_wait(dev, tickets[3], 1));
    CHECK_RESULT(cv_device_wait(dev, tickets[REPEAT - 1] + 1, 0), CV_ERROR_INVALID_ARGUMENT);

    /* A host write between two submissions is what the second one sees. */
    for (int i = 0; i < N; i++)
        hy[i] = -1.0f * (float)i;
    CHECK_OK(cv_device_write_buffer(dev, y, 0, sizeof(hy), hy));
    uint64_t t1, t2;
    CHECK_OK(cv_device_submit(dev, list, &t1));
    CHECK_OK(cv_device_submit(dev, list, &t2));
    CHECK_EQ_INT(t2, t1 + 1);
    CHECK_EQ_INT(t1, tickets[REPEAT - 1] + 1);
    CHECK_OK(cv_device_wait_idle(dev));
    CHECK_OK(cv_device_read_buffer(dev, y, 0, sizeof(out), out));
    wrong = 0;
    for (int i = 0; i < N; i++)
        wrong += out[i] != hy[i] + 4.0f * hx[i];
    CHECK_EQ_INT(wrong, 0);
    CHECK_OK(cv_device_wait(dev, t2, 0));

    cv_context_destroy(ctx);
    return vkt_report("vk_ticket");
}
