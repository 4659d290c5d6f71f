/* A TCP relay that behaves like a network link, for benchmarks, tests and manual trials
 * (corvid-relay): it accepts connections on one address and forwards each to a target,
 * holding the bytes of each direction for a one-way delay and releasing at most a capped
 * number of bytes per second, so latency and bandwidth compose as on a real link: a chunk
 * of n bytes read at time a leaves at
 *
 *     start = max(a, when the direction's link is free);  link free again at start + n / rate
 *     release = start + n / rate + delay
 *
 * (serialisation, then propagation). A stall switch (tcp_relay_set_stall) makes it stop
 * forwarding altogether: tests of a node whose network goes silent.
 *
 *     tcp_relay *relay;
 *     tcp_relay_desc desc = { .target_port = node_port, .delay_us = 10000,   // +20 ms round trip
 *                             .rate_bytes_per_s = 100000000 / 8 };          // 100 Mbit/s
 *     if (tcp_relay_create(&desc, &relay) == CV_OK) {
 *         snprintf(endpoint, sizeof endpoint, "127.0.0.1:%d", tcp_relay_port(relay));
 *         ...
 *         tcp_relay_stop(relay);
 *     }
 *
 * One thread, poll()-based; connections to the target are made without blocking it.
 * Memory is bounded: each direction of a connection holds at most its queue limit (16 MiB
 * without a rate; with one, what the link carries in the delay plus TCP_RELAY_BUFFER_MS, at
 * least 64 KiB, as a router's buffer); above that it stops reading from that side (TCP's
 * flow control pushes back on the sender). On a capped link the kernel's receive buffers of
 * the relay's sockets are kept to that size too, so they add no hidden queue of their own. At most TCP_RELAY_MAX_CONNECTIONS connections at
 * once; more are refused (closed). A half-close is passed on after the bytes before it; an
 * error on either side closes both. tcp_relay_stop closes everything and joins the thread. */
#ifndef CORVID_TOOLS_TCP_RELAY_H
#define CORVID_TOOLS_TCP_RELAY_H

#include <stdbool.h>
#include <stdint.h>

#include "corvid/result.h"

#define TCP_RELAY_MAX_CONNECTIONS 32
#define TCP_RELAY_QUEUE_BYTES (16u << 20)
#define TCP_RELAY_BUFFER_MS 50u

typedef struct tcp_relay tcp_relay;

typedef struct tcp_relay_desc {
    const char *listen_host; /* name or address to listen on; NULL = "127.0.0.1" */
    uint16_t listen_port;    /* 0 = a free port (tcp_relay_port says which) */
    const char *target_host; /* NULL = "127.0.0.1" */
    uint16_t target_port;
    uint32_t delay_us;         /* one way, each direction */
    uint64_t rate_bytes_per_s; /* each direction; 0 = no cap */
} tcp_relay_desc;

typedef struct tcp_relay_stats {
    uint64_t connections; /* accepted, in all */
    uint64_t bytes_to_target, bytes_to_client;
} tcp_relay_stats;

/* Resolves both addresses, listens and starts the thread. An error names the address. */
cv_result tcp_relay_create(const tcp_relay_desc *desc, tcp_relay **out);
/* Loopback to loopback without a cap: 0 on success; -1, logged (corvid/log.h), otherwise. */
int tcp_relay_start(int target_port, uint32_t delay_us, tcp_relay **out);
int tcp_relay_port(const tcp_relay *r);
/* Apply to bytes received from now on. */
void tcp_relay_set_delay(tcp_relay *r, uint32_t delay_us);
void tcp_relay_set_rate(tcp_relay *r, uint64_t rate_bytes_per_s);
/* Stalled: the relay forwards nothing, reads nothing and accepts nothing (connections stay open), as a
 * network that stops delivering does; within about 20 ms of the next byte or of the call. */
void tcp_relay_set_stall(tcp_relay *r, bool stall);
tcp_relay_stats tcp_relay_get_stats(tcp_relay *r);
/* Closes every connection and the listener, joins the thread, frees. NULL is ignored. */
void tcp_relay_stop(tcp_relay *r);

#endif
