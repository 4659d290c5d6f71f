/* The RPC layer over loopback: an echo server and clients, every test on 127.0.0.1 port 0, bounded waits,
 * and every test ends with nothing left (server streams back to 0, every object destroyed).
 * `rpc_test NAME` runs one test. */
#include "check.h"
#include "corvid/clock.h"
#include "corvid/rpc.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <unistd.h>

#define ECHO "/test.Echo/Stream"   /* echoes; at end of stream finishes OK "echoed N" */
#define REJECT "/test.Echo/Reject" /* finishes INVALID_ARGUMENT at once */
#define META "/test.Echo/Meta"     /* sends the "corvid-session" metadata value, returns */
#define UNARY "/test.Echo/Unary"   /* echoes; "fail" -> INVALID_ARGUMENT */

typedef struct echo_state {
    atomic_int streams_seen, eofs_seen;
} echo_state;

static void echo_stream(cv_rpc_stream *s, const char *method, void *user) {
    echo_state *st = user;
    atomic_fetch_add(&st->streams_seen, 1);
    if (strcmp(method, REJECT) == 0) {
        cv_rpc_stream_finish(s, CV_RPC_STATUS_INVALID_ARGUMENT, "bad session parameters");
        return;
    }
    if (strcmp(method, META) == 0) {
        const char *v = cv_rpc_stream_metadata(s, "corvid-session");
        cv_rpc_stream_send(s, v ? v : "(none)", strlen(v ? v : "(none)"));
        return; /* the layer finishes with OK */
    }
    unsigned count = 0;
    for (;;) {
        uint8_t *m;
        size_t n;
        if (cv_rpc_stream_recv(s, CV_RPC_FOREVER, &m, &n) != CV_OK)
            return;
        if (!m) {
            atomic_fetch_add(&st->eofs_seen, 1);
            char text[64];
            snprintf(text, sizeof text, "echoed %u", count);
            cv_rpc_stream_finish(s, CV_RPC_STATUS_OK, text);
            return;
        }
        cv_result r = cv_rpc_stream_send(s, m, n);
        free(m);
        if (r != CV_OK)
            return;
        count++;
    }
}

static int echo_unary(const char *method, const void *request, size_t size, void **response, size_t *response_size,
                      char *message, size_t cap, void *user) {
    (void)method;
    (void)user;
    if (size == 4 && memcmp(request, "fail", 4) == 0) {
        snprintf(message, cap, "asked to fail");
        return CV_RPC_STATUS_INVALID_ARGUMENT;
    }
    *response = malloc(size ? size : 1);
    memcpy(*response, request, size);
    *response_size = size;
    return 0;
}

static const char *const stream_methods[] = { ECHO, REJECT, META, NULL };
static const char *const unary_methods[] = { UNARY, NULL };

static cv_rpc_server *start_echo(echo_state *st, uint32_t max_message, uint32_t max_streams) {
    cv_rpc_server_config cfg = { .listen = "127.0.0.1:0",
                                 .max_message_bytes = max_message,
                                 .max_streams = max_streams,
                                 .on_stream = echo_stream,
                                 .on_unary = echo_unary,
                                 .stream_methods = stream_methods,
                                 .unary_methods = unary_methods,
                                 .user = st };
    cv_rpc_server *s = NULL;
    CHECK_OK(cv_rpc_server_start(&cfg, &s));
    CHECK(s && cv_rpc_server_port(s) > 0);
    return s;
}

static cv_rpc_client *connect_to(cv_rpc_server *server) {
    char target[64];
    snprintf(target, sizeof target, "127.0.0.1:%d", cv_rpc_server_port(server));
    cv_rpc_client *c = NULL;
    CHECK_OK(cv_rpc_client_create(target, NULL, &c));
    return c;
}

/* Streams end asynchronously on the server after the client goes: wait (bounded) for the count to fall. */
static bool wait_idle(cv_rpc_server *s, double seconds) {
    double end = cv_now_ms() / 1e3 + seconds;
    while (cv_rpc_server_active_streams(s) != 0 && cv_now_ms() / 1e3 < end)
        usleep(2000);
    return cv_rpc_server_active_streams(s) == 0;
}

