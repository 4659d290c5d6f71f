/* A hostile client against a node's encoder streams (node.proto: OpenEncoder,
 * ReadEncoded, CloseEncoder): every bad field is refused with its code and a
 * message naming it, a session holds at most MAX_ENCODER_STREAMS, stream
 * numbers are per session (session B cannot use session A's), streams end
 * with their session, and the node goes on serving. Spoken by hand (the proxy
 * backend refuses most of this before sending it), against mock devices. */
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "corvid/frame_codec.h"
#include "corvid/node_protocol.h"
#include "raw_node_client.h"
#include "scratch_node.h"

#define W 32u
#define H 16u
#define TEX_ID(i) cv_handle_pack(CV_HANDLE_TEXTURE, 1, 1, (i))
#define BUF_ID(i) cv_handle_pack(CV_HANDLE_BUFFER, 1, 1, (i))

static scratch_node node;

static void session(raw_client *c) {
    raw_open(c, node.endpoint);
    raw_send_hello(c, CV_NODE_PROTOCOL_VERSION, 0, "encode hostile");
    Corvid__NodeMessage *m = raw_recv(c);
    CHECK(m && m->msg_case == CORVID__NODE_MESSAGE__MSG_HELLO);
    if (m)
        corvid__node_message__free_unpacked(m, NULL);
}

static uint64_t send_open(raw_client *c, uint32_t stream, uint32_t codec, uint32_t width, uint32_t height) {
    Corvid__OpenEncoder o = CORVID__OPEN_ENCODER__INIT;
    o.stream = stream;
    o.codec = codec;
    o.width = width;
    o.height = height;
    Corvid__ClientMessage m = CORVID__CLIENT_MESSAGE__INIT;
    m.msg_case = CORVID__CLIENT_MESSAGE__MSG_OPEN_ENCODER;
    m.open_encoder = &o;
    return raw_send(c, &m);
}

static uint64_t send_read(raw_client *c, uint32_t stream, uint64_t id, cv_rect rect, const Corvid__EncodeParams *p) {
    Corvid__ReadEncoded r = CORVID__READ_ENCODED__INIT;
    r.stream = stream;
    r.id = id;
    r.x = rect.x;
    r.y = rect.y;
    r.width = rect.width;
    r.height = rect.height;
    r.params = (Corvid__EncodeParams *)p;
    Corvid__ClientMessage m = CORVID__CLIENT_MESSAGE__INIT;
    m.msg_case = CORVID__CLIENT_MESSAGE__MSG_READ_ENCODED;
    m.read_encoded = &r;
    return raw_send(c, &m);
}

static uint64_t send_close(raw_client *c, uint32_t stream) {
    Corvid__CloseEncoder x = CORVID__CLOSE_ENCODER__INIT;
    x.stream = stream;
    Corvid__ClientMessage m = CORVID__CLIENT_MESSAGE__INIT;
    m.msg_case = CORVID__CLIENT_MESSAGE__MSG_CLOSE_ENCODER;
    m.close_encoder = &x;
    return raw_send(c, &m);
}

/* A texture `id` of W x H in `format`, its texels written (RGBA8: a gradient). */
static void make_texture(raw_client *c, uint64_t id, cv_format format) {
    cv_resource_desc d = { .type = CV_HANDLE_TEXTURE, .texture = { .width = W, .height = H, .format = format } };
    EXPECT_REPLY(c, raw_send_create(c, id, &d), CV_OK, NULL);
    size_t bytes = (size_t)W * H * cv_format_bytes(format);
    uint8_t *px = malloc(bytes);
    for (size_t i = 0; i < bytes; i++)
        px[i] = (uint8_t)(i * 7);
    Corvid__WriteTexture wt = CORVID__WRITE_TEXTURE__INIT;
    wt.id = id;
    wt.width = W;
    wt.height = H;
    wt.data = (ProtobufCBinaryData){ bytes, px };
    Corvid__ClientMessage m = CORVID__CLIENT_MESSAGE__INIT;
    m.msg_case = CORVID__CLIENT_MESSAGE__MSG_WRITE_TEXTURE;
    m.write_texture = &wt;
    raw_send(c, &m); /* answered only if it fails: the next expectation would see it */
    free(px);
}

