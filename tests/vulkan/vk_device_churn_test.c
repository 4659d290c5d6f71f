/* Validated devices created and destroyed on one thread while other threads
 * work on devices of their own, as node sessions start and end while others
 * render (node_remote_render): two workers record lists with markers (debug
 * labels) and free them, three poll their device's ticket. The validation
 * layer (1.3.239) keeps its per-device state in one map for the whole
 * process, which it changes in vkCreateDevice and vkDestroyDevice without a
 * lock (vk_instance.h, vk_layer_enter). Before the backend kept those two calls
 * apart from every other call on the validated instance, this test failed in 3
 * runs of 4 (two SIGSEGV inside the layer; one run where the layer, its state
 * mixed up, reported a semaphore "not created from the correct device"); since,
 * 0 of 13. The layer's other race, an unlocked erase of a freed buffer's labels
 * (vk_device_free_command_buffers), it does not reproduce (0 of 4 runs failed
 * with only that part of the fix taken out). It also shows that threads calling
 * the backend in a tight loop do not keep devices from being created. */
#include <pthread.h>
#include <stdatomic.h>

#include "corvid/backend.h"
#include "vk_test.h"

#define WORKERS 2
#define POLLERS 3

static atomic_bool stop;

typedef struct worker {
    cv_context *ctx;
    cv_device *dev;
    cv_buffer buffer;
    uint32_t compiles;
    cv_result result;
} worker;

/* Records the list again (a new version) and compiles it: the previous compiled
 * form, never submitted, is freed at once (vkFreeCommandBuffers). */
static void *compile_loop(void *arg) {
    worker *w = arg;
    cv_cmdlist list;
    w->result = cv_cmdlist_create(w->ctx, &list);
    while (w->result == CV_OK && !atomic_load(&stop)) {
        cv_command_list *l;
        w->result = cv_cmdlist_begin(w->ctx, list, &l);
        if (w->result != CV_OK)
            break;
        cv_cmd_begin_marker(l, CV_QUEUE_COMPUTE, &(cv_begin_marker_args){ .label = "churn" });
        cv_cmd_clear_buffer(l, CV_QUEUE_COMPUTE,
                            &(cv_clear_buffer_args){ .buffer = w->buffer, .size = 256, .value = w->compiles });
        cv_cmd_end_marker(l, CV_QUEUE_COMPUTE, &(cv_end_marker_args){ 0 });
        w->result = cv_command_list_end(l);
        if (w->result == CV_OK)
            w->result = cv_device_compile(w->dev, list);
        w->compiles++;
    }
    return NULL;
}

typedef struct poller {
    cv_device *dev;
    uint64_t polls;
} poller;

/* The backend's completed() (one vkGetSemaphoreCounterValue) as fast as it goes. */
static void *poll_loop(void *arg) {
    poller *p = arg;
    const cv_backend *backend = cv_vulkan_backend();
    cv_backend_device *bd = cv_device_backend_data(p->dev);
    while (!atomic_load(&stop)) {
        backend->completed(bd);
        p->polls++;
    }
    return NULL;
}

int main(void) {
    const uint32_t cycles = CV_TEST_REPEATS(80, 20);
    cv_context *ctx, *churn_ctx;
    cv_device *filler = NULL;
    worker workers[WORKERS] = { 0 };
    poller pollers[POLLERS] = { 0 };
    CHECK_OK(cv_context_create(NULL, &ctx));
    CHECK_OK(cv_context_create(NULL, &churn_ctx));
    /* The layer keeps two entries inline (the instance's and the first device's) and the rest in a hash
     * map: the filler puts the workers' and the churned devices' state in the map. */
    CHECK_OK(vkt_device(ctx, NULL, "filler", &filler));
    for (int i = 0; i < WORKERS; i++)
        CHECK_OK(vkt_device(ctx, NULL, "worker", &workers[i].dev));
    for (int i = 0; i < POLLERS; i++)
        CHECK_OK(vkt_device(ctx, NULL, "poller", &pollers[i].dev));
    if (!filler || !workers[WORKERS - 1].dev || !pollers[POLLERS - 1].dev)
        return vkt_report("vk_device_churn");
    pthread_t threads[WORKERS + POLLERS];
    for (int i = 0; i < WORKERS; i++) {
        workers[i].ctx = ctx;
        workers[i].buffer = vkt_buffer(ctx, workers[i].dev, 256, 0, "cleared");
        CHECK_EQ_INT(pthread_create(&threads[i], NULL, compile_loop, &workers[i]), 0);
    }
    for (int i = 0; i < POLLERS; i++)
        CHECK_EQ_INT(pthread_create(&threads[WORKERS + i], NULL, poll_loop, &pollers[i]), 0);
    for (uint32_t i = 0; i < cycles; i++) {
        cv_device *dev = NULL;
        CHECK_OK(vkt_device(churn_ctx, NULL, "churned", &dev));
        cv_device_destroy(dev);
    }
    atomic_store(&stop, true);
    uint64_t compiles = 0, polls = 0;
    for (int i = 0; i < WORKERS + POLLERS; i++)
        pthread_join(threads[i], NULL);
    for (int i = 0; i < WORKERS; i++) {
        CHECK_OK(workers[i].result);
        CHECK(workers[i].compiles > 0);
        compiles += workers[i].compiles;
    }
    for (int i = 0; i < POLLERS; i++) {
        CHECK(pollers[i].polls > 0);
        polls += pollers[i].polls;
    }
    printf("%u devices created and destroyed meanwhile: %llu lists compiled, %llu polls\n", cycles,
           (unsigned long long)compiles, (unsigned long long)polls);
    cv_context_destroy(churn_ctx);
    cv_context_destroy(ctx);
    CHECK_NOTHING_LIVE();
    return vkt_report("vk_device_churn");
}