static void finish_server(cv_rpc_server *s) {
    CHECK(wait_idle(s, 5.0));
    cv_rpc_server_destroy(s, 1000);
}

/* Sends `msg`, expects it back. */
static void round_trip(cv_rpc_stream *st, const char *msg) {
    CHECK_OK(cv_rpc_stream_send(st, msg, strlen(msg)));
    uint8_t *m = NULL;
    size_t n = 0;
    CHECK_OK(cv_rpc_stream_recv(st, 5000, &m, &n));
    CHECK(m && n == strlen(msg) && memcmp(m, msg, n) == 0);
    free(m);
}

/* Half-closes, expects end of stream and an OK status reading "echoed N". */
static void close_and_expect(cv_rpc_stream *st, unsigned echoed) {
    CHECK_OK(cv_rpc_stream_close_send(st));
    uint8_t *m = (uint8_t *)1;
    size_t n;
    CHECK_OK(cv_rpc_stream_recv(st, 5000, &m, &n));
    CHECK(m == NULL);
    char text[128], want[64];
    snprintf(want, sizeof want, "echoed %u", echoed);
    CHECK_EQ_INT(cv_rpc_stream_status(st, text, sizeof text), CV_RPC_STATUS_OK);
    CHECK(strcmp(text, want) == 0);
}

/* Expects the stream to fail with `status`; returns the status message. */
static void expect_failure(cv_rpc_stream *st, int status, const char *message_part) {
    uint8_t *m = NULL;
    size_t n;
    CHECK_RESULT(cv_rpc_stream_recv(st, 5000, &m, &n), CV_ERROR_CONNECTION);
    CHECK(m == NULL);
    char text[256];
    int got = cv_rpc_stream_status(st, text, sizeof text);
    CHECK_EQ_INT(got, status);
    if (message_part && !strstr(text, message_part)) {
        fprintf(stderr, "status message '%s' lacks '%s'\n", text, message_part);
        CHECK(false);
    }
}

/* ---- tests ---- */

static void test_small_messages(void) {
    echo_state st = { 0 };
    cv_rpc_server *server = start_echo(&st, 0, 0);
    cv_rpc_client *c = connect_to(server);
    cv_rpc_stream *s = NULL;
    CHECK_OK(cv_rpc_client_open(c, ECHO, NULL, 0, &s));
    enum { N = 1000 };
    for (int i = 0; i < N; i++) { /* all queued first: the layer buffers and paces */
        char msg[32];
        int len = snprintf(msg, sizeof msg, "message %d", i);
        CHECK_OK(cv_rpc_stream_send(s, msg, (size_t)len));
    }
    CHECK_OK(cv_rpc_stream_send(s, "", 0)); /* an empty message is a message, not end of stream */
    int in_order = 0;
    for (int i = 0; i < N; i++) {
        uint8_t *m = NULL;
        size_t n = 0;
        if (cv_rpc_stream_recv(s, 5000, &m, &n) != CV_OK || !m)
            break;
        char want[32];
        int len = snprintf(want, sizeof want, "message %d", i);
        in_order += n == (size_t)len && memcmp(m, want, n) == 0;
        free(m);
    }
    CHECK_EQ_INT(in_order, N);
    uint8_t *m = NULL;
    size_t n = 1;
    CHECK_OK(cv_rpc_stream_recv(s, 5000, &m, &n));
    CHECK(m != NULL && n == 0);
    free(m);
    close_and_expect(s, N + 1);
    CHECK_EQ_INT(atomic_load(&st.eofs_seen), 1);
    cv_rpc_stream_destroy(s);
    cv_rpc_client_destroy(c);
    finish_server(server);
}

