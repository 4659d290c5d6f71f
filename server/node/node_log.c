/* corvid-node's log (node_log.h): escaping, the sink, and the per-kind rate limit. */
#include "node_log.h"

#include <inttypes.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stdio.h>
#include <string.h>

#include "corvid/clock.h"
#include "corvid/log.h"
#include "node_internal.h"

/* The longest escaped text of a line: every byte of a 1023-byte message may take 4. */
#define NODE_LOG_LINE_MAX (4 * 1024)

static const char *const kind_names[NODE_LOG_KIND_COUNT] = {
    [NODE_LOG_ALWAYS] = "log",
    [NODE_LOG_REFUSED_CALL] = "refused-call",
    [NODE_LOG_REQUEST_ERROR] = "request-error",
    [NODE_LOG_PEER] = "peer",
};

/* The length of the valid UTF-8 sequence at p (1..4), or 0 if the bytes there are not one (overlong forms,
 * surrogates and code points past U+10FFFF included). */
static size_t utf8_length(const unsigned char *p) {
    unsigned char c = p[0];
    unsigned char lo = 0x80, hi = 0xbf;
    size_t n;
    if (c >= 0xc2 && c <= 0xdf)
        n = 2;
    else if (c >= 0xe0 && c <= 0xef) {
        n = 3;
        lo = c == 0xe0 ? 0xa0 : 0x80;
        hi = c == 0xed ? 0x9f : 0xbf;
    } else if (c >= 0xf0 && c <= 0xf4) {
        n = 4;
        lo = c == 0xf0 ? 0x90 : 0x80;
        hi = c == 0xf4 ? 0x8f : 0xbf;
    } else
        return 0;
    if (p[1] < lo || p[1] > hi)
        return 0;
    for (size_t i = 2; i < n; i++)
        if (p[i] < 0x80 || p[i] > 0xbf)
            return 0;
    return n;
}

size_t cv_log_escape(char *out, size_t cap, const char *in) {
    if (!cap)
        return 0;
    size_t at = 0;
    const unsigned char *p = (const unsigned char *)(in ? in : "");
    while (*p) {
        char piece[16];
        size_t len, take = 1;
        size_t seq = *p >= 0x80 ? utf8_length(p) : 1;
        if (*p == '\\')
            len = (size_t)snprintf(piece, sizeof(piece), "\\\\");
        else if (*p == '\n')
            len = (size_t)snprintf(piece, sizeof(piece), "\\n");
        else if (*p == '\r')
            len = (size_t)snprintf(piece, sizeof(piece), "\\r");
        else if (*p == '\t')
            len = (size_t)snprintf(piece, sizeof(piece), "\\t");
        else if (*p < 0x20 || *p == 0x7f || seq == 0)
            len = (size_t)snprintf(piece, sizeof(piece), "\\x%02x", *p);
        else if (seq == 2 && p[0] == 0xc2 && p[1] < 0xa0) /* C1 controls: CSI (U+009B) drives terminals too */
            len = (size_t)snprintf(piece, sizeof(piece), "\\x%02x\\x%02x", p[0], p[1]), take = 2;
        else {
            memcpy(piece, p, seq);
            len = take = seq;
        }
        if (at + len >= cap)
            break;
        memcpy(out + at, piece, len);
        at += len;
        p += take;
    }
    out[at] = '\0';
    return at;
}

void node_log_init(node_log_state *state) {
    memset(state, 0, sizeof(*state));
    pthread_mutex_init(&state->lock, NULL);
}

void node_log_finish(node_log_state *state) { pthread_mutex_destroy(&state->lock); }

/* One line's text, escaped already: to the node's own sink as "corvid-node: <text>", else to the
 * process's log (corvid/log.h) with origin "node". */
static void emit(cv_node *node, const char *text) {
    if (!node->config.log_sink) {
        cv_log(CV_LOG_INFO, "node", "%s", text);
        return;
    }
    char line[NODE_LOG_LINE_MAX + 16];
    snprintf(line, sizeof(line), "corvid-node: %s", text);
    node->config.log_sink(line, node->config.log_user);
}

static void emit_summary(cv_node *node, node_log_kind kind, uint64_t count) {
    char text[128];
    snprintf(text, sizeof(text), "(%" PRIu64 " more %s lines suppressed)", count, kind_names[kind]);
    emit(node, text);
}

/* Whether a line of `kind` may go now; *summary gets the count of lines suppressed before it, to report first. */
static bool admit(node_log_state *st, node_log_kind kind, uint64_t *summary) {
    *summary = 0;
    if (kind == NODE_LOG_ALWAYS)
        return true;
    uint64_t now = cv_now_ns() / 1000000u;
    pthread_mutex_lock(&st->lock);
    if (now - st->window_start_ms[kind] >= 1000 || !st->window_start_ms[kind]) {
        *summary = st->suppressed[kind];
        st->suppressed[kind] = 0;
        st->window_start_ms[kind] = now ? now : 1;
        st->in_window[kind] = 0;
    }
    bool ok = st->in_window[kind] < NODE_LOG_BURST;
    if (ok)
        st->in_window[kind]++;
    else
        st->suppressed[kind]++;
    pthread_mutex_unlock(&st->lock);
    return ok;
}

void node_log(cv_node *node, node_log_kind kind, const char *fmt, ...) {
    if (!node->config.log_sessions)
        return;
    uint64_t summary;
    bool ok = admit(&node->log, kind, &summary);
    if (summary)
        emit_summary(node, kind, summary);
    if (!ok)
        return;
    char raw[1024];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(raw, sizeof(raw), fmt, ap);
    va_end(ap);
    char text[NODE_LOG_LINE_MAX];
    cv_log_escape(text, sizeof(text), raw);
    emit(node, text);
}

void node_log_flush(cv_node *node) {
    for (int k = 0; k < NODE_LOG_KIND_COUNT; k++) {
        pthread_mutex_lock(&node->log.lock);
        uint64_t count = node->log.suppressed[k];
        node->log.suppressed[k] = 0;
        pthread_mutex_unlock(&node->log.lock);
        if (count && node->config.log_sessions)
            emit_summary(node, (node_log_kind)k, count);
    }
}
