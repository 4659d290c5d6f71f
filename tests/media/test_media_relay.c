/* The link-like relay (tools/relay/tcp_relay.h): 2 MiB each way through a 20 Mbit/s,
 * 20 ms relay to an echo server arrive intact and no sooner than the link allows: at least
 * 2 x (bytes / rate + delay). Only that lower bound on time is checked (it holds on any
 * machine); how much longer a loaded machine takes is not. A target that refuses the
 * connection closes the client's; a bad target is refused at creation. */
#include <netinet/in.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <unistd.h>

#include "check.h"
#include "corvid/clock.h"
#include "tcp_relay.h"

#define BYTES (2u << 20)
#define RATE_BYTES_PER_S (20000000u / 8u)
#define DELAY_US 20000u

typedef struct echo_server {
    int listen_fd;
    uint16_t port;
    pthread_t thread;
    size_t received;
} echo_server;

/* Reads everything until the client's half-close, then sends it all back and closes. */
static void *echo_main(void *arg) {
    echo_server *s = arg;
    int fd = accept(s->listen_fd, NULL, NULL);
    uint8_t *data = malloc(BYTES + 1);
    ssize_t n = 0;
    while (fd >= 0 && data && s->received <= BYTES &&
           (n = recv(fd, data + s->received, BYTES + 1 - s->received, 0)) > 0)
        s->received += (size_t)n;
    for (size_t sent = 0; fd >= 0 && data && sent < s->received;) {
        ssize_t k = send(fd, data + sent, s->received - sent, MSG_NOSIGNAL);
        if (k <= 0)
            break;
        sent += (size_t)k;
    }
    if (fd >= 0)
        close(fd);
    free(data);
    return NULL;
}

static bool echo_start(echo_server *s) {
    *s = (echo_server){ .listen_fd = socket(AF_INET, SOCK_STREAM, 0) };
    struct sockaddr_in a = { .sin_family = AF_INET, .sin_addr.s_addr = htonl(INADDR_LOOPBACK) };
    socklen_t len = sizeof a;
    if (s->listen_fd < 0 || bind(s->listen_fd, (struct sockaddr *)&a, sizeof a) != 0 ||
        listen(s->listen_fd, 1) != 0 || getsockname(s->listen_fd, (struct sockaddr *)&a, &len) != 0)
        return false;
    s->port = ntohs(a.sin_port);
    return pthread_create(&s->thread, NULL, echo_main, s) == 0;
}

static int connect_to(int port) {
    int fd = socket(AF_INET, SOCK_STREAM, 0);
    struct sockaddr_in a = { .sin_family = AF_INET,
                             .sin_port = htons((uint16_t)port),
                             .sin_addr.s_addr = htonl(INADDR_LOOPBACK) };
    if (fd >= 0 && connect(fd, (struct sockaddr *)&a, sizeof a) != 0) {
        close(fd);
        return -1;
    }
    return fd;
}

typedef struct sender {
    int fd;
    const uint8_t *data;
    bool ok;
} sender;

static void *send_all(void *arg) {
    sender *s = arg;
    size_t sent = 0;
    while (sent < BYTES) {
        ssize_t k = send(s->fd, s->data + sent, BYTES - sent, MSG_NOSIGNAL);
        if (k <= 0)
            break;
        sent += (size_t)k;
    }
    shutdown(s->fd, SHUT_WR);
    s->ok = sent == BYTES;
    return NULL;
}

static void test_capped_link(void) {
    echo_server server;
    CHECK(echo_start(&server));
    tcp_relay *relay = NULL;
    tcp_relay_desc desc = { .target_port = server.port, .delay_us = DELAY_US, .rate_bytes_per_s = RATE_BYTES_PER_S };
    CHECK_OK(tcp_relay_create(&desc, &relay));
    uint8_t *data = malloc(BYTES), *back = malloc(BYTES + 1);
    for (size_t i = 0; i < BYTES; i++)
        data[i] = (uint8_t)(i * 7u + (i >> 11));
    int fd = relay ? connect_to(tcp_relay_port(relay)) : -1;
    CHECK(fd >= 0);
    double start = cv_now_ms();
    sender s = { .fd = fd, .data = data };
    pthread_t sending;
    CHECK_EQ_INT(pthread_create(&sending, NULL, send_all, &s), 0);
    size_t got = 0;
    ssize_t n;
    while (fd >= 0 && got <= BYTES && (n = recv(fd, back + got, BYTES + 1 - got, 0)) > 0)
        got += (size_t)n;
    double elapsed_ms = cv_now_ms() - start;
    pthread_join(sending, NULL);
    CHECK(s.ok);
    CHECK_EQ_INT(got, BYTES);
    CHECK(memcmp(back, data, BYTES) == 0);
    double bound_ms = 2.0 * ((double)BYTES * 1e3 / RATE_BYTES_PER_S + DELAY_US / 1e3);
    printf("2 x %u bytes through 20 Mbit/s + 20 ms each way: %.0f ms (the link allows no less than %.0f ms)\n", BYTES,
           elapsed_ms, bound_ms);
    CHECK(elapsed_ms >= bound_ms);
    if (fd >= 0)
        close(fd);
    pthread_join(server.thread, NULL);
    CHECK_EQ_INT(server.received, BYTES);
    tcp_relay_stats st = relay ? tcp_relay_get_stats(relay) : (tcp_relay_stats){ 0 };
    CHECK(st.connections == 1 && st.bytes_to_target == BYTES && st.bytes_to_client == BYTES);
    tcp_relay_stop(relay);
    close(server.listen_fd);
    free(data);
    free(back);
}

static void test_refusals(void) {
    tcp_relay *relay = (tcp_relay *)1;
    CHECK_RESULT(tcp_relay_create(&(tcp_relay_desc){ .target_port = 0 }, &relay), CV_ERROR_INVALID_ARGUMENT);
    CHECK(relay == NULL);
    CHECK_RESULT(tcp_relay_create(&(tcp_relay_desc){ .target_host = "no-such-host.invalid", .target_port = 9 },
                                  &relay),
                 CV_ERROR_NOT_FOUND);
    CHECK(strstr(cv_last_error(), "no-such-host.invalid:9"));
    /* A target nobody listens on: the client's connection is closed, not left hanging. */
    echo_server closed;
    CHECK(echo_start(&closed));
    int dead_port = closed.port;
    int poke = connect_to(dead_port); /* lets the echo thread finish */
    if (poke >= 0) {
        shutdown(poke, SHUT_WR);
        close(poke);
    }
    pthread_join(closed.thread, NULL);
    close(closed.listen_fd);
    CHECK_OK(tcp_relay_create(&(tcp_relay_desc){ .target_port = (uint16_t)dead_port }, &relay));
    int fd = relay ? connect_to(tcp_relay_port(relay)) : -1;
    uint8_t byte;
    CHECK(fd >= 0 && recv(fd, &byte, 1, 0) <= 0);
    if (fd >= 0)
        close(fd);
    tcp_relay_stop(relay);
}

int main(void) {
    test_capped_link();
    test_refusals();
    CHECK_NOTHING_LIVE();
    return check_report("test_media_relay");
}
