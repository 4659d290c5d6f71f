/* corvid_util: the monotonic clock and deadline arithmetic, the hash map against a naive
 * reference under random operations, and the log sink (levels, callback, many threads). */
#include <errno.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "check.h"
#include "corvid/clock.h"
#include "corvid/hash_map.h"
#include "corvid/log.h"

static void test_clock(void) {
    uint64_t a = cv_now_ns();
    double ms = cv_now_ms();
    uint64_t b = cv_now_ns();
    CHECK(b >= a);
    CHECK(ms >= (double)a / 1e6 - 1.0 && ms <= (double)b / 1e6 + 1.0);
    for (int i = 0; i < 1000; i++) {
        uint64_t c = cv_now_ns();
        CHECK(c >= b);
        b = c;
    }
}

static void test_deadlines(void) {
    uint64_t now = cv_now_ns();
    uint64_t d = cv_deadline_after_ms(50);
    CHECK(d >= now + 50 * 1000000ull);
    CHECK(!cv_deadline_passed(d));
    uint64_t left = cv_deadline_left_ns(d);
    CHECK(left > 0 && left <= 50 * 1000000ull);
    /* Past deadlines. */
    CHECK(cv_deadline_passed(now));
    CHECK(cv_deadline_passed(0));
    CHECK_EQ_INT(cv_deadline_left_ns(0), 0);
    CHECK(cv_deadline_passed(cv_deadline_after_ns(0)));
    /* Saturation: never wraps into the past. */
    CHECK(cv_deadline_after_ns(UINT64_MAX) == CV_DEADLINE_NEVER);
    CHECK(cv_deadline_after_ns(UINT64_MAX - 1) == CV_DEADLINE_NEVER);
    CHECK(cv_deadline_after_ms(UINT64_MAX) == CV_DEADLINE_NEVER);
    CHECK(cv_deadline_after_ms(UINT64_MAX / 1000) == CV_DEADLINE_NEVER);
    CHECK(cv_deadline_after_ms(UINT32_MAX) != CV_DEADLINE_NEVER && cv_deadline_after_ms(UINT32_MAX) > now);
    CHECK(!cv_deadline_passed(CV_DEADLINE_NEVER));
    CHECK(cv_deadline_left_ns(CV_DEADLINE_NEVER) == UINT64_MAX);
    CHECK(cv_deadline_min(d, CV_DEADLINE_NEVER) == d && cv_deadline_min(CV_DEADLINE_NEVER, 5) == 5);
    /* The timespec is the same instant on CLOCK_MONOTONIC; never is centuries away. */
    struct timespec mono = cv_deadline_timespec(d), now_ts;
    CHECK((uint64_t)mono.tv_sec * 1000000000ull + (uint64_t)mono.tv_nsec == d);
    CHECK(mono.tv_nsec >= 0 && mono.tv_nsec < 1000000000L);
    clock_gettime(CLOCK_MONOTONIC, &now_ts);
    struct timespec never = cv_deadline_timespec(CV_DEADLINE_NEVER);
    CHECK(never.tv_sec > now_ts.tv_sec + 100LL * 365 * 24 * 3600);
    /* A condition variable times out at its deadline, not before. */
    pthread_mutex_t mu = PTHREAD_MUTEX_INITIALIZER;
    pthread_cond_t cond;
    CHECK_EQ_INT(cv_cond_init(&cond), 0);
    uint64_t until = cv_deadline_after_ms(20);
    int r = 0;
    pthread_mutex_lock(&mu);
    while (r == 0)
        r = cv_cond_wait_until(&cond, &mu, until);
    pthread_mutex_unlock(&mu);
    CHECK_EQ_INT(r, ETIMEDOUT);
    CHECK(cv_deadline_passed(until));
    pthread_cond_destroy(&cond);
}

/* The reference: an unsorted array of pairs. */
typedef struct naive {
    uint64_t keys[512], values[512];
    uint32_t count;
} naive;

static int naive_find(const naive *n, uint64_t key) {
    for (uint32_t i = 0; i < n->count; i++)
        if (n->keys[i] == key)
            return (int)i;
    return -1;
}

static uint64_t next_random(uint64_t *state) {
    *state ^= *state << 13;
    *state ^= *state >> 7;
    *state ^= *state << 17;
    return *state;
}

/* Keys from a small pool (so removes and re-puts hit), with 0 and UINT64_MAX among them. */
static uint64_t pick_key(uint64_t *rng, uint32_t pool) {
    uint64_t k = next_random(rng) % pool;
    return k == 0 ? 0 : k == 1 ? UINT64_MAX : k * 0x10000ull;
}