static void test_large_messages(void) {
    echo_state st = { 0 };
    cv_rpc_server *server = start_echo(&st, 0, 0);
    cv_rpc_client *c = connect_to(server);
    cv_rpc_stream *s = NULL;
    CHECK_OK(cv_rpc_client_open(c, ECHO, NULL, 0, &s));
    size_t sizes[] = { 1u << 20, 12u << 20 };
    for (int k = 0; k < 2; k++) {
        uint8_t *buf = malloc(sizes[k]);
        for (size_t i = 0; i < sizes[k]; i++)
            buf[i] = (uint8_t)(i * 2654435761u >> 13);
        CHECK_OK(cv_rpc_stream_send(s, buf, sizes[k]));
        uint8_t *m = NULL;
        size_t n = 0;
        CHECK_OK(cv_rpc_stream_recv(s, 20000, &m, &n));
        CHECK(m && n == sizes[k] && memcmp(m, buf, n) == 0);
        free(m);
        free(buf);
    }
    close_and_expect(s, 2);
    cv_rpc_stream_destroy(s);
    cv_rpc_client_destroy(c);
    finish_server(server);
}

static void test_over_limit(void) {
    echo_state st = { 0 };
    cv_rpc_server *server = start_echo(&st, 1u << 20, 0);
    cv_rpc_client *c = connect_to(server);
    cv_rpc_stream *s = NULL;
    CHECK_OK(cv_rpc_client_open(c, ECHO, NULL, 0, &s));
    round_trip(s, "fits");
    size_t size = (1u << 20) + 1;
    uint8_t *buf = calloc(1, size);
    cv_result r = cv_rpc_stream_send(s, buf, size);
    CHECK(r == CV_OK || r == CV_ERROR_CONNECTION);
    free(buf);
    expect_failure(s, CV_RPC_STATUS_RESOURCE_EXHAUSTED, NULL);
    CHECK_RESULT(cv_rpc_stream_send(s, "late", 4), CV_ERROR_CONNECTION);
    cv_rpc_stream_destroy(s);
    cv_rpc_client_destroy(c);
    finish_server(server);
}

static void test_server_error_status(void) {
    echo_state st = { 0 };
    cv_rpc_server *server = start_echo(&st, 0, 0);
    cv_rpc_client *c = connect_to(server);
    cv_rpc_stream *s = NULL;
    CHECK_OK(cv_rpc_client_open(c, REJECT, NULL, 0, &s));
    expect_failure(s, CV_RPC_STATUS_INVALID_ARGUMENT, "bad session parameters");
    CHECK(strstr(cv_last_error(), "INVALID_ARGUMENT") && strstr(cv_last_error(), "bad session parameters"));
    cv_rpc_stream_destroy(s);
    cv_rpc_client_destroy(c);
    finish_server(server);
}

static void test_metadata_and_peer(void) {
    echo_state st = { 0 };
    cv_rpc_server *server = start_echo(&st, 0, 0);
    cv_rpc_client *c = connect_to(server);
    cv_rpc_stream *s = NULL;
    cv_rpc_metadata md[] = { { "corvid-session", "session-42" }, { "other", "x" } };
    CHECK_OK(cv_rpc_client_open(c, META, md, 2, &s));
    uint8_t *m = NULL;
    size_t n = 0;
    CHECK_OK(cv_rpc_stream_recv(s, 5000, &m, &n));
    CHECK(m && n == 10 && memcmp(m, "session-42", 10) == 0);
    free(m);
    CHECK_OK(cv_rpc_stream_recv(s, 5000, &m, &n));
    CHECK(m == NULL);
    CHECK_EQ_INT(cv_rpc_stream_status(s, NULL, 0), CV_RPC_STATUS_OK);
    CHECK(strlen(cv_rpc_stream_peer(s)) > 0);
    cv_rpc_stream_destroy(s);
    cv_rpc_metadata bad[] = { { "Upper-Case", "x" } };
    CHECK_RESULT(cv_rpc_client_open(c, META, bad, 1, &s), CV_ERROR_INVALID_ARGUMENT);
    cv_rpc_client_destroy(c);
    finish_server(server);
}

typedef struct worker {
    cv_rpc_client *client;
    int ok_streams;
} worker;

