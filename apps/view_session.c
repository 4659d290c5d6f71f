/* corvid-view's viewers (view_session.h): frames out, input in, credits, stats. */
#include "view_session.h"

#include <stdlib.h>
#include <string.h>

#include "corvid/clock.h"
#include "corvid/log.h"
#include "view_frame.h"
#include "view_input.h"
#include "view_messages.h"

/* A frame whose acknowledgement has not come after this long was lost on the way (replaced in
 * the socket's one-frame slot, or dropped by the page): its credit is given back. */
#define VIEW_ACK_GIVE_UP_MS 1000.0
/* Frames in flight to a page that has just connected. */
#define VIEW_START_CREDITS 2u

void view_session_init(view_session *s, const cv_render_settings *settings, cv_codec codec) {
    memset(s, 0, sizeof *s);
    pthread_mutex_init(&s->lock, NULL);
    s->settings = *settings;
    s->codec = codec;
    s->last_ack_ms = s->last_tick_ms = cv_now_ms();
}

void view_session_finish(view_session *s) {
    while (s->peers) {
        view_peer *p = s->peers;
        s->peers = p->next;
        free(p);
    }
    pthread_mutex_destroy(&s->lock);
}

/* The page's seq of the newest input of this peer that the live's `live_seq` includes (0: none). */
static uint64_t page_seq_of(const view_peer *p, uint64_t live_seq) {
    for (uint32_t i = 0; i < p->seq_count; i++) {
        uint32_t k = (p->seq_head + VIEW_SEQ_MAP - 1 - i) % VIEW_SEQ_MAP;
        if (p->live_seq[k] <= live_seq)
            return p->page_seq[k];
    }
    return 0;
}

static uint64_t live_seq_of(const view_peer *p, uint64_t page_seq) {
    for (uint32_t i = 0; i < p->seq_count; i++) {
        uint32_t k = (p->seq_head + VIEW_SEQ_MAP - 1 - i) % VIEW_SEQ_MAP;
        if (p->page_seq[k] == page_seq)
            return p->live_seq[k];
    }
    return 0;
}

static void remember_seq(view_peer *p, uint64_t live_seq, uint64_t page_seq) {
    p->live_seq[p->seq_head] = live_seq;
    p->page_seq[p->seq_head] = page_seq;
    p->seq_head = (p->seq_head + 1) % VIEW_SEQ_MAP;
    if (p->seq_count < VIEW_SEQ_MAP)
        p->seq_count++;
}

void view_session_frame(const cv_live_frame *f, void *user) {
    view_session *s = user;
    size_t n = VIEW_FRAME_HEADER_BYTES + f->size;
    uint8_t *buf = malloc(n);
    if (!buf) {
        cv_log(CV_LOG_WARNING, "view", "frame %llu: out of memory: not sent", (unsigned long long)f->index);
        return;
    }
    memcpy(buf + VIEW_FRAME_HEADER_BYTES, f->data, f->size);
    pthread_mutex_lock(&s->lock);
    s->last_frame = f->index;
    uint32_t k = (uint32_t)(f->index % VIEW_SENT_MAP);
    s->sent_index[k] = f->index;
    s->sent_ms[k] = cv_now_ms();
    s->sent_bytes[k] = n;
    for (view_peer *p = s->peers; p; p = p->next) {
        view_frame_header(buf, f, page_seq_of(p, f->input_seq));
        /* An H.264 frame refers to the ones before it: none may give way to the next. */
        if (f->codec == CV_CODEC_H264)
            cv_web_send_binary_in_order(p->conn, buf, n); /* credits keep these to two */
        else
            cv_web_send_binary(p->conn, buf, n); /* fails only while the connection closes */
    }
    pthread_mutex_unlock(&s->lock);
    free(buf);
}

static view_peer *find_peer(view_session *s, cv_web_conn *c) {
    for (view_peer *p = s->peers; p; p = p->next)
        if (p->conn == c)
            return p;
    return NULL;
}

static void send_json(cv_web_conn *c, char *json) {
    if (json)
        cv_web_send_text(c, json);
    free(json);
}

/* A page to start (lock held, the live attached): its hello, a frame of a still view, credits. */
static void greet(view_session *s, cv_web_conn *c) {
    send_json(c, view_hello_json(&s->settings, s->scene, s->codec));
    /* A new decoder starts at a keyframe; the same settings again make one more frame of a
     * still view (its history goes on), so the page has a picture at once. */
    if (s->codec == CV_CODEC_H264)
        cv_live_set_codec(s->live, s->codec, &(cv_encode_params){ .keyframe = true });
    if (cv_live_update(s->live, &s->settings, s->seq + 1) == CV_OK)
        s->seq++;
    cv_live_credit(s->live, VIEW_START_CREDITS);
}

void view_session_attach(view_session *s, cv_live *live, const cv_scene *scene) {
    pthread_mutex_lock(&s->lock);
    s->live = live;
    s->scene = scene;
    if (s->peers) /* the newest drives; the others get the hello alone */
        greet(s, s->peers->conn);
    for (view_peer *p = s->peers ? s->peers->next : NULL; p; p = p->next)
        send_json(p->conn, view_hello_json(&s->settings, s->scene, s->codec));
    pthread_mutex_unlock(&s->lock);
}

