/* bench_rpc: one-way streaming of 1 MiB messages over loopback through the RPC layer (corvid/rpc.h),
 * against a raw gRPC C core stream moving the same bytes in the same run.
 *
 * The raw peer is the floor of what the core allows: one send in flight, the same message buffer sent
 * each time without copying (a slice over static bytes), a receiver that only counts bytes. The layer
 * copies each message once on send and once on receive (into the malloc'd buffer recv hands out) and
 * moves it through its queues and pump threads: the difference is what that costs.
 *
 * Usage: bench_rpc [total MiB, default 1024] [message KiB, default 1024] */
#include "bench_util.h"
#include "corvid/rpc.h"

#include <grpc/grpc.h>
#include <grpc/grpc_security.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define METHOD "/bench.Sink/Stream"

/* ---- through the layer ---- */

static atomic_ullong layer_received;

static void sink_stream(cv_rpc_stream *s, const char *method, void *user) {
    (void)method;
    (void)user;
    for (;;) {
        uint8_t *m;
        size_t n;
        if (cv_rpc_stream_recv(s, CV_RPC_FOREVER, &m, &n) != CV_OK || !m)
            return;
        atomic_fetch_add(&layer_received, n);
        free(m);
    }
}

static double run_layer(const uint8_t *msg, size_t size, size_t count) {
    static const char *const methods[] = { METHOD, NULL };
    cv_rpc_server_config scfg = { .listen = "127.0.0.1:0", .on_stream = sink_stream, .stream_methods = methods };
    cv_rpc_server *server;
    atomic_store(&layer_received, 0);
    if (cv_rpc_server_start(&scfg, &server) != CV_OK) {
        fprintf(stderr, "server: %s\n", cv_last_error());
        exit(1);
    }
    char target[64];
    snprintf(target, sizeof target, "127.0.0.1:%d", cv_rpc_server_port(server));
    cv_rpc_client *c;
    cv_rpc_stream *s;
    cv_rpc_client_create(target, NULL, &c);
    cv_rpc_client_open(c, METHOD, NULL, 0, &s);
    cv_rpc_stream_send(s, msg, 1); /* connect before timing */
    while (atomic_load(&layer_received) < 1)
        ;
    atomic_store(&layer_received, 0);

    double t0 = bench_now();
    for (size_t i = 0; i < count; i++)
        if (cv_rpc_stream_send(s, msg, size) != CV_OK) {
            fprintf(stderr, "send: %s\n", cv_last_error());
            exit(1);
        }
    cv_rpc_stream_close_send(s);
    uint8_t *m;
    size_t n;
    cv_result r = cv_rpc_stream_recv(s, 600000, &m, &n); /* end of stream: the server read everything */
    double dt = bench_now() - t0;
    if (r != CV_OK || m || atomic_load(&layer_received) != (unsigned long long)size * count) {
        fprintf(stderr, "layer: received %llu of %zu bytes (%s)\n", atomic_load(&layer_received), size * count,
                cv_last_error());
        exit(1);
    }
    cv_rpc_stream_destroy(s);
    cv_rpc_client_destroy(c);
    cv_rpc_server_destroy(server, 1000);
    return dt;
}

/* ---- raw core ---- */

typedef struct raw_server {
    grpc_server *server;
    grpc_completion_queue *cq;
    int port;
    unsigned long long received;
} raw_server;

static grpc_event wait_tag(grpc_completion_queue *cq) {
    return grpc_completion_queue_next(cq, gpr_inf_future(GPR_CLOCK_REALTIME), NULL);
}

