/* A session's encoder streams (session_encode.h): the checks a hostile client
 * meets before the node allocates or reads anything, the texels read in stream
 * order, and the worker that encodes and sends them. */
#include "session_encode.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "corvid/clock.h"

static session_encoder *find(session_encoders *e, uint32_t id) {
    for (uint32_t i = 0; id && i < CV_NODE_MAX_ENCODER_STREAMS; i++)
        if (e->streams[i].id == id)
            return &e->streams[i];
    return NULL;
}

void session_encode_init(session_encoders *e, const session_encode_sink *sink) {
    memset(e, 0, sizeof(*e));
    e->sink = *sink;
    pthread_mutex_init(&e->lock, NULL);
    cv_cond_init(&e->cond);
}

/* Waits until the worker has no frame (lock not held). */
static void wait_idle(session_encoders *e) {
    pthread_mutex_lock(&e->lock);
    while (e->job.queued)
        pthread_cond_wait(&e->cond, &e->lock);
    pthread_mutex_unlock(&e->lock);
}

cv_result session_encode_open(session_encoders *e, const Corvid__OpenEncoder *m) {
    if (m->stream == 0)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "open_encoder: stream 0 (a stream is numbered from 1)");
    if (find(e, m->stream))
        return cv_error(CV_ERROR_ALREADY_EXISTS, "open_encoder: stream %u is already open in this session",
                        m->stream);
    cv_result r = cv_encode_check_stream((cv_codec)m->codec, m->width, m->height, "open_encoder");
    if (r != CV_OK)
        return r;
    if (m->width > CV_NODE_MAX_ENCODE_SIDE || m->height > CV_NODE_MAX_ENCODE_SIDE)
        return cv_error(CV_ERROR_LIMIT_EXCEEDED, "open_encoder: width %u, height %u: over this node's limit of %u",
                        m->width, m->height, CV_NODE_MAX_ENCODE_SIDE);
    if ((uint64_t)m->width * m->height > CV_NODE_MAX_ENCODE_PIXELS)
        return cv_error(CV_ERROR_LIMIT_EXCEEDED, "open_encoder: %ux%u is %llu pixels, over this node's limit of %u",
                        m->width, m->height, (unsigned long long)m->width * m->height, CV_NODE_MAX_ENCODE_PIXELS);
    session_encoder *slot = NULL;
    for (uint32_t i = 0; !slot && i < CV_NODE_MAX_ENCODER_STREAMS; i++)
        if (e->streams[i].id == 0)
            slot = &e->streams[i];
    if (!slot)
        return cv_error(CV_ERROR_LIMIT_EXCEEDED,
                        "open_encoder: stream %u: the session holds %u streams, the most it may "
                        "(MAX_ENCODER_STREAMS)",
                        m->stream, CV_NODE_MAX_ENCODER_STREAMS);
    cv_encoder *encoder;
    r = cv_encoder_create((cv_codec)m->codec, m->width, m->height, &encoder);
    if (r != CV_OK)
        return cv_error(r, "open_encoder: stream %u: %s", m->stream, cv_last_error());
    *slot = (session_encoder){ m->stream, (cv_codec)m->codec, m->width, m->height, encoder };
    return CV_OK;
}

/* The pieces of one encoded frame (like ReadData), the first saying what it is. */
static void send_frame(session_encoders *e, uint64_t seq, const cv_encoded *frame) {
    size_t done = 0;
    for (;;) { /* a frame of 0 bytes (an encoder may skip one) is one empty piece */
        size_t n = frame->size - done < CV_NODE_CHUNK_BYTES ? frame->size - done : CV_NODE_CHUNK_BYTES;
        Corvid__EncodedFrame piece = CORVID__ENCODED_FRAME__INIT;
        piece.offset = done;
        piece.data = (ProtobufCBinaryData){ n, frame->data + done };
        piece.last = done + n == frame->size;
        if (done == 0) {
            piece.codec = (uint32_t)frame->codec;
            piece.width = frame->width;
            piece.height = frame->height;
            piece.keyframe = frame->keyframe;
            piece.size = frame->size;
            piece.read_ms = frame->read_ms;
            piece.encode_ms = frame->encode_ms;
        }
        Corvid__NodeMessage out = CORVID__NODE_MESSAGE__INIT;
        out.seq = seq;
        out.msg_case = CORVID__NODE_MESSAGE__MSG_ENCODED_FRAME;
        out.encoded_frame = &piece;
        done += n;
        if (e->sink.send(e->sink.user, &out) != CV_OK || piece.last)
            return; /* a send fails only when the client is gone */
    }
}

static void *worker_main(void *arg) {
    session_encoders *e = arg;
    pthread_mutex_lock(&e->lock);
    for (;;) {
        while (!e->job.queued && !e->stopping)
            pthread_cond_wait(&e->cond, &e->lock);
        if (!e->job.queued)
            break;
        session_encode_job job = e->job;
        pthread_mutex_unlock(&e->lock);
        cv_encoded frame = { 0 };
        cv_result r = cv_encoder_encode(job.encoder, e->pixels, job.stride, &job.params, &frame);
        if (r == CV_OK) {
            frame.read_ms = job.read_ms;
            send_frame(e, job.seq, &frame);
        } else {
            char why[CV_ERROR_MESSAGE_MAX];
            snprintf(why, sizeof(why), "read_encoded: stream %u: %s", job.stream, cv_last_error());
            e->sink.reply(e->sink.user, job.seq, r, why);
        }
        cv_encoded_free(&frame);
        pthread_mutex_lock(&e->lock);
        e->job.queued = false;
        pthread_cond_broadcast(&e->cond);
    }
    pthread_mutex_unlock(&e->lock);
    return NULL;
}

