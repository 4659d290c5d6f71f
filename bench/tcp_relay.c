/* The delaying loopback relay of tcp_relay.h.
 *
 * Each connection is a pair of sockets (the accepted client, and ours to the
 * target) and two directions. A direction reads what arrives on one socket into
 * chunks stamped with the time they may leave (arrival + delay), queues them in
 * order, and writes them to the other socket once that time has come. One
 * ppoll() waits for readable sockets, blocked writes, the next release time and
 * the stop pipe. */
#include "tcp_relay.h"

#include <arpa/inet.h>
#include <errno.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#include "corvid/clock.h"

#define READ_BYTES (64u << 10)

typedef struct chunk {
    struct chunk *next;
    uint64_t release_ns;
    size_t len, off;
    uint8_t data[];
} chunk;

typedef struct direction {
    int from, to; /* indices into conn.fd */
    chunk *head, *tail;
    size_t queued;
    bool eof;     /* `from` said end of stream */
    bool shut;    /* passed on to `to` */
    bool blocked; /* a released chunk waits for `to` to take it */
} direction;

typedef struct conn {
    bool used;
    int fd[2];        /* 0: the accepted client; 1: ours to the target */
    direction dir[2]; /* 0: client -> target; 1: target -> client */
} conn;

struct tcp_relay {
    int listen_fd, wake[2];
    int port, target_port;
    _Atomic uint32_t delay_us;
    atomic_bool stop;
    atomic_bool stalled;
    pthread_t thread;
    pthread_mutex_t lock; /* stats */
    tcp_relay_stats stats;
    conn conns[TCP_RELAY_MAX_CONNECTIONS];
};

static void set_nonblocking(int fd) {
    int flags = fcntl(fd, F_GETFL);
    if (flags >= 0)
        fcntl(fd, F_SETFL, flags | O_NONBLOCK);
}

static void set_nodelay(int fd) {
    int one = 1;
    setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
}

static struct sockaddr_in loopback(int port) {
    struct sockaddr_in a;
    memset(&a, 0, sizeof a);
    a.sin_family = AF_INET;
    a.sin_port = htons((uint16_t)port);
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    return a;
}

static void close_conn(conn *c) {
    for (int d = 0; d < 2; d++) {
        for (chunk *k = c->dir[d].head, *next; k; k = next) {
            next = k->next;
            free(k);
        }
    }
    close(c->fd[0]);
    close(c->fd[1]);
    memset(c, 0, sizeof *c);
}

static void accept_one(tcp_relay *r) {
    int fd = accept4(r->listen_fd, NULL, NULL, SOCK_NONBLOCK | SOCK_CLOEXEC);
    if (fd < 0)
        return;
    conn *c = NULL;
    for (int i = 0; i < TCP_RELAY_MAX_CONNECTIONS && !c; i++)
        if (!r->conns[i].used)
            c = &r->conns[i];
    int up = c ? socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0) : -1;
    struct sockaddr_in target = loopback(r->target_port);
    if (up < 0 || connect(up, (struct sockaddr *)&target, sizeof target) != 0) { /* loopback: immediate */
        if (up >= 0)
            close(up);
        close(fd); /* the client sees the connection refused/closed */
        return;
    }
    set_nonblocking(up);
    set_nodelay(up);
    set_nodelay(fd);
    *c = (conn){ .used = true, .fd = { fd, up } };
    c->dir[0] = (direction){ .from = 0, .to = 1 };
    c->dir[1] = (direction){ .from = 1, .to = 0 };
    pthread_mutex_lock(&r->lock);
    r->stats.connections++;
    pthread_mutex_unlock(&r->lock);
}