static void *raw_server_main(void *arg) {
    raw_server *rs = arg;
    grpc_call *call = NULL;
    grpc_call_details details;
    grpc_metadata_array md;
    grpc_call_details_init(&details);
    grpc_metadata_array_init(&md);
    grpc_completion_queue *call_cq = grpc_completion_queue_create_for_next(NULL);
    grpc_server_request_call(rs->server, &call, &details, &md, call_cq, rs->cq, (void *)1);
    wait_tag(rs->cq);

    grpc_op initial = { .op = GRPC_OP_SEND_INITIAL_METADATA };
    grpc_call_start_batch(call, &initial, 1, (void *)2, NULL);
    wait_tag(call_cq);
    for (;;) {
        grpc_byte_buffer *bb = NULL;
        grpc_op op = { .op = GRPC_OP_RECV_MESSAGE };
        op.data.recv_message.recv_message = &bb;
        grpc_call_start_batch(call, &op, 1, (void *)3, NULL);
        grpc_event ev = wait_tag(call_cq);
        if (!ev.success || !bb)
            break;
        rs->received += grpc_byte_buffer_length(bb);
        grpc_byte_buffer_destroy(bb);
    }
    int cancelled = 0;
    grpc_slice details_out = grpc_empty_slice();
    grpc_op end[2] = { { .op = GRPC_OP_SEND_STATUS_FROM_SERVER }, { .op = GRPC_OP_RECV_CLOSE_ON_SERVER } };
    end[0].data.send_status_from_server.status = GRPC_STATUS_OK;
    end[0].data.send_status_from_server.status_details = &details_out;
    end[1].data.recv_close_on_server.cancelled = &cancelled;
    grpc_call_start_batch(call, end, 2, (void *)4, NULL);
    wait_tag(call_cq);
    grpc_call_unref(call);
    grpc_completion_queue_shutdown(call_cq);
    while (wait_tag(call_cq).type != GRPC_QUEUE_SHUTDOWN) {
    }
    grpc_completion_queue_destroy(call_cq);
    grpc_call_details_destroy(&details);
    grpc_metadata_array_destroy(&md);
    return NULL;
}