void view_session_open(void *user, cv_web_conn *c) {
    view_session *s = user;
    view_peer *p = calloc(1, sizeof *p);
    if (!p) {
        send_json(c, view_error_json("corvid-view: out of memory for this viewer"));
        return;
    }
    p->conn = c;
    pthread_mutex_lock(&s->lock);
    p->next = s->peers;
    s->peers = p; /* the newest page drives: earlier frames' acknowledgements are its no more */
    s->acked = s->last_frame;
    s->last_ack_ms = cv_now_ms();
    s->rtt_count = s->rtt_head = 0; /* another page, another link */
    s->link_bytes_per_s = s->page_bytes_per_s = 0;
    if (s->live)
        greet(s, c);
    pthread_mutex_unlock(&s->lock);
}

void view_session_close(void *user, cv_web_conn *c) {
    view_session *s = user;
    pthread_mutex_lock(&s->lock);
    for (view_peer **pp = &s->peers; *pp; pp = &(*pp)->next) {
        if ((*pp)->conn == c) {
            view_peer *p = *pp;
            *pp = p->next;
            free(p);
            break;
        }
    }
    pthread_mutex_unlock(&s->lock);
}

/* The link's bandwidth from frame `index` acknowledged now: its bytes over its round trip less
 * the shortest of the recent ones (what a frame of no size would take: latency, decode), at
 * least 2 ms; smoothed. A fast link gives a high figure, a slow one its rate. */
static void estimate_link(view_session *s, uint64_t index) {
    uint32_t k = (uint32_t)(index % VIEW_SENT_MAP);
    if (s->sent_index[k] != index)
        return;
    double rtt = cv_now_ms() - s->sent_ms[k], min = rtt;
    s->rtt_ms[s->rtt_head] = rtt;
    s->rtt_head = (s->rtt_head + 1) % VIEW_SENT_MAP;
    if (s->rtt_count < VIEW_SENT_MAP)
        s->rtt_count++;
    for (uint32_t i = 0; i < s->rtt_count; i++)
        if (s->rtt_ms[i] < min)
            min = s->rtt_ms[i];
    double transfer_ms = rtt - min > 2.0 ? rtt - min : 2.0;
    double rate = (double)s->sent_bytes[k] * 1000.0 / transfer_ms;
    s->link_bytes_per_s = s->link_bytes_per_s > 0 ? 0.75 * s->link_bytes_per_s + 0.25 * rate : rate;
    cv_live_report_link(s->live, s->link_bytes_per_s);
}

/* Frames up to `ack` displayed: their credits back to the live (only the driving page's). */
static void take_ack(view_session *s, uint64_t ack) {
    estimate_link(s, ack);
    uint64_t upto = ack < s->last_frame ? ack : s->last_frame;
    if (upto > s->acked) {
        cv_live_credit(s->live, (uint32_t)(upto - s->acked));
        s->acked = upto;
    }
    s->last_ack_ms = cv_now_ms();
}

/* An input message read (lock held): codec, then settings, acknowledgements, reports. */
static cv_result apply_input(view_session *s, view_peer *p, const view_input *in) {
    cv_result r = CV_OK;
    if (in->has_codec || in->keyframe)
        r = cv_live_set_codec(s->live, in->has_codec ? in->codec : s->codec, &(cv_encode_params){ .keyframe = true });
    if (r == CV_OK && in->has_codec)
        s->codec = in->codec;
    if (r == CV_OK && in->changed) {
        r = cv_live_update(s->live, &in->settings, s->seq + 1);
        if (r == CV_OK) {
            s->seq++;
            s->settings = in->settings;
            remember_seq(p, s->seq, in->has_seq ? in->seq : 0);
        }
    }
    bool drives = p == s->peers;
    if (in->has_ack && drives)
        take_ack(s, in->ack);
    if (in->has_ack && drives && in->bytes_per_s > 0)
        s->page_bytes_per_s = in->bytes_per_s;
    if (in->has_shown && drives)
        cv_live_report_display(s->live, live_seq_of(p, in->shown), in->m2p_ms);
    return r;
}

void view_session_text(void *user, cv_web_conn *c, const char *text, size_t size) {
    view_session *s = user;
    (void)size;
    pthread_mutex_lock(&s->lock);
    view_peer *p = find_peer(s, c);
    view_input in;
    cv_result r = p && s->live ? view_input_parse(text, &s->settings, &in) : CV_OK;
    if (r == CV_OK && p && s->live)
        r = apply_input(s, p, &in);
    pthread_mutex_unlock(&s->lock);
    if (r != CV_OK)
        send_json(c, view_error_json(cv_last_error()));
}

void view_session_tick(view_session *s, cv_web_server *server) {
    cv_live_stats ls = { 0 };
    cv_web_stats ws;
    cv_web_server_get_stats(server, &ws);
    pthread_mutex_lock(&s->lock);
    double now = cv_now_ms();
    if (now - s->last_tick_ms >= 1000.0) { /* over a second: a slow view sends a frame in several ticks */
        s->sent_bytes_per_s = (double)(ws.bytes_sent - s->last_bytes) * 1000.0 / (now - s->last_tick_ms);
        s->last_bytes = ws.bytes_sent;
        s->last_tick_ms = now;
    }
    if (s->live && s->peers && s->last_frame > s->acked && now - s->last_ack_ms > VIEW_ACK_GIVE_UP_MS) {
        cv_live_credit(s->live, (uint32_t)(s->last_frame - s->acked));
        s->acked = s->last_frame;
        s->last_ack_ms = now;
    }
    if (s->live)
        cv_live_get_stats(s->live, &ls);
    char *json = s->peers ? view_stats_json(&ls, &ws, s->sent_bytes_per_s, s->page_bytes_per_s) : NULL;
    for (view_peer *p = s->peers; json && p; p = p->next)
        cv_web_send_text(p->conn, json);
    pthread_mutex_unlock(&s->lock);
    free(json);
}
