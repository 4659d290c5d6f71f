/* Encoder streams of a proxy device (proxy_encode.h): one request per opened
 * stream and per frame; closing is sent and forgotten, like a destroy. */
#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "proxy_encode.h"
#include "proxy_session.h"

cv_result proxy_encoder_open(cv_backend_device *p, uint32_t stream, cv_codec codec, uint32_t width, uint32_t height) {
    Corvid__OpenEncoder open = CORVID__OPEN_ENCODER__INIT;
    open.stream = stream;
    open.codec = (uint32_t)codec;
    open.width = width;
    open.height = height;
    Corvid__ClientMessage m = CORVID__CLIENT_MESSAGE__INIT;
    m.msg_case = CORVID__CLIENT_MESSAGE__MSG_OPEN_ENCODER;
    m.open_encoder = &open;
    proxy_pending pending = { 0 };
    return proxy_request(p, &m, &pending);
}

cv_result proxy_encoder_send(cv_backend_device *p, uint32_t stream, void *tex, const cv_texture_desc *desc,
                             cv_rect rect, const cv_encode_params *params) {
    Corvid__EncodeParams pm;
    cv_node_encode_params_to_msg(params, &pm);
    Corvid__ReadEncoded rd = CORVID__READ_ENCODED__INIT;
    rd.stream = stream;
    rd.id = ((const proxy_resource *)tex)->id;
    rd.x = rect.x;
    rd.y = rect.y;
    rd.width = rect.width;
    rd.height = rect.height;
    rd.params = &pm;
    Corvid__ClientMessage m = CORVID__CLIENT_MESSAGE__INIT;
    m.msg_case = CORVID__CLIENT_MESSAGE__MSG_READ_ENCODED;
    m.read_encoded = &rd;
    /* What a node may send for one frame: twice the texels (a codec's worst case is far below), plus headers. */
    uint64_t raw = (uint64_t)rect.width * rect.height * cv_format_bytes(desc->format);
    proxy_pending pending = { .encoded = &p->encode_frame, .encoded_max = 2 * raw + (64u << 10) };
    return proxy_request_start(p, &m, &pending);
}

cv_result proxy_encoder_receive(cv_backend_device *p, uint32_t stream, cv_encoded *out) {
    (void)stream; /* one encoded read at a time: the one this thread sent */
    proxy_pending pending = { 0 };
    cv_result r = proxy_request_finish(p, &pending);
    *out = pending.frame; /* taken from the receiver's buffer before the slot went to another read */
    pthread_mutex_lock(&p->lock);
    if (r == CV_OK) {
        p->stats.encoded_frames++;
        p->stats.encoded_bytes += out->size;
    }
    pthread_mutex_unlock(&p->lock);
    if (r != CV_OK)
        cv_encoded_free(out);
    return r;
}

void proxy_encoder_close(cv_backend_device *p, uint32_t stream) {
    Corvid__CloseEncoder close = CORVID__CLOSE_ENCODER__INIT;
    close.stream = stream;
    Corvid__ClientMessage m = CORVID__CLIENT_MESSAGE__INIT;
    m.msg_case = CORVID__CLIENT_MESSAGE__MSG_CLOSE_ENCODER;
    m.close_encoder = &close;
    proxy_send(p, &m); /* a dead session frees its streams on the node anyway */
}
