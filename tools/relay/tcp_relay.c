/* The relay of tcp_relay.h.
 *
 * Each connection is a pair of sockets (the accepted client, and ours to the target) and
 * two directions. A direction reads what arrives on one socket into chunks stamped with the
 * time they may leave (the link model of tcp_relay.h), queues them in order, and writes
 * them to the other socket once that time has come. One ppoll() waits for readable
 * sockets, blocked writes, connections to the target being made, the next release time
 * and the stop pipe. */
#include "tcp_relay.h"

#include <errno.h>
#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#include "corvid/clock.h"
#include "corvid/log.h"

#define READ_BYTES (64u << 10)
#define MIN_CAPPED_QUEUE (64u << 10)

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
    uint64_t link_free_ns; /* when the capped link has sent what is queued (before the delay) */
    bool eof;              /* `from` said end of stream */
    bool shut;             /* passed on to `to` */
    bool blocked;          /* a released chunk waits for `to` to take it */
} direction;

typedef struct conn {
    bool used;
    bool connecting;  /* ours to the target is not connected yet */
    int fd[2];        /* 0: the accepted client; 1: ours to the target */
    direction dir[2]; /* 0: client -> target; 1: target -> client */
} conn;

struct tcp_relay {
    int listen_fd, wake[2];
    int port;
    struct sockaddr_storage target;
    socklen_t target_len;
    _Atomic uint32_t delay_us;
    _Atomic uint64_t rate;
    atomic_bool stop;
    atomic_bool stalled;
    pthread_t thread;
    pthread_mutex_t lock; /* stats */
    tcp_relay_stats stats;
    conn conns[TCP_RELAY_MAX_CONNECTIONS];
};

static void set_nodelay(int fd) {
    int one = 1;
    setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
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

/* The most bytes a direction holds: a router's buffer on a capped link (what it carries in the
 * delay plus TCP_RELAY_BUFFER_MS), a large fixed bound on an uncapped one. */
static size_t queue_limit(const tcp_relay *r) {
    uint64_t rate = atomic_load(&r->rate);
    if (rate == 0)
        return TCP_RELAY_QUEUE_BYTES;
    uint64_t us = (uint64_t)atomic_load(&r->delay_us) + TCP_RELAY_BUFFER_MS * 1000u;
    uint64_t bytes = rate / 1000u * us / 1000u;
    return bytes < MIN_CAPPED_QUEUE        ? MIN_CAPPED_QUEUE
           : bytes > TCP_RELAY_QUEUE_BYTES ? TCP_RELAY_QUEUE_BYTES
                                           : (size_t)bytes;
}

/* On a capped link, the kernel's receive buffer of a socket the relay reads is kept to the
 * queue's size: left to grow (to megabytes on loopback), it would be a second, unbounded
 * queue in front of the link, holding bytes the model never sees. */
static void bound_receive_buffer(const tcp_relay *r, int fd) {
    if (atomic_load(&r->rate) == 0)
        return;
    int bytes = (int)queue_limit(r);
    setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &bytes, sizeof bytes);
}

static void accept_one(tcp_relay *r) {
    int fd = accept4(r->listen_fd, NULL, NULL, SOCK_NONBLOCK | SOCK_CLOEXEC);
    if (fd < 0)
        return;
    conn *c = NULL;
    for (int i = 0; i < TCP_RELAY_MAX_CONNECTIONS && !c; i++)
        if (!r->conns[i].used)
            c = &r->conns[i];
    int up = c ? socket(r->target.ss_family, SOCK_STREAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0) : -1;
    if (up >= 0)
        bound_receive_buffer(r, up); /* before connect: the window it offers follows */
    int rc = up >= 0 ? connect(up, (struct sockaddr *)&r->target, r->target_len) : -1;
    if (up < 0 || (rc != 0 && errno != EINPROGRESS)) {
        if (up >= 0)
            close(up);
        close(fd); /* the client sees the connection closed */
        return;
    }
    set_nodelay(up);
    set_nodelay(fd);
    bound_receive_buffer(r, fd);
    *c = (conn){ .used = true, .connecting = rc != 0, .fd = { fd, up } };
    c->dir[0] = (direction){ .from = 0, .to = 1 };
    c->dir[1] = (direction){ .from = 1, .to = 0 };
    pthread_mutex_lock(&r->lock);
    r->stats.connections++;
    pthread_mutex_unlock(&r->lock);
}