static void *concurrent_worker(void *arg) {
    worker *w = arg;
    enum { STREAMS = 8, MESSAGES = 50 };
    cv_rpc_stream *s[STREAMS] = { 0 };
    for (int i = 0; i < STREAMS; i++)
        if (cv_rpc_client_open(w->client, ECHO, NULL, 0, &s[i]) != CV_OK)
            s[i] = NULL;
    int good[STREAMS] = { 0 };
    for (int k = 0; k < MESSAGES; k++)
        for (int i = 0; i < STREAMS; i++) {
            if (!s[i])
                continue;
            char msg[48];
            int len = snprintf(msg, sizeof msg, "w%p s%d m%d", (void *)w, i, k);
            if (cv_rpc_stream_send(s[i], msg, (size_t)len) != CV_OK)
                continue;
            uint8_t *m = NULL;
            size_t n = 0;
            if (cv_rpc_stream_recv(s[i], 10000, &m, &n) == CV_OK && m && n == (size_t)len && memcmp(m, msg, n) == 0)
                good[i]++;
            free(m);
        }
    for (int i = 0; i < STREAMS; i++) {
        if (!s[i])
            continue;
        uint8_t *m = (uint8_t *)1;
        size_t n;
        if (cv_rpc_stream_close_send(s[i]) == CV_OK && cv_rpc_stream_recv(s[i], 10000, &m, &n) == CV_OK &&
            m == NULL && cv_rpc_stream_status(s[i], NULL, 0) == 0 && good[i] == MESSAGES)
            w->ok_streams++;
        cv_rpc_stream_destroy(s[i]);
    }
    return NULL;
}

static void test_concurrent_streams(void) {
    echo_state st = { 0 };
    cv_rpc_server *server = start_echo(&st, 0, 0);
    cv_rpc_client *c = connect_to(server);
    enum { THREADS = 8 };
    worker w[THREADS] = { 0 };
    pthread_t t[THREADS];
    for (int i = 0; i < THREADS; i++) {
        w[i].client = c;
        pthread_create(&t[i], NULL, concurrent_worker, &w[i]);
    }
    int ok = 0;
    for (int i = 0; i < THREADS; i++) {
        pthread_join(t[i], NULL);
        ok += w[i].ok_streams;
    }
    CHECK_EQ_INT(ok, 64);
    CHECK_EQ_INT(atomic_load(&st.streams_seen), 64);
    cv_rpc_client_destroy(c);
    finish_server(server);
}

static void test_open_and_drop(void) {
    echo_state st = { 0 };
    cv_rpc_server *server = start_echo(&st, 0, 0);
    cv_rpc_client *c = connect_to(server);
    for (int i = 0; i < 500; i++) {
        cv_rpc_stream *s = NULL;
        if (cv_rpc_client_open(c, ECHO, NULL, 0, &s) != CV_OK) {
            CHECK(false);
            break;
        }
        if (i % 2)
            cv_rpc_stream_send(s, "x", 1);
        if (i % 3 == 0)
            cv_rpc_stream_cancel(s);
        cv_rpc_stream_destroy(s);
    }
    CHECK(wait_idle(server, 10.0));
    CHECK_EQ_INT(cv_rpc_server_active_streams(server), 0);
    cv_rpc_stream *s = NULL; /* the server still serves */
    CHECK_OK(cv_rpc_client_open(c, ECHO, NULL, 0, &s));
    round_trip(s, "still here");
    close_and_expect(s, 1);
    cv_rpc_stream_destroy(s);
    cv_rpc_client_destroy(c);
    finish_server(server);
}

typedef struct waiter {
    cv_rpc_stream *stream;
    cv_result result;
    double returned_at;
} waiter;

static void *wait_in_recv(void *arg) {
    waiter *w = arg;
    uint8_t *m = NULL;
    size_t n;
    w->result = cv_rpc_stream_recv(w->stream, 20000, &m, &n);
    w->returned_at = cv_now_ms() / 1e3;
    free(m);
    return NULL;
}

static void test_server_killed(void) {
    echo_state st = { 0 };
    cv_rpc_server *server = start_echo(&st, 0, 0);
    cv_rpc_client *c = connect_to(server);
    cv_rpc_stream *s = NULL;
    CHECK_OK(cv_rpc_client_open(c, ECHO, NULL, 0, &s));
    round_trip(s, "hello");
    waiter w = { .stream = s };
    pthread_t t;
    pthread_create(&t, NULL, wait_in_recv, &w);
    usleep(100000);
    double killed_at = cv_now_ms() / 1e3;
    cv_rpc_server_destroy(server, 0);
    pthread_join(t, NULL);
    CHECK_RESULT(w.result, CV_ERROR_CONNECTION);
    CHECK(w.returned_at - killed_at < 2.0);
    CHECK_RESULT(cv_rpc_stream_send(s, "x", 1), CV_ERROR_CONNECTION);
    cv_rpc_stream_destroy(s);
    cv_rpc_client_destroy(c);
}

