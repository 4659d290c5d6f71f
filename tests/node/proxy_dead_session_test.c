/* A proxy session that died while the node still had things to say.
 *
 * A scripted node (the rpc layer and the protocol's messages, no node code)
 * answers the hello and every request but one read, which it holds. The
 * client's read times out (cv_proxy_options.timeout_ms): the session is dead, every
 * ticket counts as finished, and so the client may release a command list whose
 * submission the node never reported. Only then does the node report that
 * submission Completed, with timings. The client must ignore it: before the
 * fix, its receiver wrote the timings into the released list (a heap
 * use-after-free, which the ASan run of this test reports). Then:
 *  - every later call fails with the death's code, naming the node;
 *  - a Reply with an error arriving after the death changes nothing either;
 *  - everything is freed. */
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "check.h"
#include "corvid/proxy.h"
#include "corvid/rpc.h"
#include "node.pb-c.h"
#include "corvid/node_protocol.h"

typedef struct script {
    atomic_uint_fast64_t ticket; /* the submission the node holds back */
    atomic_bool read_seen;       /* the read it will never answer arrived */
    atomic_bool send_late;       /* the test says: report the submission now */
    atomic_bool late_sent;       /* ... and it was sent */
    atomic_uint_fast64_t read_seq;
} script;

static void sleep_ms(long ms) { nanosleep(&(struct timespec){ ms / 1000, (ms % 1000) * 1000000L }, NULL); }

static void send_node(cv_rpc_stream *s, Corvid__NodeMessage *m) {
    uint8_t *buf = NULL;
    size_t size = 0;
    if (cv_node_pack_node(m, &buf, &size) == CV_OK)
        cv_rpc_stream_send_owned(s, buf, size);
}

static void reply(cv_rpc_stream *s, uint64_t seq, int32_t result, const char *message) {
    Corvid__Reply r = CORVID__REPLY__INIT;
    r.result = result;
    r.message = (char *)message;
    Corvid__NodeMessage m = CORVID__NODE_MESSAGE__INIT;
    m.seq = seq;
    m.msg_case = CORVID__NODE_MESSAGE__MSG_REPLY;
    m.reply = &r;
    send_node(s, &m);
}

static void hello(cv_rpc_stream *s, uint64_t seq) {
    uint32_t dispatch[3] = { 65535, 65535, 65535 };
    Corvid__DeviceInfo info = CORVID__DEVICE_INFO__INIT;
    info.label = "scripted0";
    info.name = "scripted device";
    info.backend = "mock";
    info.driver = "none";
    info.trace_path = "none";
    info.max_storage_buffer_range = 1u << 30;
    info.n_max_dispatch = 3;
    info.max_dispatch = dispatch;
    Corvid__HelloReply h = CORVID__HELLO_REPLY__INIT;
    h.protocol_version = CV_NODE_PROTOCOL_VERSION;
    h.node_name = "scripted";
    h.device = &info;
    h.session_id = 1;
    h.max_message_bytes = CV_NODE_MAX_MESSAGE_BYTES;
    Corvid__NodeMessage m = CORVID__NODE_MESSAGE__INIT;
    m.seq = seq;
    m.msg_case = CORVID__NODE_MESSAGE__MSG_HELLO;
    m.hello = &h;
    send_node(s, &m);
}

static void completed_late(cv_rpc_stream *s, uint64_t ticket) {
    Corvid__PassTiming t = CORVID__PASS_TIMING__INIT;
    t.label = "late";
    t.duration_ms = 1.0;
    Corvid__PassTiming *timings[1] = { &t };
    Corvid__Completed c = CORVID__COMPLETED__INIT;
    c.ticket = ticket;
    c.n_timings = 1;
    c.timings = timings;
    Corvid__NodeMessage m = CORVID__NODE_MESSAGE__INIT;
    m.msg_case = CORVID__NODE_MESSAGE__MSG_COMPLETED;
    m.completed = &c;
    send_node(s, &m);
}

static void on_stream(cv_rpc_stream *s, const char *method, void *user) {
    (void)method;
    script *sc = user;
    for (;;) {
        if (atomic_load(&sc->send_late) && !atomic_load(&sc->late_sent)) {
            completed_late(s, atomic_load(&sc->ticket));
            /* and an error for the read the client gave up on */
            reply(s, atomic_load(&sc->read_seq), CV_ERROR_BACKEND, "an answer nobody waits for");
            atomic_store(&sc->late_sent, true);
        }
        uint8_t *data = NULL;
        size_t size = 0;
        cv_result r = cv_rpc_stream_recv(s, 20, &data, &size);
        if (r == CV_ERROR_TIMEOUT)
            continue;
        if (r != CV_OK || !data)
            return; /* the client closed or cancelled */
        Corvid__ClientMessage *m = corvid__client_message__unpack(NULL, size, data);
        free(data);
        if (!m)
            return;
        switch (m->msg_case) {
        case CORVID__CLIENT_MESSAGE__MSG_HELLO: hello(s, m->seq); break;
        case CORVID__CLIENT_MESSAGE__MSG_SUBMIT: atomic_store(&sc->ticket, m->submit->ticket); break;
        case CORVID__CLIENT_MESSAGE__MSG_READ_BUFFER:
            atomic_store(&sc->read_seq, m->seq);
            atomic_store(&sc->read_seen, true);
            break;
        default: reply(s, m->seq, CV_OK, ""); break;
        }
        corvid__client_message__free_unpacked(m, NULL);
    }
}