/* The connection to the target is made (true) or failed (false). */
static bool finish_connect(conn *c) {
    int error = 0;
    socklen_t len = sizeof error;
    if (getsockopt(c->fd[1], SOL_SOCKET, SO_ERROR, &error, &len) != 0 || error != 0)
        return false;
    c->connecting = false;
    return true;
}

/* Writes what is due; false on a socket error (the connection is closed then). */
static bool flush_dir(tcp_relay *r, conn *c, int d, uint64_t now) {
    direction *dir = &c->dir[d];
    dir->blocked = false;
    if (c->connecting)
        return true;
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

/* Queues n bytes that arrived now, stamped with when the link model lets them leave. */
static bool enqueue(tcp_relay *r, direction *dir, const uint8_t *bytes, size_t n) {
    chunk *k = malloc(sizeof(*k) + n);
    if (!k)
        return false;
    uint64_t now = cv_now_ns(), rate = atomic_load(&r->rate);
    uint64_t sent = now;
    if (rate) {
        uint64_t start = dir->link_free_ns > now ? dir->link_free_ns : now;
        sent = start + ((uint64_t)n * 1000000000u + rate - 1) / rate; /* serialised, rounded up */
        dir->link_free_ns = sent;
    }
    *k = (chunk){ .release_ns = sent + (uint64_t)atomic_load(&r->delay_us) * 1000u, .len = n };
    memcpy(k->data, bytes, n);
    if (dir->tail)
        dir->tail->next = k;
    else
        dir->head = k;
    dir->tail = k;
    dir->queued += n;
    return true;
}

/* Reads what arrived on the socket this direction reads; false on an error. */
static bool fill_dir(tcp_relay *r, conn *c, int d, uint8_t *buf) {
    direction *dir = &c->dir[d];
    size_t limit = queue_limit(r);
    while (!dir->eof && dir->queued < limit) {
        size_t room = limit - dir->queued < READ_BYTES ? limit - dir->queued : READ_BYTES;
        ssize_t n = recv(c->fd[dir->from], buf, room, MSG_DONTWAIT);
        if (n < 0) {
            if (errno == EINTR)
                continue;
            return errno == EAGAIN || errno == EWOULDBLOCK;
        }
        if (n == 0) {
            dir->eof = true;
            return true;
        }
        if (!enqueue(r, dir, buf, (size_t)n))
            return false;
        if ((size_t)n < room)
            return true; /* drained for now */
    }
    return true;
}

typedef struct poll_set {
    struct pollfd pfd[2 + 2 * TCP_RELAY_MAX_CONNECTIONS];
    int owner[2 + 2 * TCP_RELAY_MAX_CONNECTIONS]; /* conn index * 2 + side, for pfd[2..] */
    nfds_t n;
    uint64_t next_release; /* UINT64_MAX: none */
} poll_set;

/* Sends what is due and lists what to wait for. */
static void build_poll_set(tcp_relay *r, uint64_t now, poll_set *ps) {
    ps->n = 0;
    ps->next_release = UINT64_MAX;
    ps->pfd[ps->n++] = (struct pollfd){ .fd = r->wake[0], .events = POLLIN };
    ps->pfd[ps->n++] = (struct pollfd){ .fd = r->listen_fd, .events = POLLIN };
    size_t limit = queue_limit(r);
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
            if (!in->eof && in->queued < limit && !(side == 1 && c->connecting))
                events |= POLLIN;
            if (out->blocked || (side == 1 && c->connecting))
                events |= POLLOUT;
            ps->owner[ps->n] = i * 2 + side;
            /* Nothing wanted: leave it out, or a hung-up socket would wake us again and again. */
            ps->pfd[ps->n++] = (struct pollfd){ .fd = events ? c->fd[side] : -1, .events = events };
        }
        for (int d = 0; d < 2; d++)
            if (c->dir[d].head && !c->dir[d].blocked && c->dir[d].head->release_ns < ps->next_release)
                ps->next_release = c->dir[d].head->release_ns;
    }
}