/* Receives the pieces of the frame answering `seq`; true if a whole one of `codec` came, W x H. */
static bool expect_frame(raw_client *c, uint64_t seq, cv_codec codec, uint64_t *size) {
    bool ok = true, last = false;
    uint64_t received = 0, total = 0;
    while (ok && !last) {
        Corvid__NodeMessage *m = raw_recv(c);
        ok = m && m->seq == seq && m->msg_case == CORVID__NODE_MESSAGE__MSG_ENCODED_FRAME;
        if (ok) {
            const Corvid__EncodedFrame *f = m->encoded_frame;
            if (f->offset == 0) {
                ok = f->codec == (uint32_t)codec && f->width == W && f->height == H;
                total = f->size;
            }
            ok = ok && f->offset == received;
            received += f->data.len;
            last = f->last;
        } else if (m && m->msg_case == CORVID__NODE_MESSAGE__MSG_REPLY) {
            fprintf(stderr, "expected a frame, got reply %s '%s'\n", cv_result_name(m->reply->result),
                    m->reply->message);
        }
        if (m)
            corvid__node_message__free_unpacked(m, NULL);
    }
    *size = received;
    return ok && received == total && total > 0;
}

static void open_refusals(raw_client *c) {
    EXPECT_REPLY(c, send_open(c, 0, CV_CODEC_JPEG, W, H), CV_ERROR_INVALID_ARGUMENT, "stream 0");
    EXPECT_REPLY(c, send_open(c, 1, 9, W, H), CV_ERROR_INVALID_ARGUMENT, "codec 9 is not a codec");
    EXPECT_REPLY(c, send_open(c, 1, CV_CODEC_JPEG, 0, H), CV_ERROR_INVALID_ARGUMENT, "must not be 0");
    EXPECT_REPLY(c, send_open(c, 1, CV_CODEC_H264, 33, 16), CV_ERROR_INVALID_ARGUMENT, "must be even");
    EXPECT_REPLY(c, send_open(c, 1, CV_CODEC_JPEG, 9000, 16), CV_ERROR_LIMIT_EXCEEDED, "limit of 8192");
    EXPECT_REPLY(c, send_open(c, 1, CV_CODEC_PNG, 8192, 8192), CV_ERROR_LIMIT_EXCEEDED, "pixels");
    EXPECT_REPLY(c, send_open(c, 1, CV_CODEC_JPEG, UINT32_MAX, UINT32_MAX), CV_ERROR_LIMIT_EXCEEDED, "width");
}

static void read_refusals(raw_client *c) {
    const cv_rect all = { 0, 0, W, H };
    EXPECT_REPLY(c, send_read(c, 77, TEX_ID(1), all, NULL), CV_ERROR_INVALID_HANDLE, "stream 77 is not open");
    EXPECT_REPLY(c, send_read(c, 1, TEX_ID(9), all, NULL), CV_ERROR_INVALID_HANDLE, "unknown in this session");
    EXPECT_REPLY(c, send_read(c, 1, BUF_ID(1), all, NULL), CV_ERROR_WRONG_HANDLE_TYPE, "needs a texture");
    EXPECT_REPLY(c, send_read(c, 1, TEX_ID(1), (cv_rect){ 0, 0, W / 2, H }, NULL), CV_ERROR_FORMAT_MISMATCH,
                 "frames are 32x16");
    EXPECT_REPLY(c, send_read(c, 1, TEX_ID(1), (cv_rect){ 1, 0, W, H }, NULL), CV_ERROR_OUT_OF_RANGE, "(1,0)");
    EXPECT_REPLY(c, send_read(c, 1, TEX_ID(1), (cv_rect){ UINT32_MAX, UINT32_MAX, W, H }, NULL),
                 CV_ERROR_OUT_OF_RANGE, "read_encoded");
    EXPECT_REPLY(c, send_read(c, 1, TEX_ID(2), all, NULL), CV_ERROR_FORMAT_MISMATCH, "jpeg encodes RGBA8_UNORM");
    Corvid__EncodeParams p = CORVID__ENCODE_PARAMS__INIT;
    p.quality = 101;
    EXPECT_REPLY(c, send_read(c, 1, TEX_ID(1), all, &p), CV_ERROR_OUT_OF_RANGE, "quality 101");
    p.quality = 0;
    p.bitrate_kbps = CV_ENCODE_MAX_BITRATE_KBPS + 1;
    EXPECT_REPLY(c, send_read(c, 1, TEX_ID(1), all, &p), CV_ERROR_OUT_OF_RANGE, "bitrate_kbps");
    p.bitrate_kbps = 0;
    p.fps = 100000;
    EXPECT_REPLY(c, send_read(c, 1, TEX_ID(1), all, &p), CV_ERROR_OUT_OF_RANGE, "fps 100000");
    p.fps = 0;
    p.zstd_level = -1000000;
    EXPECT_REPLY(c, send_read(c, 1, TEX_ID(1), all, &p), CV_ERROR_OUT_OF_RANGE, "zstd_level");
}