static void hash_map_step(cv_hash_map *m, naive *n, uint64_t *rng, uint32_t pool) {
    uint64_t key = pick_key(rng, pool), value = next_random(rng), got = 0;
    int at = naive_find(n, key);
    switch (next_random(rng) % 3) {
    case 0:
        CHECK_OK(cv_hash_map_put(m, key, value));
        if (at >= 0) {
            n->values[at] = value;
        } else {
            n->keys[n->count] = key;
            n->values[n->count++] = value;
        }
        break;
    case 1:
        CHECK_EQ_INT(cv_hash_map_remove(m, key, &got), at >= 0);
        if (at >= 0) {
            CHECK(got == n->values[at]);
            n->keys[at] = n->keys[--n->count];
            n->values[at] = n->values[n->count];
        }
        break;
    default: CHECK_EQ_INT(cv_hash_map_get(m, key, &got), at >= 0); CHECK(at < 0 || got == n->values[at]);
    }
}

static void test_hash_map_random(void) {
    cv_hash_map m;
    cv_hash_map_init(&m, 12345);
    static naive n;
    n.count = 0;
    uint64_t rng = 0x9e3779b97f4a7c15ull;
    uint32_t max_capacity = 0;
    for (int round = 0; round < 20000; round++) {
        /* The pool grows then shrinks: the map grows, then fills with tombstones it must clear. */
        uint32_t pool = round < 10000 ? 16 + (uint32_t)round / 25 : 64;
        hash_map_step(&m, &n, &rng, pool);
        CHECK_EQ_INT(cv_hash_map_count(&m), n.count);
        if (m.capacity > max_capacity)
            max_capacity = m.capacity;
        CHECK((m.count + m.tombstones) * 2 <= m.capacity);
    }
    CHECK(max_capacity >= 512);
    CHECK(m.capacity <= max_capacity); /* tombstones never made it grow past what live entries need */
    /* Iteration sees every entry once. */
    uint32_t cursor = 0, seen = 0;
    uint64_t key, value;
    while (cv_hash_map_next(&m, &cursor, &key, &value)) {
        int at = naive_find(&n, key);
        CHECK(at >= 0 && n.values[at] == value);
        seen++;
    }
    CHECK_EQ_INT(seen, n.count);
    cv_hash_map_finish(&m);
    CHECK_EQ_INT(cv_hash_map_count(&m), 0);
    CHECK(!cv_hash_map_get(&m, 0, NULL) && !cv_hash_map_remove(&m, 0, NULL));
}

/* Many removes and puts of fresh keys at a steady size: tombstones are cleared without growing. */
static void test_hash_map_tombstones(void) {
    cv_hash_map m;
    cv_hash_map_init(&m, 0);
    for (uint64_t k = 0; k < 8; k++)
        CHECK_OK(cv_hash_map_put(&m, k, k + 100));
    for (uint64_t k = 8; k < 100000; k++) {
        CHECK_OK(cv_hash_map_put(&m, k, k + 100));
        CHECK(cv_hash_map_remove(&m, k - 8, NULL));
    }
    CHECK(m.capacity <= 64); /* 8 live entries fill at most a quarter after a rebuild */
    CHECK_EQ_INT(cv_hash_map_count(&m), 8);
    uint64_t v = 0;
    CHECK(cv_hash_map_get(&m, 99999, &v) && v == 100099);
    CHECK(!cv_hash_map_get(&m, 99991, NULL));
    cv_hash_map_finish(&m);
}

/* Clear empties the map and keeps its memory: the barrier tracker refills one map per list. */
static void test_hash_map_clear(void) {
    cv_hash_map m;
    cv_hash_map_init(&m, 7);
    for (uint64_t round = 0; round < 3; round++) {
        for (uint64_t k = 0; k < 1000; k++)
            CHECK_OK(cv_hash_map_put(&m, k * 3 + round, k));
        CHECK_EQ_INT(cv_hash_map_count(&m), 1000);
        uint32_t capacity = m.capacity;
        cv_hash_map_clear(&m);
        CHECK_EQ_INT(cv_hash_map_count(&m), 0);
        CHECK_EQ_INT(m.capacity, capacity);
        CHECK(!cv_hash_map_get(&m, 3 + round, NULL));
        uint32_t cursor = 0;
        CHECK(!cv_hash_map_next(&m, &cursor, NULL, NULL));
    }
    CHECK_OK(cv_hash_map_put(&m, 5, 6));
    uint64_t v = 0;
    CHECK(cv_hash_map_get(&m, 5, &v) && v == 6);
    cv_hash_map_finish(&m);
}

typedef struct captured {
    int count;
    cv_log_level level;
    char origin[32], message[256];
} captured;

static void capture(cv_log_level level, const char *origin, const char *message, void *user) {
    captured *c = user;
    c->count++;
    c->level = level;
    snprintf(c->origin, sizeof(c->origin), "%s", origin);
    snprintf(c->message, sizeof(c->message), "%s", message);
}