static void handle_events(tcp_relay *r, const poll_set *ps, uint8_t *buf) {
    if (ps->pfd[1].revents & POLLIN)
        accept_one(r);
    for (nfds_t p = 2; p < ps->n; p++) {
        short revents = ps->pfd[p].revents;
        if (!revents)
            continue;
        conn *c = &r->conns[ps->owner[p] / 2];
        int side = ps->owner[p] % 2;
        if (!c->used)
            continue; /* closed earlier in this pass */
        bool ok = true;
        if (side == 1 && c->connecting)
            ok = finish_connect(c);
        else if (revents & (POLLIN | POLLHUP | POLLERR))
            ok = fill_dir(r, c, side, buf); /* the direction that reads `side` has index side */
        if (ok && (revents & POLLERR) && c->dir[side].eof == false)
            ok = false;
        if (!ok)
            close_conn(c);
    }
}

static void *relay_main(void *arg) {
    tcp_relay *r = arg;
    uint8_t *buf = malloc(READ_BYTES);
    poll_set *ps = malloc(sizeof *ps);
    while (buf && ps && !atomic_load(&r->stop)) {
        if (atomic_load(&r->stalled)) { /* a black hole: nothing read, written or accepted */
            struct pollfd w = { .fd = r->wake[0], .events = POLLIN };
            if (poll(&w, 1, 20) > 0)
                break; /* stop */
            continue;
        }
        uint64_t now = cv_now_ns();
        build_poll_set(r, now, ps);
        struct timespec timeout, *tp = NULL;
        if (ps->next_release != UINT64_MAX) {
            uint64_t wait = ps->next_release > now ? ps->next_release - now : 0;
            timeout = (struct timespec){ (time_t)(wait / 1000000000ull), (long)(wait % 1000000000ull) };
            tp = &timeout;
        }
        int ready = ppoll(ps->pfd, ps->n, tp, NULL);
        if (ready < 0) {
            if (errno == EINTR)
                continue;
            cv_log(CV_LOG_ERROR, "relay", "ppoll: %s; the relay stops forwarding", strerror(errno));
            break;
        }
        if (ps->pfd[0].revents)
            break; /* stop */
        handle_events(r, ps, buf);
    }
    for (int i = 0; i < TCP_RELAY_MAX_CONNECTIONS; i++)
        if (r->conns[i].used)
            close_conn(&r->conns[i]);
    free(ps);
    free(buf);
    return NULL;
}

/* host:port to one address (the first the resolver gives). */
static cv_result resolve(const char *what, const char *host, uint16_t port, bool passive,
                         struct sockaddr_storage *out, socklen_t *len) {
    char service[8];
    snprintf(service, sizeof service, "%u", port);
    struct addrinfo hints = { .ai_socktype = SOCK_STREAM, .ai_flags = passive ? AI_PASSIVE : 0 }, *list = NULL;
    int rc = getaddrinfo(host, service, &hints, &list);
    if (rc != 0 || !list)
        return cv_error(CV_ERROR_NOT_FOUND, "relay: %s %s:%u: %s", what, host, port,
                        rc ? gai_strerror(rc) : "no address");
    memcpy(out, list->ai_addr, list->ai_addrlen);
    *len = list->ai_addrlen;
    freeaddrinfo(list);
    return CV_OK;
}

