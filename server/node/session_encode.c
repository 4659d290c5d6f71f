/* A session's encoder streams (session_encode.h): the checks a hostile client
 * meets before the node allocates or reads anything, and the frame readers. */
#include "session_encode.h"

#include <stdio.h>
#include <string.h>

static session_encoder *find(session_encoders *e, uint32_t id) {
    for (uint32_t i = 0; id && i < CV_NODE_MAX_ENCODER_STREAMS; i++)
        if (e->streams[i].id == id)
            return &e->streams[i];
    return NULL;
}

cv_result session_encode_open(session_encoders *e, cv_device *dev, const Corvid__OpenEncoder *m) {
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
    cv_frame_reader *reader;
    r = cv_frame_reader_create(dev, (cv_codec)m->codec, m->width, m->height, &reader);
    if (r != CV_OK)
        return cv_error(r, "open_encoder: stream %u: %s", m->stream, cv_last_error());
    *slot = (session_encoder){ m->stream, (cv_codec)m->codec, m->width, m->height, reader };
    return CV_OK;
}

cv_result session_encode_read(session_encoders *e, cv_context *ctx, cv_texture texture, const Corvid__ReadEncoded *m,
                              cv_encoded *out) {
    memset(out, 0, sizeof(*out));
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
    cv_encode_params params;
    cv_node_encode_params_from_msg(m->params, &params);
    if (r == CV_OK)
        r = cv_encode_check_params(&params, "read_encoded: params");
    if (r == CV_OK)
        r = cv_frame_reader_read(st->reader, texture, (cv_rect){ m->x, m->y, m->width, m->height }, &params, out);
    return r;
}

cv_result session_encode_close(session_encoders *e, const Corvid__CloseEncoder *m) {
    session_encoder *st = find(e, m->stream);
    if (!st)
        return cv_error(CV_ERROR_INVALID_HANDLE, "close_encoder: stream %u is not open in this session", m->stream);
    cv_frame_reader_destroy(st->reader);
    memset(st, 0, sizeof(*st));
    return CV_OK;
}

void session_encode_finish(session_encoders *e) {
    for (uint32_t i = 0; i < CV_NODE_MAX_ENCODER_STREAMS; i++)
        cv_frame_reader_destroy(e->streams[i].reader);
    memset(e, 0, sizeof(*e));
}
