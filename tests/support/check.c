/* Counters, the end-of-test live-object check and the summary line for
 * tests/support/check.h. */
#include "check.h"

#include <pthread.h>

#include "corvid/graph.h"

int check_failures = 0;
int check_count = 0;

typedef struct live_counter {
    const char *what;
    uint32_t (*count)(void);
} live_counter;

/* What every test may make through corvid_client, which every test links. */
static const live_counter client_counters[] = {
    { "contexts", cv_live_contexts },
    { "devices", cv_live_devices },
    { "graphs", cv_live_graphs },
};

/* The Vulkan backend's memory blocks (server/vulkan/vk_memory.c), which every device frees by its end. A weak
 * reference: it is set in the tests that use Vulkan memory (they link vk_memory.c), NULL in the others. */
extern uint32_t cv_vulkan_live_memory_blocks(void) __attribute__((weak));

/* Support code may start nodes or devices from a test's threads. */
static pthread_mutex_t live_lock = PTHREAD_MUTEX_INITIALIZER;
static live_counter live_counters[8];
static int live_counter_count;

void check_live_counter(const char *what, uint32_t (*count)(void)) {
    pthread_mutex_lock(&live_lock);
    bool known = false;
    for (int i = 0; i < live_counter_count; i++)
        known |= live_counters[i].count == count;
    if (!known && live_counter_count < (int)(sizeof(live_counters) / sizeof(live_counters[0]))) {
        live_counters[live_counter_count++] = (live_counter){ what, count };
    } else if (!known) {
        check_failures++; /* a counter not checked would pass a leak */
        fprintf(stderr, "check_live_counter: no room for '%s'\n", what);
    }
    pthread_mutex_unlock(&live_lock);
}

static void check_none_live(const char *name, const live_counter *c) {
    uint32_t live = c->count();
    check_count++;
    if (live != 0) {
        check_failures++;
        fprintf(stderr, "%s: %u %s still live at the end (destroy what the test made)\n", name, live, c->what);
    }
}

int check_report(const char *name) {
    /* The client's objects first: registered counters (memory blocks of devices, say) come down after them. */
    for (size_t i = 0; i < sizeof(client_counters) / sizeof(client_counters[0]); i++)
        check_none_live(name, &client_counters[i]);
    if (cv_vulkan_live_memory_blocks) /* after the devices */
        check_none_live(name, &(live_counter){ "Vulkan memory blocks", cv_vulkan_live_memory_blocks });
    pthread_mutex_lock(&live_lock);
    for (int i = 0; i < live_counter_count; i++)
        check_none_live(name, &live_counters[i]);
    pthread_mutex_unlock(&live_lock);
    printf("%s: %d passed, %d failed\n", name, check_count - check_failures, check_failures);
    return check_failures == 0 ? 0 : 1;
}