static void test_nothing_listens(void) {
    int fd = socket(AF_INET, SOCK_STREAM, 0); /* a port that was free a moment ago */
    struct sockaddr_in a = { .sin_family = AF_INET, .sin_addr.s_addr = htonl(INADDR_LOOPBACK) };
    socklen_t len = sizeof a;
    bind(fd, (struct sockaddr *)&a, sizeof a);
    getsockname(fd, (struct sockaddr *)&a, &len);
    close(fd);
    char target[64];
    snprintf(target, sizeof target, "127.0.0.1:%d", ntohs(a.sin_port));
    cv_rpc_client_config cfg = { .connect_timeout_ms = 2000 };
    cv_rpc_client *c = NULL;
    CHECK_OK(cv_rpc_client_create(target, &cfg, &c));
    double t0 = cv_now_ms() / 1e3;
    cv_rpc_stream *s = NULL;
    CHECK_OK(cv_rpc_client_open(c, ECHO, NULL, 0, &s));
    uint8_t *m = NULL;
    size_t n;
    CHECK_RESULT(cv_rpc_stream_recv(s, 10000, &m, &n), CV_ERROR_CONNECTION);
    CHECK(cv_now_ms() / 1e3 - t0 < 2.5);
    CHECK_EQ_INT(cv_rpc_stream_status(s, NULL, 0), CV_RPC_STATUS_UNAVAILABLE);
    cv_rpc_stream_destroy(s);
    void *resp = NULL;
    size_t resp_size = 0;
    int status = 0;
    t0 = cv_now_ms() / 1e3;
    CHECK_RESULT(cv_rpc_client_unary(c, UNARY, "x", 1, 5000, &resp, &resp_size, &status), CV_ERROR_CONNECTION);
    CHECK_EQ_INT(status, CV_RPC_STATUS_UNAVAILABLE);
    CHECK(cv_now_ms() / 1e3 - t0 < 2.5);
    cv_rpc_client_destroy(c);
}

static void test_drain(void) {
    echo_state st = { 0 };
    cv_rpc_server *server = start_echo(&st, 0, 0);
    cv_rpc_client *c = connect_to(server);
    cv_rpc_stream *a = NULL, *b = NULL;
    CHECK_OK(cv_rpc_client_open(c, ECHO, NULL, 0, &a));
    round_trip(a, "before drain");
    cv_rpc_server_drain(server);
    CHECK_OK(cv_rpc_client_open(c, ECHO, NULL, 0, &b));
    expect_failure(b, CV_RPC_STATUS_UNAVAILABLE, "node is draining");
    cv_rpc_stream_destroy(b);
    round_trip(a, "after drain");
    void *resp = NULL; /* unary calls (health) still answered */
    size_t resp_size = 0;
    CHECK_OK(cv_rpc_client_unary(c, UNARY, "ping", 4, 5000, &resp, &resp_size, NULL));
    free(resp);
    close_and_expect(a, 2);
    cv_rpc_stream_destroy(a);
    cv_rpc_client_destroy(c);
    finish_server(server);
}

static void test_max_streams(void) {
    echo_state st = { 0 };
    cv_rpc_server *server = start_echo(&st, 0, 2);
    cv_rpc_client *c = connect_to(server);
    cv_rpc_stream *s[3] = { 0 };
    for (int i = 0; i < 2; i++) {
        CHECK_OK(cv_rpc_client_open(c, ECHO, NULL, 0, &s[i]));
        round_trip(s[i], "occupying");
    }
    CHECK_OK(cv_rpc_client_open(c, ECHO, NULL, 0, &s[2]));
    expect_failure(s[2], CV_RPC_STATUS_RESOURCE_EXHAUSTED, "limit");
    cv_rpc_stream_destroy(s[2]);
    close_and_expect(s[0], 1);
    cv_rpc_stream_destroy(s[0]);
    cv_rpc_stream_destroy(s[1]); /* dropped without closing: cancelled */
    cv_rpc_client_destroy(c);
    finish_server(server);
}

