/* corvid-node's memory (docs/node.md, "Memory"):
 *  - bursts: a corvid-node process (lavapipe) takes 256 Hello-only sessions, 32
 *    at a time, twice; its resident set must come back to within RSS_SLACK of
 *    what it was idle after each burst;
 *  - node_limit: two sessions, each within its own memory quota, together past
 *    the node-wide limit: the second is refused, naming the limit, the first
 *    goes on, and once the first has ended the second can allocate. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "check.h"
#include "corvid/clock.h"
#include "corvid/handle.h"
#include "raw_node_client.h"
#include "scratch_node.h"

/* Sanitizer builds: fewer sessions of the same kind, fewer at once (each Hello creates a VkDevice, about
 * ten times slower under ASan). */
#define SESSIONS CV_TEST_REPEATS(256u, 64u)
#define BATCH CV_TEST_REPEATS(32u, 8u)
#define RSS_SLACK (64ull << 20)
/* In the sanitizer builds the resident set is the sanitizer's allocator's (ASan keeps freed blocks in a
 * quarantine by design), not glibc's arenas that the node trims: the bursts run, the bound is not checked. */
#ifdef CORVID_TEST_SANITIZED
#define RSS_CHECKED false
#else
#define RSS_CHECKED true
#endif
#define BUF_ID(i) cv_handle_pack(CV_HANDLE_BUFFER, 1, 1, (i))
#define MIB (1ull << 20)

/* VmRSS of a process, in bytes (0 if unknown). */
static unsigned long long rss_of(int pid) {
    char path[64], line[256];
    snprintf(path, sizeof(path), "/proc/%d/status", pid);
    FILE *f = fopen(path, "r");
    unsigned long long kb = 0;
    while (f && fgets(line, sizeof(line), f))
        if (sscanf(line, "VmRSS: %llu kB", &kb) == 1)
            break;
    if (f)
        fclose(f);
    return kb << 10;
}

/* The node's running sessions, from its Info answer. */
static unsigned sessions_of(const char *endpoint) {
    cv_rpc_client *client = NULL;
    cv_rpc_client_config cc = { .max_message_bytes = CV_NODE_MAX_MESSAGE_BYTES };
    if (cv_rpc_client_create(endpoint, &cc, &client) != CV_OK)
        return ~0u;
    void *data = NULL;
    size_t size = 0;
    unsigned sessions = ~0u;
    static const uint8_t empty[1];
    if (cv_rpc_client_unary(client, CV_NODE_METHOD_INFO, empty, 0, 5000, &data, &size, NULL) == CV_OK) {
        Corvid__NodeInfo *info = corvid__node_info__unpack(NULL, size, data);
        if (info)
            sessions = info->sessions;
        corvid__node_info__free_unpacked(info, NULL);
    }
    free(data);
    cv_rpc_client_destroy(client);
    return sessions;
}

static void wait_no_sessions(const char *endpoint) {
    unsigned left = ~0u;
    for (int i = 0; i < 500 && (left = sessions_of(endpoint)) != 0; i++)
        nanosleep(&(struct timespec){ 0, 20 * 1000 * 1000 }, NULL);
    CHECK_EQ_INT(left, 0);
}

/* Whether a HelloReply comes, waiting longer than raw_recv does: the node creates BATCH devices at once. */
static bool hello_reply(raw_client *c) {
    uint8_t *data = NULL;
    size_t size = 0;
    if (cv_rpc_stream_recv(c->stream, 60000, &data, &size) != CV_OK || !data)
        return false;
    Corvid__NodeMessage *m = corvid__node_message__unpack(NULL, size, data);
    free(data);
    bool ok = m && m->msg_case == CORVID__NODE_MESSAGE__MSG_HELLO;
    if (m)
        corvid__node_message__free_unpacked(m, NULL);
    return ok;
}

/* SESSIONS sessions, BATCH open at once, each saying Hello and getting its HelloReply. */
static void burst(const char *endpoint) {
    static raw_client clients[BATCH];
    for (uint32_t done = 0; done < SESSIONS; done += BATCH) {
        for (uint32_t i = 0; i < BATCH; i++) {
            raw_open(&clients[i], endpoint);
            raw_send_hello(&clients[i], CV_NODE_PROTOCOL_VERSION, 0, "memory");
        }
        for (uint32_t i = 0; i < BATCH; i++)
            CHECK(hello_reply(&clients[i]));
        for (uint32_t i = 0; i < BATCH; i++)
            raw_close(&clients[i]);
    }
}

static bool hello_ok(raw_client *c) {
    raw_send_hello(c, CV_NODE_PROTOCOL_VERSION, 0, "memory");
    Corvid__NodeMessage *m = raw_recv(c);
    bool ok = m && m->msg_case == CORVID__NODE_MESSAGE__MSG_HELLO;
    if (m)
        corvid__node_message__free_unpacked(m, NULL);
    return ok;
}

