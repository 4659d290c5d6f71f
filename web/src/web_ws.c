/* WebSocket connections: sends from any thread, writes and reads on the service thread. */
#include "web_ws.h"

#include <corvid/log.h>

#include <stdlib.h>
#include <string.h>

static void message_free(web_message *m) {
    free(m->buf);
    m->buf = NULL;
    m->size = 0;
}

cv_web_conn *web_ws_open(cv_web_server *s, struct lws *wsi) {
    cv_web_conn *c = calloc(1, sizeof *c);
    web_message *texts = calloc(s->text_queue_max, sizeof *texts);
    if (!c || !texts) {
        free(c);
        free(texts);
        cv_log(CV_LOG_WARNING, "web", "ws: out of memory for a new connection");
        return NULL;
    }
    c->server = s;
    c->wsi = wsi;
    c->texts = texts;
    c->next = s->conns;
    if (s->conns)
        s->conns->prev = c;
    s->conns = c;
    pthread_mutex_lock(&s->lock);
    s->stats.ws_opened++;
    s->stats.ws_open_now++;
    pthread_mutex_unlock(&s->lock);
    if (s->ws_open)
        s->ws_open(s->ws_user, c);
    return c;
}

void web_ws_close(cv_web_conn *c) {
    cv_web_server *s = c->server;
    if (s->ws_close)
        s->ws_close(s->ws_user, c);
    pthread_mutex_lock(&s->lock);
    c->closing = true;
    for (cv_web_conn **p = &s->wake; *p; p = &(*p)->wake_next) {
        if (*p == c) {
            *p = c->wake_next;
            break;
        }
    }
    for (uint32_t i = 0; i < c->binary_count; i++)
        message_free(&c->binary[(c->binary_head + i) % WEB_BINARY_QUEUE]);
    for (uint32_t i = 0; i < c->text_count; i++)
        message_free(&c->texts[(c->text_head + i) % s->text_queue_max]);
    s->stats.ws_open_now--;
    pthread_mutex_unlock(&s->lock);
    if (c->prev)
        c->prev->next = c->next;
    else
        s->conns = c->next;
    if (c->next)
        c->next->prev = c->prev;
    free(c->texts);
    free(c->rx);
    free(c);
}

/* With the lock held: lists the connection for a write callback. Returns whether the
 * service thread must be woken (the list was empty). */
static bool wake_locked(cv_web_conn *c) {
    if (c->wake_listed)
        return false;
    bool first = c->server->wake == NULL;
    c->wake_listed = true;
    c->wake_next = c->server->wake;
    c->server->wake = c;
    return first;
}

static cv_result message_copy(web_message *m, const void *data, size_t size) {
    m->buf = malloc(LWS_PRE + size + 1);
    if (!m->buf)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "web: ws: message of %zu bytes", size);
    memcpy(m->buf + LWS_PRE, data, size);
    m->size = size;
    return CV_OK;
}

/* Queues frame m (lock held): over a replaceable unsent tail, or behind the unsent ones. */
static cv_result queue_binary_locked(cv_web_conn *c, web_message *m, bool replaceable) {
    cv_web_server *s = c->server;
    uint32_t tail = (c->binary_head + c->binary_count - 1) % WEB_BINARY_QUEUE;
    if (c->binary_count && c->binary_replaceable[tail] && replaceable) {
        s->stats.binary_replaced++;
        message_free(&c->binary[tail]);
    } else if (c->binary_count == WEB_BINARY_QUEUE) {
        s->stats.binary_dropped++;
        return cv_error(CV_ERROR_LIMIT_EXCEEDED, "web: send binary: %u frames already wait", WEB_BINARY_QUEUE);
    } else {
        tail = (c->binary_head + c->binary_count++) % WEB_BINARY_QUEUE;
    }
    c->binary[tail] = *m;
    c->binary_replaceable[tail] = replaceable;
    *m = (web_message){ 0 };
    return CV_OK;
}

static cv_result send_binary(cv_web_conn *c, const void *data, size_t size, bool replaceable) {
    if (!c || (!data && size))
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "web: send binary: NULL connection or data");
    web_message m;
    cv_result r = message_copy(&m, data, size);
    if (r != CV_OK)
        return r;
    cv_web_server *s = c->server;
    pthread_mutex_lock(&s->lock);
    r = c->closing || s->stopping ? cv_error(CV_ERROR_CONNECTION, "web: send binary: the connection is closing")
                                  : queue_binary_locked(c, &m, replaceable);
    if (r == CV_OK && wake_locked(c)) /* under the lock: stop may not destroy the context meanwhile */
        lws_cancel_service(s->context);
    pthread_mutex_unlock(&s->lock);
    message_free(&m);
    return r;
}