/* Session A: its refusals, its four streams and no fifth, and frames after every refusal. */
static void streams_and_limits(raw_client *a) {
    make_texture(a, TEX_ID(1), CV_FORMAT_RGBA8_UNORM);
    make_texture(a, TEX_ID(2), CV_FORMAT_RGBA32F);
    cv_resource_desc buf = { .type = CV_HANDLE_BUFFER, .buffer = { .size = 256 } };
    EXPECT_REPLY(a, raw_send_create(a, BUF_ID(1), &buf), CV_OK, NULL);
    open_refusals(a);
    EXPECT_REPLY(a, send_open(a, 1, CV_CODEC_JPEG, W, H), CV_OK, NULL);
    EXPECT_REPLY(a, send_open(a, 1, CV_CODEC_PNG, W, H), CV_ERROR_ALREADY_EXISTS, "stream 1 is already open");
    read_refusals(a);
    uint64_t size = 0;
    CHECK(expect_frame(a, send_read(a, 1, TEX_ID(1), (cv_rect){ 0, 0, W, H }, NULL), CV_CODEC_JPEG, &size));
    EXPECT_REPLY(a, send_open(a, 2, CV_CODEC_H264, W, H), CV_OK, NULL);
    EXPECT_REPLY(a, send_open(a, 3, CV_CODEC_ZSTD, W, H), CV_OK, NULL);
    EXPECT_REPLY(a, send_open(a, 4, CV_CODEC_RAW, W, H), CV_OK, NULL);
    EXPECT_REPLY(a, send_open(a, 5, CV_CODEC_PNG, W, H), CV_ERROR_LIMIT_EXCEEDED, "MAX_ENCODER_STREAMS");
    CHECK(expect_frame(a, send_read(a, 3, TEX_ID(2), (cv_rect){ 0, 0, W, H }, NULL), CV_CODEC_ZSTD, &size));
    CHECK(expect_frame(a, send_read(a, 4, TEX_ID(2), (cv_rect){ 0, 0, W, H }, NULL), CV_CODEC_RAW, &size));
    CHECK_EQ_INT(size, W * H * 16);
    /* Closing frees a place; closing what is not open is refused (a close is answered only then). */
    send_close(a, 4);
    EXPECT_REPLY(a, send_close(a, 4), CV_ERROR_INVALID_HANDLE, "close_encoder: stream 4 is not open");
    EXPECT_REPLY(a, send_read(a, 4, TEX_ID(2), (cv_rect){ 0, 0, W, H }, NULL), CV_ERROR_INVALID_HANDLE,
                 "stream 4 is not open");
    EXPECT_REPLY(a, send_open(a, 5, CV_CODEC_PNG, W, H), CV_OK, NULL);
    CHECK(expect_frame(a, send_read(a, 5, TEX_ID(1), (cv_rect){ 0, 0, W, H }, NULL), CV_CODEC_PNG, &size));
}