static cv_resource_desc buffer_of(uint64_t size) {
    return (cv_resource_desc){ .type = CV_HANDLE_BUFFER, .buffer = { .size = size } };
}

/* A 1.5 MiB node limit over sessions of 1 MiB each (mock devices). */
static void node_limit(void) {
    scratch_node n;
    cv_node_config limits = { .quota = { .memory_bytes = MIB }, .memory_bytes = 3 * MIB / 2 };
    CHECK_OK(scratch_node_start_secured(&n, cv_mock_backend(), 1, &limits));
    CHECK_EQ_INT(cv_node_get_stats(n.node).memory_limit, 3 * MIB / 2);
    raw_client a, b;
    raw_open(&a, n.endpoint);
    raw_open(&b, n.endpoint);
    CHECK(hello_ok(&a));
    CHECK(hello_ok(&b));
    cv_resource_desc whole = buffer_of(MIB), quarter = buffer_of(MIB / 4);
    EXPECT_REPLY(&a, raw_send_create(&a, BUF_ID(1), &whole), CV_OK, NULL);
    /* Within b's own quota, past the node's limit: refused, naming it, and nothing taken. */
    EXPECT_REPLY(&b, raw_send_create(&b, BUF_ID(1), &whole), CV_ERROR_LIMIT_EXCEEDED,
                 "node memory limit exceeded: create of 1048576 bytes: the node's sessions hold 1048576 bytes of "
                 "device memory of its limit of 1572864 (corvid-node --memory-limit 1572864)");
    CHECK_EQ_INT(cv_node_get_stats(n.node).quota_refusals, 1);
    CHECK_EQ_INT(cv_node_get_stats(n.node).memory_bytes, MIB);
    /* What is left fits; destroying gives it back. */
    EXPECT_REPLY(&b, raw_send_create(&b, BUF_ID(2), &quarter), CV_OK, NULL);
    CHECK_EQ_INT(cv_node_get_stats(n.node).memory_bytes, MIB + MIB / 4);
    raw_send_destroy(&b, BUF_ID(2));
    /* The first session goes on: its buffer works. */
    uint8_t data[256], back[256];
    memset(data, 0x3c, sizeof(data));
    raw_send_write(&a, BUF_ID(1), 0, data, sizeof(data));
    CHECK(raw_read_back(&a, BUF_ID(1), sizeof(back), back) && memcmp(back, data, sizeof(data)) == 0);
    /* Once it has ended, its megabyte is free for the second. */
    raw_close(&a);
    for (int i = 0; i < 500 && cv_node_get_stats(n.node).sessions_active > 1; i++)
        nanosleep(&(struct timespec){ 0, 10 * 1000 * 1000 }, NULL);
    CHECK_EQ_INT(cv_node_get_stats(n.node).memory_bytes, 0);
    EXPECT_REPLY(&b, raw_send_create(&b, BUF_ID(1), &whole), CV_OK, NULL);
    CHECK_EQ_INT(cv_node_get_stats(n.node).memory_bytes, MIB);
    raw_close(&b);
    CHECK_EQ_INT(scratch_node_wait_sessions(&n, 5000), 0);
    CHECK_EQ_INT(cv_node_get_stats(n.node).memory_bytes, 0);
    scratch_node_stop(&n);
}

int main(int argc, char **argv) {
    if (argc < 2) {
        fprintf(stderr, "usage: node_memory PATH-TO-corvid-node\n");
        return 2;
    }
    node_limit();
    CHECK_NOTHING_LIVE();
    scratch_process_node n = { 0 };
    const char *extra[] = { "--quiet", NULL };
    CHECK_OK(scratch_process_node_start(&n, argv[1], 1, 0, extra));
    if (!n.pid)
        return check_report("node_memory");
    unsigned long long idle = rss_of(n.pid);
    printf("idle: %.1f MB\n", idle / 1048576.0);
    for (int round = 1; round <= 2; round++) {
        double t0 = cv_now_ms() / 1e3;
        burst(n.endpoint);
        wait_no_sessions(n.endpoint);
        /* The node trims after a session's thread has counted it ended: give the last trim time to finish. */
        unsigned long long after = rss_of(n.pid);
        for (int i = 0; RSS_CHECKED && i < 100 && after > idle + RSS_SLACK; i++) {
            nanosleep(&(struct timespec){ 0, 100 * 1000 * 1000 }, NULL);
            after = rss_of(n.pid);
        }
        printf("after burst %d of %u sessions (%.1f s): %.1f MB (idle %.1f MB, bound %.1f MB)\n", round, SESSIONS,
               cv_now_ms() / 1e3 - t0, after / 1048576.0, idle / 1048576.0, (idle + RSS_SLACK) / 1048576.0);
        CHECK(idle > 0 && (!RSS_CHECKED || after <= idle + RSS_SLACK));
    }
    scratch_process_node_stop(&n);
    return check_report("node_memory");
}
