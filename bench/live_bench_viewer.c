/* bench_live's synthetic viewer (live_bench_viewer.h): the live's frames
 * queued by its callback (at most VIEWER_CREDITS, the credits in flight),
 * decoded and "displayed" on the caller's thread, which gives a credit back
 * per frame and turns the camera every input_every frames. */
#include <pthread.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "corvid/clock.h"
#include "corvid/frame_codec.h"
#include "live_bench_viewer.h"

/* Inputs remembered for motion-to-photon: more than can be in flight at once. */
#define VIEWER_SEQS 1024u

/* A frame as it arrived: a copy of the callback's. */
typedef struct viewer_msg {
    cv_live_frame f;
    uint8_t *data;
    double arrive_ms;
} viewer_msg;

typedef struct viewer {
    pthread_mutex_t lock;
    pthread_cond_t cond;
    viewer_msg q[VIEWER_CREDITS + 1];
    uint32_t head, count;
    uint64_t overflow; /* frames beyond the credits: none, if the live keeps to them */
} viewer;

static void on_frame(const cv_live_frame *f, void *user) {
    viewer *v = user;
    uint8_t *copy = malloc(f->size ? f->size : 1);
    if (copy)
        memcpy(copy, f->data, f->size);
    pthread_mutex_lock(&v->lock);
    if (v->count < VIEWER_CREDITS + 1 && copy) {
        viewer_msg *m = &v->q[(v->head + v->count++) % (VIEWER_CREDITS + 1)];
        *m = (viewer_msg){ .f = *f, .data = copy, .arrive_ms = cv_now_ms() };
        m->f.data = copy;
        copy = NULL;
    } else {
        v->overflow++;
    }
    pthread_cond_signal(&v->cond);
    pthread_mutex_unlock(&v->lock);
    free(copy);
}

/* The next frame, or false at the deadline (cv_now_ms's clock). */
static bool next_frame(viewer *v, double deadline_ms, viewer_msg *out) {
    pthread_mutex_lock(&v->lock);
    while (!v->count && cv_now_ms() < deadline_ms) {
        struct timespec ts;
        clock_gettime(CLOCK_REALTIME, &ts);
        ts.tv_nsec += 20 * 1000 * 1000;
        if (ts.tv_nsec >= 1000000000L) {
            ts.tv_sec++;
            ts.tv_nsec -= 1000000000L;
        }
        pthread_cond_timedwait(&v->cond, &v->lock, &ts);
    }
    bool got = v->count > 0;
    if (got) {
        *out = v->q[v->head];
        v->head = (v->head + 1) % (VIEWER_CREDITS + 1);
        v->count--;
    }
    pthread_mutex_unlock(&v->lock);
    return got;
}

/* The viewer's inputs: when each seq was sent, and the newest seq a displayed frame showed. */
typedef struct viewer_inputs {
    double sent_ms[VIEWER_SEQS];
    uint64_t seq, shown;
} viewer_inputs;

/* A frame displayed at shown_ms: motion-to-photon of each input it is the first to reflect. */
static void shown(viewer_inputs *in, const cv_live_frame *f, double shown_ms, double measure_from,
                  viewer_figures *fig) {
    for (uint64_t s = in->shown + 1; s <= f->input_seq && s <= in->seq; s++)
        if (in->sent_ms[s % VIEWER_SEQS] >= measure_from)
            viewer_figures_m2p(fig, shown_ms - in->sent_ms[s % VIEWER_SEQS]);
    if (f->input_seq > in->shown)
        in->shown = f->input_seq;
}

/* Decodes and displays the frames until the deadline. */
static cv_result consume(const viewer_desc *d, cv_live *live, viewer *v, cv_render_settings *s, viewer_figures *fig) {
    cv_decoder *dec = NULL;
    cv_result res = cv_decoder_create(d->codec, &dec);
    viewer_camera cam;
    viewer_camera_init(&cam, s, d->scene);
    viewer_inputs *in = calloc(1, sizeof(*in)); /* 8 kB: off the stack */
    if (!in)
        res = cv_error(CV_ERROR_OUT_OF_MEMORY, "viewer: inputs");
    double start = cv_now_ms(), measure_from = start + viewer_warmup_ms(d->seconds);
    double deadline = start + d->seconds * 1e3;
    fig->start_ms = measure_from;
    uint64_t displayed = 0;
    viewer_msg m;
    while (res == CV_OK && next_frame(v, deadline, &m)) {
        uint8_t *px = NULL;
        size_t px_size = 0;
        uint32_t w = 0, h = 0;
        double t0 = cv_now_ms();
        res = cv_decoder_decode(dec, m.data, m.f.size, &px, &px_size, &w, &h);
        double t1 = cv_now_ms();
        free(px);
        cv_live_trace_span(d->trace, "decode", m.f.index, 0, t0, t1);
        if (res == CV_OK && px_size && m.arrive_ms >= measure_from)
            viewer_figures_add(fig, &(viewer_frame){ .arrive_ms = m.arrive_ms,
                                                     .shown_ms = t1,
                                                     .bytes = m.f.size,
                                                     .render_ms = m.f.render_ms,
                                                     .read_ms = m.f.read_ms,
                                                     .encode_ms = m.f.encode_ms,
                                                     .transfer_ms = m.f.fetch_ms - m.f.read_ms - m.f.encode_ms,
                                                     .decode_ms = t1 - t0 });
        if (res == CV_OK && px_size)
            shown(in, &m.f, t1, measure_from, fig);
        free(m.data);
        cv_live_credit(live, 1);
        if (res == CV_OK && ++displayed % d->input_every == 0) {
            viewer_camera_step(&cam, s);
            in->sent_ms[(in->seq + 1) % VIEWER_SEQS] = cv_now_ms();
            res = cv_live_update(live, s, ++in->seq);
        }
    }
    fig->end_ms = cv_now_ms();
    fig->inputs_unseen = in ? in->seq - in->shown : 0;
    free(in);
    cv_decoder_destroy(dec);
    return res;
}

cv_result viewer_run(const viewer_desc *d, viewer_figures *fig) {
    viewer v = { 0 };
    pthread_mutex_init(&v.lock, NULL);
    pthread_cond_init(&v.cond, NULL);
    viewer_figures_init(fig, cv_codec_name(d->codec));
    cv_render_settings s = { .width = d->width, .height = d->height };
    viewer_camera cam;
    viewer_camera_init(&cam, &s, d->scene);
    cv_live_desc ld = { .renderer = d->renderer,
                        .primary = d->primary,
                        .settings = s,
                        .codec = d->codec,
                        .frame = on_frame,
                        .user = &v,
                        .trace = d->trace };
    cv_live *live = NULL;
    cv_result res = cv_live_start(&ld, &live);
    if (res == CV_OK) {
        cv_live_credit(live, VIEWER_CREDITS);
        res = consume(d, live, &v, &s, fig);
        cv_live_stats st;
        cv_live_get_stats(live, &st);
        fig->rendered = st.rendered, fig->presented = st.presented, fig->spoiled = st.spoiled;
        if (res == CV_OK && st.failed)
            res = cv_error(CV_ERROR_BAD_STATE, "%s", st.error);
        cv_live_stop(live);
    }
    for (; v.count; v.count--, v.head = (v.head + 1) % (VIEWER_CREDITS + 1))
        free(v.q[v.head].data);
    pthread_mutex_destroy(&v.lock);
    pthread_cond_destroy(&v.cond);
    if (res == CV_OK && v.overflow)
        res = cv_error(CV_ERROR_BAD_STATE, "%llu frames came beyond the viewer's credits",
                       (unsigned long long)v.overflow);
    return res;
}