static void test_log_levels(void) {
    captured c = { 0 };
    cv_log_set_sink(capture, &c, CV_LOG_WARNING);
    CHECK(cv_log_enabled(CV_LOG_ERROR) && cv_log_enabled(CV_LOG_WARNING));
    CHECK(!cv_log_enabled(CV_LOG_INFO) && !cv_log_enabled(CV_LOG_DEBUG));
    cv_log(CV_LOG_INFO, "test", "dropped");
    CHECK_EQ_INT(c.count, 0);
    cv_log(CV_LOG_WARNING, "test", "kept %d", 7);
    CHECK_EQ_INT(c.count, 1);
    CHECK_EQ_INT(c.level, CV_LOG_WARNING);
    CHECK(strcmp(c.origin, "test") == 0 && strcmp(c.message, "kept 7") == 0);
    /* A long message arrives whole. */
    char long_text[3000];
    memset(long_text, 'x', sizeof(long_text) - 1);
    long_text[sizeof(long_text) - 1] = '\0';
    cv_log(CV_LOG_ERROR, "test", "%s!", long_text);
    CHECK_EQ_INT(c.count, 2);
    /* cv_error logs at DEBUG with origin "error", only when DEBUG is on. */
    cv_error(CV_ERROR_NOT_FOUND, "quiet");
    CHECK_EQ_INT(c.count, 2);
    cv_log_set_sink(capture, &c, CV_LOG_DEBUG);
    cv_error(CV_ERROR_NOT_FOUND, "thing %s", "x");
    CHECK_EQ_INT(c.count, 3);
    CHECK(c.level == CV_LOG_DEBUG && strcmp(c.origin, "error") == 0);
    CHECK(strcmp(c.message, "CV_ERROR_NOT_FOUND: thing x") == 0);
    cv_clear_error();
    cv_log_set_sink(NULL, NULL, CV_LOG_INFO);
    CHECK(cv_log_enabled(CV_LOG_INFO) && !cv_log_enabled(CV_LOG_DEBUG));
}

/* The default sink: one line on stderr, "corvid <origin>: <message>". */
static void test_log_stderr(void) {
    fflush(stderr);
    int saved = dup(STDERR_FILENO);
    FILE *capture_file = tmpfile();
    CHECK(saved >= 0 && capture_file != NULL);
    if (saved < 0 || !capture_file)
        return;
    dup2(fileno(capture_file), STDERR_FILENO);
    cv_log_set_sink(NULL, NULL, CV_LOG_INFO);
    cv_log(CV_LOG_INFO, "test", "hello %s", "there");
    cv_log(CV_LOG_DEBUG, "test", "dropped");
    fflush(stderr);
    dup2(saved, STDERR_FILENO);
    close(saved);
    char text[128] = { 0 };
    rewind(capture_file);
    size_t n = fread(text, 1, sizeof(text) - 1, capture_file);
    fclose(capture_file);
    CHECK_EQ_INT(n, strlen("corvid test: hello there\n"));
    CHECK(strcmp(text, "corvid test: hello there\n") == 0);
}

/* Several threads log while the main thread swaps sinks: each message reaches exactly one sink. */
typedef struct counting {
    long count; /* the sink's lock serialises the calls */
} counting;

static void count_message(cv_log_level level, const char *origin, const char *message, void *user) {
    (void)level;
    (void)origin;
    (void)message;
    ((counting *)user)->count++;
}

#define LOG_THREADS 4
#define LOG_MESSAGES 2000

static void *log_many(void *arg) {
    (void)arg;
    for (int i = 0; i < LOG_MESSAGES; i++)
        cv_log(CV_LOG_INFO, "thread", "message %d", i);
    return NULL;
}

static void test_log_threads(void) {
    counting a = { 0 }, b = { 0 };
    cv_log_set_sink(count_message, &a, CV_LOG_INFO);
    pthread_t threads[LOG_THREADS];
    for (int i = 0; i < LOG_THREADS; i++)
        pthread_create(&threads[i], NULL, log_many, NULL);
    for (int i = 0; i < 100; i++)
        cv_log_set_sink(count_message, i % 2 ? &a : &b, CV_LOG_INFO);
    for (int i = 0; i < LOG_THREADS; i++)
        pthread_join(threads[i], NULL);
    cv_log_set_sink(NULL, NULL, CV_LOG_INFO);
    CHECK_EQ_INT(a.count + b.count, LOG_THREADS * LOG_MESSAGES);
}

int main(void) {
    test_clock();
    test_deadlines();
    test_hash_map_random();
    test_hash_map_tombstones();
    test_hash_map_clear();
    test_log_levels();
    test_log_stderr();
    test_log_threads();
    CHECK_NOTHING_LIVE();
    return check_report("core_util");
}