/* The stream, rect, format and parameters of a read, checked. */
static cv_result check_read(session_encoders *e, cv_context *ctx, cv_texture texture, const Corvid__ReadEncoded *m,
                            cv_encode_params *params, session_encoder **stream, cv_format *format) {
    session_encoder *st = find(e, m->stream);
    if (!st)
        return cv_error(CV_ERROR_INVALID_HANDLE, "read_encoded: stream %u is not open in this session", m->stream);
    cv_resource_desc desc;
    cv_result r = cv_context_describe(ctx, (cv_handle){ texture.id }, &desc);
    if (r != CV_OK)
        return r;
    const cv_texture_desc *d = &desc.texture;
    if (m->x > d->width || m->width > d->width - m->x || m->y > d->height || m->height > d->height - m->y)
        return cv_error(CV_ERROR_OUT_OF_RANGE, "read_encoded: %ux%u at (%u,%u) of texture '%s' (%ux%u)", m->width,
                        m->height, m->x, m->y, d->label, d->width, d->height);
    if (m->width != st->width || m->height != st->height)
        return cv_error(CV_ERROR_FORMAT_MISMATCH, "read_encoded: width %u, height %u: stream %u's frames are %ux%u",
                        m->width, m->height, m->stream, st->width, st->height);
    char what[CV_LABEL_MAX + 48];
    snprintf(what, sizeof(what), "read_encoded: texture '%s'", d->label);
    r = cv_encode_check_format(st->codec, d->format, what);
    cv_node_encode_params_from_msg(m->params, params);
    if (r == CV_OK)
        r = cv_encode_check_params(params, "read_encoded: params");
    *stream = st;
    *format = d->format;
    return r;
}

cv_result session_encode_read(session_encoders *e, cv_device *dev, cv_context *ctx, cv_texture texture, uint64_t seq,
                              const Corvid__ReadEncoded *m) {
    cv_encode_params params;
    session_encoder *st = NULL;
    cv_format format = CV_FORMAT_UNDEFINED;
    cv_result r = check_read(e, ctx, texture, m, &params, &st, &format);
    if (r != CV_OK)
        return r;
    if (!e->worker_started) {
        if (pthread_create(&e->worker, NULL, worker_main, e) != 0)
            return cv_error(CV_ERROR_OUT_OF_MEMORY, "read_encoded: cannot start the session's encode thread");
        e->worker_started = true;
    }
    wait_idle(e); /* the worker owns the texels until its frame is out */
    size_t stride = (size_t)m->width * cv_format_bytes(format), bytes = stride * m->height;
    if (bytes > e->capacity) {
        uint8_t *p = realloc(e->pixels, bytes);
        if (!p)
            return cv_error(CV_ERROR_OUT_OF_MEMORY, "read_encoded: %zu bytes of texels", bytes);
        e->pixels = p;
        e->capacity = bytes;
    }
    double start = cv_now_ms();
    r = cv_device_read_texture(dev, texture, (cv_rect){ m->x, m->y, m->width, m->height }, e->pixels);
    if (r != CV_OK)
        return r;
    pthread_mutex_lock(&e->lock);
    e->job = (session_encode_job){ true, seq, st->encoder, st->id, stride, params, cv_now_ms() - start };
    pthread_cond_broadcast(&e->cond);
    pthread_mutex_unlock(&e->lock);
    return CV_OK;
}

cv_result session_encode_close(session_encoders *e, const Corvid__CloseEncoder *m) {
    session_encoder *st = find(e, m->stream);
    if (!st)
        return cv_error(CV_ERROR_INVALID_HANDLE, "close_encoder: stream %u is not open in this session", m->stream);
    wait_idle(e); /* its last frame may still be encoding */
    cv_encoder_destroy(st->encoder);
    memset(st, 0, sizeof(*st));
    return CV_OK;
}

void session_encode_stop(session_encoders *e) {
    if (!e->worker_started)
        return;
    pthread_mutex_lock(&e->lock);
    e->stopping = true; /* after the frame it has */
    pthread_cond_broadcast(&e->cond);
    pthread_mutex_unlock(&e->lock);
    pthread_join(e->worker, NULL);
    e->worker_started = false;
}

void session_encode_finish(session_encoders *e) {
    session_encode_stop(e);
    for (uint32_t i = 0; i < CV_NODE_MAX_ENCODER_STREAMS; i++)
        cv_encoder_destroy(e->streams[i].encoder);
    free(e->pixels);
    pthread_cond_destroy(&e->cond);
    pthread_mutex_destroy(&e->lock);
    memset(e, 0, sizeof(*e));
}