cv_result cv_web_send_binary(cv_web_conn *c, const void *data, size_t size) {
    return send_binary(c, data, size, true);
}

cv_result cv_web_send_binary_in_order(cv_web_conn *c, const void *data, size_t size) {
    return send_binary(c, data, size, false);
}

cv_result cv_web_send_text(cv_web_conn *c, const char *text) {
    if (!c || !text)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "web: send text: NULL connection or text");
    web_message m;
    cv_result r = message_copy(&m, text, strlen(text));
    if (r != CV_OK)
        return r;
    cv_web_server *s = c->server;
    pthread_mutex_lock(&s->lock);
    if (c->closing || s->stopping || c->text_count == s->text_queue_max) {
        bool full = !c->closing && !s->stopping;
        if (full)
            s->stats.text_dropped++;
        pthread_mutex_unlock(&s->lock);
        message_free(&m);
        return full ? cv_error(CV_ERROR_LIMIT_EXCEEDED, "web: send text: %u messages already wait", s->text_queue_max)
                    : cv_error(CV_ERROR_CONNECTION, "web: send text: the connection is closing");
    }
    c->texts[(c->text_head + c->text_count) % s->text_queue_max] = m;
    c->text_count++;
    if (wake_locked(c)) /* under the lock: stop may not destroy the context meanwhile */
        lws_cancel_service(s->context);
    pthread_mutex_unlock(&s->lock);
    return CV_OK;
}

void web_ws_wake(cv_web_server *s) {
    pthread_mutex_lock(&s->lock);
    for (cv_web_conn *c = s->wake; c; c = c->wake_next) {
        c->wake_listed = false;
        lws_callback_on_writable(c->wsi);
    }
    s->wake = NULL;
    pthread_mutex_unlock(&s->lock);
}

int web_ws_writeable(cv_web_conn *c) {
    cv_web_server *s = c->server;
    web_message m = { 0 };
    bool text = false, more;
    pthread_mutex_lock(&s->lock);
    if (c->text_count) { /* small (stats, errors): never kept behind a frame */
        m = c->texts[c->text_head];
        c->text_head = (c->text_head + 1) % s->text_queue_max;
        c->text_count--;
        text = true;
    } else if (c->binary_count) {
        m = c->binary[c->binary_head];
        c->binary[c->binary_head] = (web_message){ 0 };
        c->binary_head = (c->binary_head + 1) % WEB_BINARY_QUEUE;
        c->binary_count--;
    }
    more = c->text_count || c->binary_count;
    if (m.buf) { /* counted as it goes to lws, so a peer that has it sees it counted */
        s->stats.bytes_sent += m.size;
        if (text)
            s->stats.text_sent++;
        else
            s->stats.binary_sent++;
    }
    pthread_mutex_unlock(&s->lock);
    if (!m.buf)
        return 0;
    int n = lws_write(c->wsi, m.buf + LWS_PRE, m.size, text ? LWS_WRITE_TEXT : LWS_WRITE_BINARY);
    size_t size = m.size;
    message_free(&m);
    if (n < (int)size) {
        cv_log(CV_LOG_INFO, "web", "ws: write of %zu bytes failed: closing the connection", size);
        return -1;
    }
    if (more)
        lws_callback_on_writable(c->wsi);
    return 0;
}

int web_ws_receive(cv_web_conn *c, const void *in, size_t len) {
    cv_web_server *s = c->server;
    if (lws_is_first_fragment(c->wsi)) {
        c->rx_size = 0;
    }
    if (c->rx_size + len > s->ws_max_message_bytes) {
        cv_log(CV_LOG_INFO, "web", "ws: incoming message over %zu bytes: closing the connection",
               s->ws_max_message_bytes);
        return -1;
    }
    if (!c->rx && !(c->rx = malloc(s->ws_max_message_bytes + 1)))
        return -1;
    memcpy(c->rx + c->rx_size, in, len);
    c->rx_size += len;
    if (!lws_is_final_fragment(c->wsi) || lws_remaining_packet_payload(c->wsi) > 0)
        return 0;
    if (lws_frame_is_binary(c->wsi)) /* the page sends only text: binary is ignored */
        return 0;
    c->rx[c->rx_size] = 0;
    if (s->ws_text)
        s->ws_text(s->ws_user, c, (const char *)c->rx, c->rx_size);
    return 0;
}
