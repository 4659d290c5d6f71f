/* A delaying TCP relay on loopback, for benchmarks: it accepts on
 * 127.0.0.1:<free port> and forwards every connection to 127.0.0.1:<target>,
 * holding the bytes of each direction for `delay_us` before passing them on, so
 * a round trip through it takes 2 * delay_us longer. Bandwidth is not limited.
 * A stall switch (tcp_relay_set_stall) makes it stop forwarding altogether:
 * tests of a node whose network goes silent.
 *
 *     tcp_relay *relay;
 *     if (tcp_relay_start(node_port, 10000, &relay) == 0) {       // +20 ms round trip
 *         snprintf(endpoint, sizeof endpoint, "127.0.0.1:%d", tcp_relay_port(relay));
 *         ...
 *         tcp_relay_stop(relay);
 *     }
 *
 * Only loopback: it listens on 127.0.0.1 and connects to 127.0.0.1, nothing else.
 * One thread, poll()-based. Memory is bounded: each direction of a connection
 * holds at most TCP_RELAY_QUEUE_BYTES; above that it stops reading from that
 * side (TCP's flow control pushes back on the sender). At most
 * TCP_RELAY_MAX_CONNECTIONS connections at once; more are refused (closed).
 * A half-close is passed on after the bytes before it; an error on either side
 * closes both. tcp_relay_stop closes everything and joins the thread. */
#ifndef CORVID_BENCH_TCP_RELAY_H
#define CORVID_BENCH_TCP_RELAY_H

#include <stdbool.h>
#include <stdint.h>

#define TCP_RELAY_MAX_CONNECTIONS 32
#define TCP_RELAY_QUEUE_BYTES (16u << 20)

typedef struct tcp_relay tcp_relay;

typedef struct tcp_relay_stats {
    uint64_t connections; /* accepted, in all */
    uint64_t bytes_to_target, bytes_to_client;
} tcp_relay_stats;

/* 0 on success; -1 with errno-style reason on stderr otherwise. */
int tcp_relay_start(int target_port, uint32_t delay_us, tcp_relay **out);
int tcp_relay_port(const tcp_relay *r);
/* Applies to bytes received from now on. */
void tcp_relay_set_delay(tcp_relay *r, uint32_t delay_us);
/* Stalled: the relay forwards nothing, reads nothing and accepts nothing (connections stay open), as a
 * network that stops delivering does; within about 20 ms of the next byte or of the call. */
void tcp_relay_set_stall(tcp_relay *r, bool stall);
tcp_relay_stats tcp_relay_get_stats(tcp_relay *r);
/* Closes every connection and the listener, joins the thread, frees. NULL is ignored. */
void tcp_relay_stop(tcp_relay *r);

#endif