/* Session B has its own numbers: A's stream 2 (H.264) is not B's, even over a texture of the same id. */
static void per_session(raw_client *a) {
    raw_client b;
    session(&b);
    make_texture(&b, TEX_ID(1), CV_FORMAT_RGBA8_UNORM);
    EXPECT_REPLY(&b, send_read(&b, 2, TEX_ID(1), (cv_rect){ 0, 0, W, H }, NULL), CV_ERROR_INVALID_HANDLE,
                 "stream 2 is not open in this session");
    EXPECT_REPLY(&b, send_close(&b, 2), CV_ERROR_INVALID_HANDLE, "not open");
    EXPECT_REPLY(&b, send_open(&b, 2, CV_CODEC_JPEG, W, H), CV_OK, NULL); /* B's own 2 */
    uint64_t size = 0;
    CHECK(expect_frame(&b, send_read(&b, 2, TEX_ID(1), (cv_rect){ 0, 0, W, H }, NULL), CV_CODEC_JPEG, &size));
    CHECK(expect_frame(a, send_read(a, 2, TEX_ID(1), (cv_rect){ 0, 0, W, H }, NULL), CV_CODEC_H264, &size));
    raw_close(&b); /* leaves with an open stream: the node frees it with the session */
}

/* Reads sent back to back (the worker encodes one while the session reads the next), then a close right
 * behind them: every frame comes, in order, before the close takes the stream. */
static void pipelined(raw_client *c) {
    EXPECT_REPLY(c, send_open(c, 7, CV_CODEC_H264, W, H), CV_OK, NULL);
    uint64_t seqs[3];
    for (int i = 0; i < 3; i++)
        seqs[i] = send_read(c, 7, TEX_ID(1), (cv_rect){ 0, 0, W, H }, NULL);
    send_close(c, 7); /* answered only if it fails */
    uint64_t size = 0;
    for (int i = 0; i < 3; i++)
        CHECK(expect_frame(c, seqs[i], CV_CODEC_H264, &size));
    EXPECT_REPLY(c, send_read(c, 7, TEX_ID(1), (cv_rect){ 0, 0, W, H }, NULL), CV_ERROR_INVALID_HANDLE,
                 "stream 7 is not open");
    send_read(c, 1, TEX_ID(1), (cv_rect){ 0, 0, W, H }, NULL); /* and the session ends with a frame in flight */
}

int main(void) {
    check_live_counter("encoders", cv_live_encoders);
    CHECK_OK(scratch_node_start(&node, cv_mock_backend(), 1, false));
    if (!node.node)
        return check_report("node_encode_hostile");
    raw_client a;
    session(&a);
    streams_and_limits(&a);
    per_session(&a);
    raw_close(&a); /* three streams still open */
    CHECK_EQ_INT(scratch_node_wait_sessions(&node, 5000), 0);
    CHECK_EQ_INT(cv_live_encoders(), 0);
    raw_client c; /* the node goes on serving */
    session(&c);
    make_texture(&c, TEX_ID(1), CV_FORMAT_RGBA8_UNORM);
    EXPECT_REPLY(&c, send_open(&c, 1, CV_CODEC_RAW, W, H), CV_OK, NULL);
    uint64_t size = 0, before = cv_node_get_stats(node.node).bytes_out;
    CHECK(expect_frame(&c, send_read(&c, 1, TEX_ID(1), (cv_rect){ 0, 0, W, H }, NULL), CV_CODEC_RAW, &size));
    uint64_t out = cv_node_get_stats(node.node).bytes_out - before; /* the frame counts in the node's bytes out */
    CHECK(size == W * H * 4 && out >= size && out < size + 256);
    pipelined(&c);
    raw_close(&c);
    CHECK_EQ_INT(scratch_node_wait_sessions(&node, 5000), 0);
    scratch_node_stop(&node);
    CHECK_NOTHING_LIVE();
    return check_report("node_encode_hostile");
}
