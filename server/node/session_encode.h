/* A session's encoder streams (node.proto: OpenEncoder, ReadEncoded,
 * CloseEncoder): at most CV_NODE_MAX_ENCODER_STREAMS per session, freed with
 * it. Every field of a request is checked here, and a refusal names it.
 *
 * A read is split in two: the session's thread reads the texels in stream order
 * (after the work submitted before it), then hands them to the session's encode
 * worker and goes on with the next messages, so the device runs the next
 * submissions while the frame is encoded and sent (EncodedFrame pieces, or a
 * Reply if the encoder fails). One frame at a time: the next read waits for the
 * worker, as do closing a stream and the session's end.
 *
 *     session_encoders enc;
 *     session_encode_init(&enc, &sink);             // how the worker answers
 *     session_encode_open(&enc, open_msg);
 *     session_encode_read(&enc, dev, ctx, texture, seq, read_msg);  // the frame goes out later
 *     session_encode_stop(&enc);                     // before the stream ends
 *     session_encode_finish(&enc); */
#ifndef CORVID_SESSION_ENCODE_H
#define CORVID_SESSION_ENCODE_H

#include <pthread.h>

#include "corvid/device.h"
#include "corvid/frame_codec.h"
#include "corvid/node_protocol.h"

/* How the worker answers the client (the session's send and reply, thread-safe). */
typedef struct session_encode_sink {
    cv_result (*send)(void *user, const Corvid__NodeMessage *m);
    void (*reply)(void *user, uint64_t seq, cv_result result, const char *message);
    void *user;
} session_encode_sink;

typedef struct session_encoder {
    uint32_t id; /* the client's number; 0 = a free slot */
    cv_codec codec;
    uint32_t width, height;
    cv_encoder *encoder;
} session_encoder;

/* The frame handed to the worker. */
typedef struct session_encode_job {
    bool queued; /* the worker has it (or is encoding it) */
    uint64_t seq;
    cv_encoder *encoder;
    uint32_t stream;
    size_t stride;
    cv_encode_params params;
    double read_ms;
} session_encode_job;

typedef struct session_encoders {
    session_encoder streams[CV_NODE_MAX_ENCODER_STREAMS];
    session_encode_sink sink;
    uint8_t *pixels; /* the texels of the frame being encoded, reused */
    size_t capacity;
    pthread_mutex_t lock; /* job, stopping */
    pthread_cond_t cond;
    session_encode_job job;
    bool stopping, worker_started;
    pthread_t worker;
} session_encoders;

void session_encode_init(session_encoders *e, const session_encode_sink *sink);
cv_result session_encode_open(session_encoders *e, const Corvid__OpenEncoder *m);
/* texture: the session's own handle for m->id (already translated). CV_OK: the frame is the worker's to send. */
cv_result session_encode_read(session_encoders *e, cv_device *dev, cv_context *ctx, cv_texture texture, uint64_t seq,
                              const Corvid__ReadEncoded *m);
cv_result session_encode_close(session_encoders *e, const Corvid__CloseEncoder *m);
/* Lets the worker finish its frame, then ends it (before the session's stream ends). */
void session_encode_stop(session_encoders *e);
/* Frees every stream (after session_encode_stop). */
void session_encode_finish(session_encoders *e);

#endif