static void test_unary(void) {
    echo_state st = { 0 };
    cv_rpc_server *server = start_echo(&st, 0, 0);
    cv_rpc_client *c = connect_to(server);
    void *resp = NULL;
    size_t resp_size = 0;
    int status = -2;
    CHECK_OK(cv_rpc_client_unary(c, UNARY, "hello", 5, 5000, &resp, &resp_size, &status));
    CHECK(status == 0 && resp && resp_size == 5 && memcmp(resp, "hello", 5) == 0);
    free(resp);
    CHECK_RESULT(cv_rpc_client_unary(c, UNARY, "fail", 4, 5000, &resp, &resp_size, &status), CV_ERROR_CONNECTION);
    CHECK_EQ_INT(status, CV_RPC_STATUS_INVALID_ARGUMENT);
    CHECK(strstr(cv_last_error(), "asked to fail") != NULL);
    CHECK_RESULT(cv_rpc_client_unary(c, "/test.Echo/Nope", "x", 1, 5000, &resp, &resp_size, &status),
                 CV_ERROR_CONNECTION);
    CHECK_EQ_INT(status, CV_RPC_STATUS_UNIMPLEMENTED);
    cv_rpc_stream *s = NULL; /* a stream on an unknown method too */
    CHECK_OK(cv_rpc_client_open(c, "/test.Echo/Nope", NULL, 0, &s));
    expect_failure(s, CV_RPC_STATUS_UNIMPLEMENTED, "not served");
    cv_rpc_stream_destroy(s);
    cv_rpc_client_destroy(c);
    finish_server(server);
}

static void test_recv_timeout(void) {
    echo_state st = { 0 };
    cv_rpc_server *server = start_echo(&st, 0, 0);
    cv_rpc_client *c = connect_to(server);
    cv_rpc_stream *s = NULL;
    CHECK_OK(cv_rpc_client_open(c, ECHO, NULL, 0, &s));
    double t0 = cv_now_ms() / 1e3;
    uint8_t *m = NULL;
    size_t n;
    CHECK_RESULT(cv_rpc_stream_recv(s, 100, &m, &n), CV_ERROR_TIMEOUT);
    double dt = cv_now_ms() / 1e3 - t0;
    CHECK(dt >= 0.09 && dt < 1.0);
    round_trip(s, "after a timeout");
    close_and_expect(s, 1);
    cv_rpc_stream_destroy(s);
    cv_rpc_client_destroy(c);
    finish_server(server);
}

/* A TCP proxy that can freeze: it stops moving bytes but keeps both sockets open, as a peer behind a dead
 * network path would look. Only keepalive can notice that. */
typedef struct proxy {
    int listen_fd, listen_port, port;
    atomic_bool frozen, stop;
    pthread_t thread;
} proxy;

static void *proxy_main(void *arg) {
    proxy *p = arg;
    struct pollfd lp = { .fd = p->listen_fd, .events = POLLIN };
    int client = -1;
    while (!atomic_load(&p->stop) && client < 0)
        if (poll(&lp, 1, 50) > 0)
            client = accept(p->listen_fd, NULL, NULL);
    if (client < 0)
        return NULL;
    int server = socket(AF_INET, SOCK_STREAM, 0);
    struct sockaddr_in a = { .sin_family = AF_INET, .sin_addr.s_addr = htonl(INADDR_LOOPBACK) };
    a.sin_port = htons((uint16_t)p->port);
    if (connect(server, (struct sockaddr *)&a, sizeof a) != 0) {
        close(client);
        close(server);
        return NULL;
    }
    char buf[65536];
    while (!atomic_load(&p->stop)) {
        if (atomic_load(&p->frozen)) {
            usleep(10000);
            continue;
        }
        struct pollfd fds[2] = { { .fd = client, .events = POLLIN }, { .fd = server, .events = POLLIN } };
        if (poll(fds, 2, 50) <= 0)
            continue;
        for (int i = 0; i < 2; i++) {
            if (!(fds[i].revents & (POLLIN | POLLHUP | POLLERR)))
                continue;
            ssize_t n = read(fds[i].fd, buf, sizeof buf);
            if (n <= 0)
                goto done;
            for (ssize_t at = 0; at < n;) {
                ssize_t w = write(fds[1 - i].fd, buf + at, (size_t)(n - at));
                if (w <= 0)
                    goto done;
                at += w;
            }
        }
    }
done:
    close(client);
    close(server);
    return NULL;
}

