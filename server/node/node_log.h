/* corvid-node's log: every line the node writes about its sessions and callers
 * goes through node_log, which escapes it and hands it to the configured sink
 * (cv_node_config.log_sink), or by default to the process's log (corvid/log.h,
 * origin "node", level CV_LOG_INFO).
 *
 * Most of what the node logs comes from clients: Hello.client_name, resource and
 * pass labels, pipeline names, endpoints, peers' messages. Written raw, a
 * newline in one forges a log line and an escape sequence rewrites a terminal.
 * cv_log_escape makes any string one printable line: backslash becomes "\\",
 * newline, carriage return and tab "\n", "\r", "\t", every other control
 * character (C0, DEL, and the C1 range U+0080..U+009F) and every byte that is not
 * part of valid UTF-8 "\xNN". Valid UTF-8 text passes unchanged. The same helper
 * makes the messages the node sends back to clients valid UTF-8 (proto3 strings
 * must be).
 *
 * Refusals and request errors a client can trigger at will are rate-limited per
 * kind: at most NODE_LOG_BURST lines a second each, then one summary line,
 * "(K more <kind> lines suppressed)", when the next one of that kind comes after
 * the second, or when the node stops (node_log_flush).
 *
 *     node_log(node, NODE_LOG_ALWAYS, "session %" PRIu64 ": client '%s'", id, name);
 *     node_log(node, NODE_LOG_REQUEST_ERROR, "session %" PRIu64 ": request %" PRIu64 ": %s", id, seq, why);
 */
#ifndef CORVID_NODE_LOG_H
#define CORVID_NODE_LOG_H

#include <pthread.h>
#include <stddef.h>
#include <stdint.h>

typedef struct cv_node cv_node;

/* Escapes `in` (NUL-terminated) into out (cap bytes, always NUL-terminated when cap > 0); an escape is never
 * cut in half. Returns the length written. */
size_t cv_log_escape(char *out, size_t cap, const char *in);

typedef enum node_log_kind {
    NODE_LOG_ALWAYS,        /* session starts and ends, drain: never suppressed */
    NODE_LOG_REFUSED_CALL,  /* calls refused for their token */
    NODE_LOG_REQUEST_ERROR, /* requests answered with an error (quota refusals included) */
    NODE_LOG_PEER,          /* node-to-node transfers refused or not delivered */
    NODE_LOG_KIND_COUNT
} node_log_kind;

#define NODE_LOG_BURST 20u /* lines of one kind a second */

/* The rate limiter's state, one per node (in cv_node). */
typedef struct node_log_state {
    pthread_mutex_t lock;
    uint64_t window_start_ms[NODE_LOG_KIND_COUNT];
    uint32_t in_window[NODE_LOG_KIND_COUNT];
    uint64_t suppressed[NODE_LOG_KIND_COUNT];
} node_log_state;

void node_log_init(node_log_state *state);
void node_log_finish(node_log_state *state);

/* Formats, escapes and writes one line "corvid-node: <text>" when the node logs (config.log_sessions). */
void node_log(cv_node *node, node_log_kind kind, const char *fmt, ...) __attribute__((format(printf, 3, 4)));
/* Writes the summaries of lines still suppressed. */
void node_log_flush(cv_node *node);

#endif