static double run_raw(const uint8_t *msg, size_t size, size_t count, unsigned long long *received) {
    grpc_init();
    grpc_arg args[] = {
        { .type = GRPC_ARG_INTEGER, .key = GRPC_ARG_MAX_RECEIVE_MESSAGE_LENGTH, .value.integer = 16 << 20 }
    };
    grpc_channel_args ca = { .num_args = 1, .args = args };
    raw_server rs = { 0 };
    rs.server = grpc_server_create(&ca, NULL);
    rs.cq = grpc_completion_queue_create_for_next(NULL);
    grpc_server_register_completion_queue(rs.server, rs.cq, NULL);
    grpc_server_credentials *sc = grpc_insecure_server_credentials_create();
    rs.port = grpc_server_add_http2_port(rs.server, "127.0.0.1:0", sc);
    grpc_server_credentials_release(sc);
    grpc_server_start(rs.server);
    pthread_t t;
    pthread_create(&t, NULL, raw_server_main, &rs);

    char target[64];
    snprintf(target, sizeof target, "127.0.0.1:%d", rs.port);
    grpc_channel_credentials *cc = grpc_insecure_credentials_create();
    grpc_channel *ch = grpc_channel_create(target, cc, &ca);
    grpc_channel_credentials_release(cc);
    grpc_completion_queue *cq = grpc_completion_queue_create_for_next(NULL);
    grpc_slice method = grpc_slice_from_static_string(METHOD);
    grpc_call *call = grpc_channel_create_call(ch, NULL, GRPC_PROPAGATE_DEFAULTS, cq, method, NULL,
                                               gpr_inf_future(GPR_CLOCK_REALTIME), NULL);
    grpc_metadata_array trailing;
    grpc_metadata_array_init(&trailing);
    grpc_status_code status;
    grpc_slice details = grpc_empty_slice();
    grpc_op st = { .op = GRPC_OP_RECV_STATUS_ON_CLIENT };
    st.data.recv_status_on_client.trailing_metadata = &trailing;
    st.data.recv_status_on_client.status = &status;
    st.data.recv_status_on_client.status_details = &details;
    grpc_call_start_batch(call, &st, 1, (void *)10, NULL);
    grpc_op initial = { .op = GRPC_OP_SEND_INITIAL_METADATA };
    grpc_call_start_batch(call, &initial, 1, (void *)11, NULL);
    wait_tag(cq);

    grpc_slice payload = grpc_slice_from_static_buffer(msg, size); /* no copy: the floor */
    double t0 = bench_now();
    for (size_t i = 0; i < count; i++) {
        grpc_byte_buffer *bb = grpc_raw_byte_buffer_create(&payload, 1);
        grpc_op op = { .op = GRPC_OP_SEND_MESSAGE };
        op.data.send_message.send_message = bb;
        grpc_call_start_batch(call, &op, 1, (void *)12, NULL);
        wait_tag(cq);
        grpc_byte_buffer_destroy(bb);
    }
    grpc_op close = { .op = GRPC_OP_SEND_CLOSE_FROM_CLIENT };
    grpc_call_start_batch(call, &close, 1, (void *)13, NULL);
    /* The status is delivered only once the client has read the (empty) response stream. */
    grpc_metadata_array initial_md;
    grpc_metadata_array_init(&initial_md);
    grpc_byte_buffer *none = NULL;
    grpc_op reads[2] = { { .op = GRPC_OP_RECV_INITIAL_METADATA }, { .op = GRPC_OP_RECV_MESSAGE } };
    reads[0].data.recv_initial_metadata.recv_initial_metadata = &initial_md;
    reads[1].data.recv_message.recv_message = &none;
    grpc_call_start_batch(call, reads, 2, (void *)14, NULL);
    for (int i = 0; i < 3; i++) /* close, reads, status: the server read everything */
        wait_tag(cq);
    double dt = bench_now() - t0;
    pthread_join(t, NULL);
    *received = rs.received;

    grpc_call_unref(call);
    grpc_slice_unref(details);
    grpc_metadata_array_destroy(&trailing);
    grpc_metadata_array_destroy(&initial_md);
    grpc_completion_queue_shutdown(cq);
    while (wait_tag(cq).type != GRPC_QUEUE_SHUTDOWN) {
    }
    grpc_completion_queue_destroy(cq);
    grpc_channel_destroy(ch);
    grpc_server_shutdown_and_notify(rs.server, rs.cq, (void *)99);
    grpc_server_cancel_all_calls(rs.server);
    wait_tag(rs.cq);
    grpc_server_destroy(rs.server);
    grpc_completion_queue_shutdown(rs.cq);
    while (wait_tag(rs.cq).type != GRPC_QUEUE_SHUTDOWN) {
    }
    grpc_completion_queue_destroy(rs.cq);
    grpc_shutdown();
    return dt;
}

int main(int argc, char **argv) {
    size_t total_mib = argc > 1 ? strtoul(argv[1], NULL, 10) : 1024;
    size_t size = (argc > 2 ? strtoul(argv[2], NULL, 10) : 1024) << 10;
    size_t count = (total_mib << 20) / size;
    uint8_t *msg = malloc(size);
    for (size_t i = 0; i < size; i++)
        msg[i] = (uint8_t)(i * 31);
    char machine[256];
    bench_machine(machine, sizeof machine);
    printf("bench_rpc: %zu messages of %zu KiB one way over loopback (%s; gRPC core %s)\n", count, size >> 10,
           machine, grpc_version_string());
    for (int round = 0; round < 2; round++) {
        unsigned long long raw_bytes = 0;
        double raw = run_raw(msg, size, count, &raw_bytes);
        double layer = run_layer(msg, size, count);
        double mb = (double)(size * count) / 1e6;
        printf("  round %d: corvid rpc layer %7.0f MB/s   raw grpc core %7.0f MB/s%s   (layer/raw %.2f)\n", round + 1,
               mb / layer, mb / raw, raw_bytes == size * count ? "" : " (raw lost bytes!)", raw / layer);
    }
    free(msg);
    return 0;
}