/* Writes what is due; false on a socket error (the connection is closed then). */
static bool flush_dir(tcp_relay *r, conn *c, int d, uint64_t now) {
    direction *dir = &c->dir[d];
    dir->blocked = false;
    while (dir->head && dir->head->release_ns <= now) {
        chunk *k = dir->head;
        ssize_t n = send(c->fd[dir->to], k->data + k->off, k->len - k->off, MSG_NOSIGNAL | MSG_DONTWAIT);
        if (n < 0) {
            if (errno == EAGAIN || errno == EWOULDBLOCK) {
                dir->blocked = true;
                return true;
            }
            if (errno == EINTR)
                continue;
            return false;
        }
        k->off += (size_t)n;
        dir->queued -= (size_t)n;
        pthread_mutex_lock(&r->lock);
        if (d == 0)
            r->stats.bytes_to_target += (uint64_t)n;
        else
            r->stats.bytes_to_client += (uint64_t)n;
        pthread_mutex_unlock(&r->lock);
        if (k->off == k->len) {
            dir->head = k->next;
            if (!dir->head)
                dir->tail = NULL;
            free(k);
        }
    }
    if (!dir->head && dir->eof && !dir->shut) {
        shutdown(c->fd[dir->to], SHUT_WR);
        dir->shut = true;
    }
    return true;
}

/* Reads what arrived on the socket this direction reads; false on an error. */
static bool fill_dir(tcp_relay *r, conn *c, int d, uint8_t *buf) {
    direction *dir = &c->dir[d];
    while (!dir->eof && dir->queued < TCP_RELAY_QUEUE_BYTES) {
        ssize_t n = recv(c->fd[dir->from], buf, READ_BYTES, MSG_DONTWAIT);
        if (n < 0) {
            if (errno == EINTR)
                continue;
            return errno == EAGAIN || errno == EWOULDBLOCK;
        }
        if (n == 0) {
            dir->eof = true;
            return true;
        }
        chunk *k = malloc(sizeof(*k) + (size_t)n);
        if (!k)
            return false;
        k->next = NULL;
        k->release_ns = cv_now_ns() + (uint64_t)atomic_load(&r->delay_us) * 1000u;
        k->len = (size_t)n;
        k->off = 0;
        memcpy(k->data, buf, (size_t)n);
        if (dir->tail)
            dir->tail->next = k;
        else
            dir->head = k;
        dir->tail = k;
        dir->queued += (size_t)n;
        if ((size_t)n < READ_BYTES)
            return true; /* drained for now */
    }
    return true;
}

static void *relay_main(void *arg) {
    tcp_relay *r = arg;
    uint8_t *buf = malloc(READ_BYTES);
    struct pollfd pfd[2 + 2 * TCP_RELAY_MAX_CONNECTIONS];
    int owner[2 + 2 * TCP_RELAY_MAX_CONNECTIONS]; /* conn index * 2 + side, for pfd[2..] */
    while (buf && !atomic_load(&r->stop)) {
        if (atomic_load(&r->stalled)) { /* a black hole: nothing read, written or accepted */
            struct pollfd w = { .fd = r->wake[0], .events = POLLIN };
            if (poll(&w, 1, 20) > 0)
                break; /* stop */
            continue;
        }
        uint64_t now = cv_now_ns();
        uint64_t next_release = UINT64_MAX;
        nfds_t n = 0;
        pfd[n++] = (struct pollfd){ .fd = r->wake[0], .events = POLLIN };
        pfd[n++] = (struct pollfd){ .fd = r->listen_fd, .events = POLLIN };
        for (int i = 0; i < TCP_RELAY_MAX_CONNECTIONS; i++) {
            conn *c = &r->conns[i];
            if (!c->used)
                continue;
            if (!flush_dir(r, c, 0, now) || !flush_dir(r, c, 1, now) || (c->dir[0].shut && c->dir[1].shut)) {
                close_conn(c);
                continue;
            }
            for (int side = 0; side < 2; side++) {
                short events = 0;
                /* side is read by the direction side (from == side) and written by 1 - side. */
                const direction *in = &c->dir[side], *out = &c->dir[1 - side];
                if (!in->eof && in->queued < TCP_RELAY_QUEUE_BYTES)
                    events |= POLLIN;
                if (out->blocked)
                    events |= POLLOUT;
                owner[n] = i * 2 + side;
                /* Nothing wanted: leave it out, or a hung-up socket would wake us again and again. */
                pfd[n++] = (struct pollfd){ .fd = events ? c->fd[side] : -1, .events = events };
            }
            for (int d = 0; d < 2; d++)
                if (c->dir[d].head && !c->dir[d].blocked && c->dir[d].head->release_ns < next_release)
                    next_release = c->dir[d].head->release_ns;
        }
        struct timespec timeout, *tp = NULL;
        if (next_release != UINT64_MAX) {
            uint64_t wait = next_release > now ? next_release - now : 0;
            timeout = (struct timespec){ (time_t)(wait / 1000000000ull), (long)(wait % 1000000000ull) };
            tp = &timeout;
        }
        int ready = ppoll(pfd, n, tp, NULL);
        if (ready < 0) {
            if (errno == EINTR)
                continue;
            perror("tcp_relay: ppoll");
            break;
        }
        if (pfd[0].revents)
            break; /* stop */
        if (pfd[1].revents & POLLIN)
            accept_one(r);
        for (nfds_t p = 2; p < n; p++) {
            if (!pfd[p].revents)
                continue;
            conn *c = &r->conns[owner[p] / 2];
            int side = owner[p] % 2;
            if (!c->used)
                continue; /* closed earlier in this pass */
            bool ok = true;
            if (pfd[p].revents & (POLLIN | POLLHUP | POLLERR))
                ok = fill_dir(r, c, side, buf); /* the direction that reads `side` has index side */
            if (ok && (pfd[p].revents & POLLERR) && c->dir[side].eof == false)
                ok = false;
            if (!ok)
                close_conn(c);
        }
    }
    for (int i = 0; i < TCP_RELAY_MAX_CONNECTIONS; i++)
        if (r->conns[i].used)
            close_conn(&r->conns[i]);
    free(buf);
    return NULL;
}

