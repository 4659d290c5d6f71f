/* A session's encoder streams (node.proto: OpenEncoder, ReadEncoded,
 * CloseEncoder): at most CV_NODE_MAX_ENCODER_STREAMS per session, each a frame
 * reader on the session's device, freed with the session. Every field of a
 * request is checked here, and a refusal names it; the session (session.c)
 * translates the client's texture id and sends the frame.
 *
 *     session_encoders enc = { 0 };
 *     session_encode_open(&enc, dev, open_msg);
 *     cv_encoded frame = { 0 };
 *     if (session_encode_read(&enc, ctx, texture, read_msg, &frame) == CV_OK) ... send it
 *     session_encode_finish(&enc); */
#ifndef CORVID_SESSION_ENCODE_H
#define CORVID_SESSION_ENCODE_H

#include "corvid/frame_reader.h"
#include "corvid/node_protocol.h"

typedef struct session_encoder {
    uint32_t id; /* the client's number; 0 = a free slot */
    cv_codec codec;
    uint32_t width, height;
    cv_frame_reader *reader;
} session_encoder;

typedef struct session_encoders {
    session_encoder streams[CV_NODE_MAX_ENCODER_STREAMS];
} session_encoders;

cv_result session_encode_open(session_encoders *e, cv_device *dev, const Corvid__OpenEncoder *m);
/* texture: the session's own handle for m->id (already translated). */
cv_result session_encode_read(session_encoders *e, cv_context *ctx, cv_texture texture, const Corvid__ReadEncoded *m,
                              cv_encoded *out);
cv_result session_encode_close(session_encoders *e, const Corvid__CloseEncoder *m);
/* Frees every stream (the session's end). */
void session_encode_finish(session_encoders *e);

#endif