int main(void) {
    /* Taken at device creation; long enough for a loaded sanitizer run to connect. */
    CHECK_OK(cv_proxy_configure(&(cv_proxy_options){ .timeout_ms = 2000 }));
    script sc = { 0 };
    const char *methods[] = { CV_NODE_METHOD_SESSION, NULL };
    cv_rpc_server *server = NULL;
    CHECK_OK(cv_rpc_server_start(&(cv_rpc_server_config){ .listen = "127.0.0.1:0",
                                                          .on_stream = on_stream,
                                                          .stream_methods = methods,
                                                          .user = &sc },
                                 &server));
    if (!server)
        return check_report("proxy_dead_session");
    char endpoint[64];
    snprintf(endpoint, sizeof(endpoint), "127.0.0.1:%d", cv_rpc_server_port(server));

    cv_context *ctx;
    cv_device *dev = NULL;
    CHECK_OK(cv_context_create(NULL, &ctx));
    CHECK_OK(cv_device_create(ctx, cv_proxy_backend(), &(cv_device_desc){ .endpoint = endpoint }, &dev));
    if (dev) {
        cv_buffer buf;
        cv_pipeline fill;
        cv_cmdlist list;
        CHECK_OK(cv_buffer_create(ctx, &(cv_buffer_desc){ .size = 256 }, &buf));
        CHECK_OK(cv_pipeline_create(ctx, "test.fill_u32", &fill));
        CHECK_OK(cv_device_load(dev, cv_any(buf)));
        CHECK_OK(cv_device_load(dev, cv_any(fill)));
        CHECK_OK(cv_cmdlist_create(ctx, &list));
        cv_command_list *l;
        CHECK_OK(cv_cmdlist_begin(ctx, list, &l));
        cv_binding b = { .resource = cv_any(buf) };
        uint32_t push[2] = { 7, 64 };
        cv_cmd_dispatch(l, CV_QUEUE_COMPUTE,
                        &(cv_dispatch_args){ .pipeline = fill,
                                             .bindings = &b,
                                             .bindings_count = 1,
                                             .push = push,
                                             .push_size = sizeof(push),
                                             .groups_x = 1,
                                             .groups_y = 1,
                                             .groups_z = 1 });
        CHECK_OK(cv_command_list_end(l));
        uint64_t ticket = 0;
        CHECK_OK(cv_device_submit(dev, list, &ticket));

        /* The node holds the read: the request times out and the session is dead. */
        uint8_t out[256];
        CHECK_RESULT(cv_device_read_buffer(dev, buf, 0, sizeof(out), out), CV_ERROR_TIMEOUT);
        CHECK(strstr(cv_last_error(), endpoint) != NULL);
        CHECK(atomic_load(&sc.read_seen));
        CHECK_EQ_INT(atomic_load(&sc.ticket), ticket);

        /* Dead: the submission counts as finished, so the list goes now. */
        CHECK(cv_device_is_lost(dev));
        CHECK_OK(cv_destroy(ctx, cv_any(list)));

        /* Now the node speaks: Completed for that submission, an error for the read. */
        cv_proxy_stats before, after = { 0 };
        CHECK_OK(cv_proxy_get_stats(dev, &before));
        atomic_store(&sc.send_late, true);
        for (int waited = 0; waited < 5000; waited += 10) {
            cv_proxy_get_stats(dev, &after);
            if (after.bytes_received > before.bytes_received && atomic_load(&sc.late_sent))
                break;
            sleep_ms(10);
        }
        CHECK(atomic_load(&sc.late_sent));
        sleep_ms(50); /* the read's error reply, the second message */

        /* Still dead with the first reason; nothing the late messages said took effect. */
        CHECK_RESULT(cv_device_wait(dev, ticket, 1000000000ull), CV_ERROR_TIMEOUT);
        CHECK(strstr(cv_last_error(), "no answer") != NULL);
        CHECK_RESULT(cv_device_read_buffer(dev, buf, 0, sizeof(out), out), CV_ERROR_TIMEOUT);
        CHECK(strstr(cv_last_error(), endpoint) != NULL);
    }
    cv_context_destroy(ctx);
    cv_rpc_server_destroy(server, 1000);
    CHECK_NOTHING_LIVE();
    return check_report("proxy_dead_session");
}