int tcp_relay_start(int target_port, uint32_t delay_us, tcp_relay **out) {
    *out = NULL;
    if (target_port <= 0 || target_port > 65535) {
        fprintf(stderr, "tcp_relay: bad target port %d\n", target_port);
        return -1;
    }
    tcp_relay *r = calloc(1, sizeof *r);
    if (!r)
        return -1;
    r->target_port = target_port;
    atomic_store(&r->delay_us, delay_us);
    pthread_mutex_init(&r->lock, NULL);
    r->listen_fd = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
    struct sockaddr_in a = loopback(0);
    socklen_t len = sizeof a;
    if (r->listen_fd < 0 || bind(r->listen_fd, (struct sockaddr *)&a, sizeof a) != 0 ||
        listen(r->listen_fd, 16) != 0 || getsockname(r->listen_fd, (struct sockaddr *)&a, &len) != 0 ||
        pipe2(r->wake, O_CLOEXEC) != 0) {
        perror("tcp_relay: listen on 127.0.0.1");
        if (r->listen_fd >= 0)
            close(r->listen_fd);
        free(r);
        return -1;
    }
    r->port = ntohs(a.sin_port);
    if (pthread_create(&r->thread, NULL, relay_main, r) != 0) {
        fprintf(stderr, "tcp_relay: no thread\n");
        close(r->listen_fd);
        close(r->wake[0]);
        close(r->wake[1]);
        free(r);
        return -1;
    }
    *out = r;
    return 0;
}

int tcp_relay_port(const tcp_relay *r) { return r->port; }

void tcp_relay_set_delay(tcp_relay *r, uint32_t delay_us) { atomic_store(&r->delay_us, delay_us); }

void tcp_relay_set_stall(tcp_relay *r, bool stall) { atomic_store(&r->stalled, stall); }

tcp_relay_stats tcp_relay_get_stats(tcp_relay *r) {
    pthread_mutex_lock(&r->lock);
    tcp_relay_stats s = r->stats;
    pthread_mutex_unlock(&r->lock);
    return s;
}

void tcp_relay_stop(tcp_relay *r) {
    if (!r)
        return;
    atomic_store(&r->stop, true);
    char one = 1;
    if (write(r->wake[1], &one, 1) != 1)
        perror("tcp_relay: wake");
    pthread_join(r->thread, NULL);
    close(r->listen_fd);
    close(r->wake[0]);
    close(r->wake[1]);
    pthread_mutex_destroy(&r->lock);
    free(r);
}