static cv_result listen_on(tcp_relay *r, const char *host, uint16_t port) {
    struct sockaddr_storage a;
    socklen_t len = 0;
    cv_result res = resolve("listen address", host, port, true, &a, &len);
    if (res != CV_OK)
        return res;
    r->listen_fd = socket(a.ss_family, SOCK_STREAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
    int one = 1;
    if (r->listen_fd >= 0) {
        setsockopt(r->listen_fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
        bound_receive_buffer(r, r->listen_fd); /* accepted sockets start with it */
    }
    if (r->listen_fd < 0 || bind(r->listen_fd, (struct sockaddr *)&a, len) != 0 || listen(r->listen_fd, 16) != 0 ||
        getsockname(r->listen_fd, (struct sockaddr *)&a, &len) != 0)
        return cv_error(CV_ERROR_IO, "relay: listen on %s:%u: %s", host, port, strerror(errno));
    r->port = ntohs(a.ss_family == AF_INET6 ? ((struct sockaddr_in6 *)&a)->sin6_port
                                            : ((struct sockaddr_in *)&a)->sin_port);
    return CV_OK;
}

cv_result tcp_relay_create(const tcp_relay_desc *desc, tcp_relay **out) {
    if (!out || !desc)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "relay: desc or out is NULL");
    *out = NULL;
    const char *target_host = desc->target_host ? desc->target_host : "127.0.0.1";
    if (desc->target_port == 0)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "relay: target %s has port 0", target_host);
    tcp_relay *r = calloc(1, sizeof *r);
    if (!r)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "relay: no memory");
    r->listen_fd = r->wake[0] = r->wake[1] = -1;
    atomic_store(&r->delay_us, desc->delay_us);
    atomic_store(&r->rate, desc->rate_bytes_per_s);
    pthread_mutex_init(&r->lock, NULL);
    cv_result res = resolve("target", target_host, desc->target_port, false, &r->target, &r->target_len);
    if (res == CV_OK)
        res = listen_on(r, desc->listen_host ? desc->listen_host : "127.0.0.1", desc->listen_port);
    if (res == CV_OK && pipe2(r->wake, O_CLOEXEC) != 0)
        res = cv_error(CV_ERROR_IO, "relay: pipe: %s", strerror(errno));
    if (res == CV_OK && pthread_create(&r->thread, NULL, relay_main, r) != 0)
        res = cv_error(CV_ERROR_OUT_OF_MEMORY, "relay: no thread");
    if (res != CV_OK) {
        if (r->listen_fd >= 0)
            close(r->listen_fd);
        if (r->wake[0] >= 0) {
            close(r->wake[0]);
            close(r->wake[1]);
        }
        pthread_mutex_destroy(&r->lock);
        free(r);
        return res;
    }
    *out = r;
    return CV_OK;
}

int tcp_relay_start(int target_port, uint32_t delay_us, tcp_relay **out) {
    *out = NULL;
    if (target_port <= 0 || target_port > 65535) {
        cv_log(CV_LOG_ERROR, "relay", "bad target port %d", target_port);
        return -1;
    }
    tcp_relay_desc desc = { .target_port = (uint16_t)target_port, .delay_us = delay_us };
    if (tcp_relay_create(&desc, out) != CV_OK) {
        cv_log(CV_LOG_ERROR, "relay", "%s", cv_last_error());
        return -1;
    }
    return 0;
}

int tcp_relay_port(const tcp_relay *r) { return r->port; }

void tcp_relay_set_delay(tcp_relay *r, uint32_t delay_us) { atomic_store(&r->delay_us, delay_us); }

void tcp_relay_set_rate(tcp_relay *r, uint64_t rate_bytes_per_s) { atomic_store(&r->rate, rate_bytes_per_s); }

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
        cv_log(CV_LOG_ERROR, "relay", "wake: %s", strerror(errno));
    pthread_join(r->thread, NULL);
    close(r->listen_fd);
    close(r->wake[0]);
    close(r->wake[1]);
    pthread_mutex_destroy(&r->lock);
    free(r);
}