static void proxy_start(proxy *p, int server_port) {
    p->port = server_port;
    p->listen_fd = socket(AF_INET, SOCK_STREAM, 0);
    struct sockaddr_in a = { .sin_family = AF_INET, .sin_addr.s_addr = htonl(INADDR_LOOPBACK) };
    socklen_t len = sizeof a;
    bind(p->listen_fd, (struct sockaddr *)&a, sizeof a);
    listen(p->listen_fd, 4);
    getsockname(p->listen_fd, (struct sockaddr *)&a, &len);
    p->listen_port = ntohs(a.sin_port);
    pthread_create(&p->thread, NULL, proxy_main, p);
}

static void proxy_stop(proxy *p) {
    atomic_store(&p->stop, true);
    pthread_join(p->thread, NULL);
    close(p->listen_fd);
}

static void test_silent_peer(void) {
    echo_state st = { 0 };
    cv_rpc_server *server = start_echo(&st, 0, 0);
    proxy p = { 0 };
    proxy_start(&p, cv_rpc_server_port(server));
    char target[64];
    snprintf(target, sizeof target, "127.0.0.1:%d", p.listen_port);
    cv_rpc_client_config cfg = { .keepalive_ms = 500, .keepalive_timeout_ms = 500 };
    cv_rpc_client *c = NULL;
    CHECK_OK(cv_rpc_client_create(target, &cfg, &c));
    cv_rpc_stream *s = NULL;
    CHECK_OK(cv_rpc_client_open(c, ECHO, NULL, 0, &s));
    round_trip(s, "through the proxy");
    atomic_store(&p.frozen, true);
    double t0 = cv_now_ms() / 1e3;
    uint8_t *m = NULL;
    size_t n;
    CHECK_RESULT(cv_rpc_stream_recv(s, 10000, &m, &n), CV_ERROR_CONNECTION);
    double dt = cv_now_ms() / 1e3 - t0;
    if (dt > 3.0)
        fprintf(stderr, "silent peer noticed after %.2f s\n", dt);
    CHECK(dt < 3.0); /* keepalive 0.5 s + timeout 0.5 s, with slack */
    CHECK_RESULT(cv_rpc_stream_send(s, "x", 1), CV_ERROR_CONNECTION);
    cv_rpc_stream_destroy(s);
    cv_rpc_client_destroy(c);
    proxy_stop(&p); /* closes the server's side: its stream is cancelled */
    finish_server(server);
}

static const struct {
    const char *name;
    void (*fn)(void);
} tests[] = {
    { "small_messages", test_small_messages },
    { "large_messages", test_large_messages },
    { "over_limit", test_over_limit },
    { "server_error_status", test_server_error_status },
    { "metadata_and_peer", test_metadata_and_peer },
    { "concurrent_streams", test_concurrent_streams },
    { "open_and_drop", test_open_and_drop },
    { "server_killed", test_server_killed },
    { "nothing_listens", test_nothing_listens },
    { "drain", test_drain },
    { "max_streams", test_max_streams },
    { "unary", test_unary },
    { "recv_timeout", test_recv_timeout },
    { "silent_peer", test_silent_peer },
};

int main(int argc, char **argv) {
    for (size_t i = 0; i < sizeof tests / sizeof tests[0]; i++) {
        if (argc > 1 && strcmp(argv[1], tests[i].name) != 0)
            continue;
        int before = check_failures;
        double t0 = cv_now_ms() / 1e3;
        tests[i].fn();
        fprintf(stderr, "%-22s %s (%.2f s)\n", tests[i].name, check_failures == before ? "ok" : "FAILED",
                cv_now_ms() / 1e3 - t0);
    }
    return check_report("rpc");
}
