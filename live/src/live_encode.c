/* The live's encode thread: against the consumer's credit, the newest
 * finished step's display read through a cv_frame_reader (encoded on the
 * primary's machine), handed to desc.frame, and its figures into the stats
 * and the bandwidth adaptation. */
#include <stdio.h>

#include "corvid/clock.h"
#include "corvid/frame_reader.h"
#include "live_internal.h"

/* One frame to present: what the encoder took from the shared state. */
typedef struct live_job {
    live_published frame;
    uint64_t index;
    cv_codec codec;
    cv_encode_params params;
} live_job;

/* The encode thread's reader: one stream, remade for a new codec or size. */
typedef struct live_stream {
    cv_frame_reader *reader;
    cv_codec codec;
    uint32_t width, height;
} live_stream;

static bool frame_ready(const cv_live *l) {
    return l->credit > 0 && l->published.step && !l->published.taken && !l->resizing;
}

/* Takes the newest step (lock held). */
static live_job take(cv_live *l) {
    live_job job = { .frame = l->published, .index = l->presented + 1, .codec = l->codec, .params = l->encode };
    job.params.quality = l->rate.quality;
    job.params.bitrate_kbps = l->rate.bitrate_kbps;
    job.params.keyframe = l->keyframe_request;
    l->keyframe_request = false;
    l->published.taken = true;
    l->reading = job.frame.step;
    l->credit--;
    return job;
}

/* Reads and encodes the job's display; a new codec or size opens a new
 * stream, whose first frame is a keyframe. */
static cv_result encode(cv_live *l, live_stream *st, live_job *job, cv_encoded *out) {
    const cv_render_step *s = &job->frame.info;
    if (!st->reader || st->codec != job->codec || st->width != s->width || st->height != s->height) {
        cv_frame_reader_destroy(st->reader);
        *st = (live_stream){ .codec = job->codec, .width = s->width, .height = s->height };
        cv_result res = cv_frame_reader_create(l->desc.primary, job->codec, s->width, s->height, &st->reader);
        if (res != CV_OK)
            return res;
        job->params.keyframe = true;
    }
    return cv_frame_reader_read(st->reader, s->display, (cv_rect){ 0, 0, s->width, s->height }, &job->params, out);
}

/* The frame's figures (lock held). */
static void account(cv_live *l, const live_job *job, const cv_live_frame *f) {
    double now = cv_now_ms();
    l->presented++;
    l->bytes += f->size;
    live_window_add(&l->presented_window, now, (double[3]){ f->render_ms, f->read_ms, f->encode_ms });
    if (f->codec == CV_CODEC_JPEG) {
        double fps = live_window_last_second(&l->rendered_window, now, NULL);
        live_rate_jpeg_frame(&l->rate, f->size, fps);
    }
    /* The server's part of motion-to-photon: the first frame that shows an input. */
    if (job->frame.input_seq != l->input_seq || l->presented == 1) {
        l->input_age_ms = f->input_age_ms;
        if (f->input_age_ms > l->input_age_max_ms)
            l->input_age_max_ms = f->input_age_ms;
    }
    l->input_seq = job->frame.input_seq;
    l->accumulated = f->accumulated;
    l->frame_width = f->width;
    l->frame_height = f->height;
}

/* The consumer's view of the encoded frame (data: e's, valid until it is freed). */
static cv_live_frame frame_of(const live_job *job, const cv_encoded *e, double fetch_ms) {
    const cv_render_step *s = &job->frame.info;
    return (cv_live_frame){ .index = job->index,
                            .input_seq = job->frame.input_seq,
                            .accumulated = s->accumulated,
                            .width = s->width,
                            .height = s->height,
                            .codec = job->codec,
                            .keyframe = e->keyframe,
                            .data = e->data,
                            .size = e->size,
                            .render_ms = s->frame_ms,
                            .read_ms = e->read_ms,
                            .encode_ms = e->encode_ms,
                            .input_age_ms = cv_now_ms() - job->frame.input_ms,
                            .fetch_ms = fetch_ms };
}

/* The reader call's spans: read, then encode, from its start (a node's own clock is not ours), and
 * the rest of the call (the link, for a proxy device) up to its end. */
static void trace_fetch(cv_live_trace *t, const live_job *job, const cv_live_frame *f, double start, double end) {
    double read_end = start + f->read_ms, encode_end = read_end + f->encode_ms;
    cv_live_trace_span(t, "read", job->index, job->frame.step, start, read_end);
    cv_live_trace_span(t, "encode", job->index, job->frame.step, read_end, encode_end);
    cv_live_trace_span(t, "link", job->index, job->frame.step, encode_end < end ? encode_end : end, end);
}

void *live_encode_main(void *arg) {
    cv_live *l = arg;
    live_stream st = { 0 };
    pthread_mutex_lock(&l->lock);
    for (;;) {
        while (!l->stopping && !l->failed && !frame_ready(l))
            pthread_cond_wait(&l->encode_cond, &l->lock);
        if (l->stopping || l->failed)
            break;
        live_job job = take(l);
        pthread_mutex_unlock(&l->lock);
        cv_encoded e = { 0 };
        double fetch_start = cv_now_ms();
        cv_result res = encode(l, &st, &job, &e);
        double fetch_end = cv_now_ms();
        char why[sizeof(l->error)] = "";
        if (res != CV_OK)
            snprintf(why, sizeof(why), "%s", cv_last_error());
        pthread_mutex_lock(&l->lock);
        l->reading = 0;
        pthread_cond_broadcast(&l->render_cond);
        if (res != CV_OK) {
            live_fail_locked(l, "live: frame %llu (step %llu): %s", (unsigned long long)job.index,
                             (unsigned long long)job.frame.step, why);
            break;
        }
        /* Counted before the consumer has it: stats read in the callback, or after it, include it. */
        cv_live_frame f = frame_of(&job, &e, fetch_end - fetch_start);
        account(l, &job, &f);
        pthread_mutex_unlock(&l->lock);
        trace_fetch(l->desc.trace, &job, &f, fetch_start, fetch_end);
        double send_start = cv_now_ms();
        l->desc.frame(&f, l->desc.user);
        cv_live_trace_span(l->desc.trace, "send", job.index, job.frame.step, send_start, cv_now_ms());
        cv_encoded_free(&e);
        pthread_mutex_lock(&l->lock);
    }
    pthread_mutex_unlock(&l->lock);
    cv_frame_reader_destroy(st.reader);
    return NULL;
}
