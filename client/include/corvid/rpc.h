/* Corvid RPC: a thin layer over gRPC's C core (grpc/grpc.h), the only place in Corvid that talks to gRPC.
 *
 * The C core API changes between releases (this is written against Debian 12's 1.51.1); everything else
 * (corvid-node, the proxy backend) sees only these calls. Messages are opaque bytes: callers encode them
 * (protobuf-c, the command codec) and pick method paths themselves ("/corvid.Node/Session").
 *
 * What it offers
 *  - A client (one channel to "host:port") that opens bidirectional streams and makes unary calls.
 *  - A server that runs one handler thread per accepted stream and answers unary calls.
 *  - Streams with blocking recv (with a timeout), thread-safe send with backpressure, half-close,
 *    finish-with-status, cancel. A dead peer shows up as CV_ERROR_CONNECTION on recv and send, within
 *    about keepalive_ms + keepalive_timeout_ms when the connection goes silent, at once when it closes.
 *
 * Usage (client)
 *     cv_rpc_client *c;
 *     cv_rpc_client_config cfg = {0};                        // zero = defaults
 *     if (cv_rpc_client_create("node1:7400", &cfg, &c) != CV_OK) { ... cv_last_error() ... }
 *     cv_rpc_metadata md[] = {{"corvid-session", "42"}};
 *     cv_rpc_stream *s;
 *     cv_rpc_client_open(c, "/corvid.Node/Session", md, 1, &s);
 *     cv_rpc_stream_send(s, bytes, n);                       // copies; returns at once unless 64 MiB wait
 *     uint8_t *reply; size_t size;
 *     cv_result r = cv_rpc_stream_recv(s, 5000, &reply, &size);
 *     if (r == CV_OK && reply) { ...; free(reply); }          // reply == NULL: the server ended the stream
 *     cv_rpc_stream_close_send(s);                           // no more sends; the server sees end of stream
 *     ... recv until reply == NULL or an error; cv_rpc_stream_status(s, msg, sizeof msg) gives the status
 *     cv_rpc_stream_destroy(s);
 *     cv_rpc_client_destroy(c);
 *
 * Usage (server)
 *     static void session(cv_rpc_stream *s, const char *method, void *user) {
 *         uint8_t *m; size_t n;
 *         while (cv_rpc_stream_recv(s, UINT32_MAX, &m, &n) == CV_OK && m) { ...; free(m); }
 *         cv_rpc_stream_finish(s, 0, "");                    // optional: the layer finishes with OK
 *     }
 *     static const char *const streams[] = {"/corvid.Node/Session", NULL};
 *     cv_rpc_server_config cfg = {.listen = "0.0.0.0:7400", .on_stream = session, .stream_methods = streams};
 *     cv_rpc_server *srv;  cv_rpc_server_start(&cfg, &srv);
 *     ... cv_rpc_server_drain(srv); ... cv_rpc_server_destroy(srv, 30000);
 *
 * Threading rules
 *  - Client and server objects: create/destroy from one thread; cv_rpc_client_open, cv_rpc_client_unary,
 *    cv_rpc_server_drain, cv_rpc_server_active_streams and cv_rpc_server_port may be called from any thread.
 *  - A stream: cv_rpc_stream_recv from ONE thread at a time. cv_rpc_stream_send, close_send, finish, cancel,
 *    status, peer and metadata from any thread, concurrently with recv and each other. cv_rpc_stream_destroy
 *    (client) once, when no other thread uses the stream.
 *  - Server handlers: on_stream runs on its own thread (one per stream); the stream is valid until it returns,
 *    and it must return soon after recv/send fail (the server's destroy waits for every handler).
 *    on_unary runs on a per-call thread the layer owns, at most CV_RPC_MAX_UNARY_CALLS at once.
 *  - Each stream has its own completion queue and pump thread inside; no process-wide state is kept here
 *    beyond gRPC's own (grpc_init/grpc_shutdown are balanced per client and server object).
 *
 * Errors: functions return cv_result; cv_last_error() says why, with the gRPC status when there is one.
 * Security: plaintext unless TLS files are given (gRPC's own SSL credentials, made in one function on each
 * side: client_credentials in rpc_client.c, server_credentials in rpc_server.c). A client may carry a bearer
 * token, sent as "authorization: Bearer <token>" initial metadata on every call (streams and unary); a server
 * may check every call before it runs (on_call), with the call's method, peer and initial metadata. */
#ifndef CORVID_RPC_H
#define CORVID_RPC_H

#include <stddef.h>
#include <stdint.h>
#include "corvid/result.h"

typedef struct cv_rpc_client cv_rpc_client; /* one channel to "host:port" */
typedef struct cv_rpc_server cv_rpc_server;
typedef struct cv_rpc_stream cv_rpc_stream; /* one bidirectional-streaming call, either side */

/* Bounds of the stream machinery. */
#define CV_RPC_RECV_QUEUE_MAX 4u            /* received messages buffered before we stop reading */
#define CV_RPC_SEND_QUEUE_BYTES (64u << 20) /* queued send bytes above which send() blocks */
#define CV_RPC_DEFAULT_MAX_MESSAGE (16u << 20)
#define CV_RPC_MAX_UNARY_CALLS 64u /* concurrent unary calls a server runs; more: RESOURCE_EXHAUSTED */
#define CV_RPC_FOREVER UINT32_MAX

/* gRPC status codes, as the wire carries them (grpc_status_code). */
enum {
    CV_RPC_STATUS_OK = 0,
    CV_RPC_STATUS_CANCELLED = 1,
    CV_RPC_STATUS_UNKNOWN = 2,
    CV_RPC_STATUS_INVALID_ARGUMENT = 3,
    CV_RPC_STATUS_DEADLINE_EXCEEDED = 4,
    CV_RPC_STATUS_NOT_FOUND = 5,
    CV_RPC_STATUS_PERMISSION_DENIED = 7,
    CV_RPC_STATUS_RESOURCE_EXHAUSTED = 8,
    CV_RPC_STATUS_FAILED_PRECONDITION = 9,
    CV_RPC_STATUS_UNIMPLEMENTED = 12,
    CV_RPC_STATUS_INTERNAL = 13,
    CV_RPC_STATUS_UNAVAILABLE = 14,
};

typedef struct cv_rpc_metadata {
    const char *key, *value; /* key: lowercase [0-9a-z_.-]; value: printable ASCII (no "-bin" keys) */
} cv_rpc_metadata;

/* ---- client ---- */

typedef struct cv_rpc_client_config {
    uint32_t max_message_bytes;    /* receive and send limit; 0 = 16 MiB */
    uint32_t keepalive_ms;         /* 0 = 10000: ping interval, so a dead peer is noticed */
    uint32_t keepalive_timeout_ms; /* 0 = 5000 */
    uint32_t connect_timeout_ms;   /* 0 = 5000: how long one connection attempt may take; calls made while
                                         the node cannot be reached fail with CV_ERROR_CONNECTION (UNAVAILABLE)
                                         once the attempt failed, they do not wait for the node to come up */
    const char *bearer_token;      /* NULL = none; else sent as "authorization: Bearer <token>" on every call
                                         (printable ASCII, no spaces; copied) */
    const char *tls_ca_file;       /* NULL = plaintext; else TLS, trusting the PEM CA certificates in this file
                                         (the server's certificate must name the target's host: SAN) */
    const char *tls_cert_file;     /* with tls_key_file: a client certificate (PEM) for mutual TLS */
    const char *tls_key_file;
} cv_rpc_client_config;

/* Creates the channel; connects lazily (on the first call). `config` may be NULL (all defaults). TLS files are
 * read here: a file that cannot be read, or a certificate without its key, is CV_ERROR_IO / INVALID_ARGUMENT
 * naming it. A TLS handshake that fails (untrusted or expired certificate, plaintext server) shows up as
 * CV_ERROR_CONNECTION (UNAVAILABLE) on the calls. */
cv_result cv_rpc_client_create(const char *target, const cv_rpc_client_config *config, cv_rpc_client **out);
/* Streams must be destroyed first. NULL is ignored. */
void cv_rpc_client_destroy(cv_rpc_client *c);
/* Clients created and not yet destroyed in this process (tests check it is 0 at their end). */
uint32_t cv_rpc_live_clients(void);

/* Opens a bidi stream on `method` ("/corvid.Node/Session"), sending `metadata` (count entries) as initial
 * metadata. Returns once the call is started (does not wait for the server): a node that cannot be reached
 * shows up as CV_ERROR_CONNECTION from the first recv. */
cv_result cv_rpc_client_open(cv_rpc_client *c, const char *method, const cv_rpc_metadata *metadata, uint32_t count,
                             cv_rpc_stream **out);

/* Unary call: request bytes in, response bytes out (malloc'd, caller frees; NULL and 0 for an empty response).
 * timeout_ms: the call's deadline (0 = 10000, CV_RPC_FOREVER = none). *status (may be NULL) gets the gRPC
 * status code (0 = OK; -1 if the call could not be started). A non-OK status returns CV_ERROR_TIMEOUT for
 * DEADLINE_EXCEEDED and CV_ERROR_CONNECTION for all others, with code and message in cv_last_error(). */
cv_result cv_rpc_client_unary(cv_rpc_client *c, const char *method, const void *request, size_t size,
                              uint32_t timeout_ms, void **response, size_t *response_size, int *status);

/* ---- server ---- */

typedef struct cv_rpc_server_config {
    const char *listen;         /* "127.0.0.1:0" picks a free port */
    uint32_t max_message_bytes; /* receive and send limit; 0 = 16 MiB */
    uint32_t max_streams;       /* concurrent streams; more are refused with RESOURCE_EXHAUSTED; 0 = 1024 */
    /* A stream of a registered streaming method: called on a new thread owned by the layer; the stream is
       valid until the handler returns (the layer then finishes the call with OK if the handler did not; sends
       still queued go out first, so a client that stops reading holds the stream until it is cancelled, its
       connection dies or the server is destroyed). */
    void (*on_stream)(cv_rpc_stream *s, const char *method, void *user);
    /* A unary call of a registered unary method: request in, response out (malloc'd; the layer frees it;
       may stay NULL for an empty response) and 0, or a non-zero gRPC status with a message written to
       `message` (NUL-terminated, at most message_cap bytes). Runs on a thread of the layer's; should not
       block long (the client waits). */
    int (*on_unary)(const char *method, const void *request, size_t size, void **response, size_t *response_size,
                    char *message, size_t message_cap, void *user);
    const char *const *stream_methods; /* NULL-terminated list of full method paths; copied */
    const char *const *unary_methods;  /* the same; methods in neither list get UNIMPLEMENTED */
    /* Optional: decides whether a call of a served method may run, before any handler sees it: 0 runs it, a
       non-zero gRPC status refuses it with the message written to `message` (NUL-terminated, at most cap
       bytes). Gets the method path, the peer ("ipv4:127.0.0.1:53412") and the call's initial metadata. Runs on
       the acceptor thread: must be quick and must not block. */
    int (*on_call)(const char *method, const char *peer, const cv_rpc_metadata *metadata, uint32_t count,
                   char *message, size_t cap, void *user);
    void *user;
    /* TLS (NULL = plaintext): the server's certificate chain and private key, PEM files read at start. With
       tls_client_ca_file, every client must present a certificate signed by a CA in that file (mutual TLS);
       without it, clients are not asked for one. */
    const char *tls_cert_file, *tls_key_file, *tls_client_ca_file;
} cv_rpc_server_config;

/* Binds, starts the acceptor thread. Fails (CV_ERROR_CONNECTION) if the address cannot be bound, CV_ERROR_IO or
 * CV_ERROR_INVALID_ARGUMENT (naming the file) if a TLS file cannot be read or only one of cert/key is given. */
cv_result cv_rpc_server_start(const cv_rpc_server_config *config, cv_rpc_server **out);
int cv_rpc_server_port(const cv_rpc_server *s); /* bound port */
/* Stops accepting streams: streams that arrive later are refused with UNAVAILABLE "node is draining";
 * running streams go on. Unary calls are still served (so the node's health check can say it drains). */
void cv_rpc_server_drain(cv_rpc_server *s);
/* Waits up to timeout_ms for running streams to end, then cancels the rest (their recv/send fail), waits
 * for every handler to return, joins every thread and frees everything. NULL is ignored. */
void cv_rpc_server_destroy(cv_rpc_server *s, uint32_t timeout_ms);
/* Servers started and not yet destroyed in this process (tests check it is 0 at their end). */
uint32_t cv_rpc_live_servers(void);
/* Streams whose handler has not yet returned (and been cleaned up). */
uint32_t cv_rpc_server_active_streams(const cv_rpc_server *s);
/* Waits up to timeout_ms for the running streams to end (a deadline, however often it wakes); returns how many
 * are left. Any thread. */
uint32_t cv_rpc_server_wait_streams(cv_rpc_server *s, uint32_t timeout_ms);
/* Ends every running stream now with `status` and `message` (ahead of replies still queued): each client sees
 * that status rather than a bare cancellation, and each handler's recv and send then fail. Any thread. */
void cv_rpc_server_finish_streams(cv_rpc_server *s, int status, const char *message);

/* ---- streams, both sides ---- */

/* Blocks up to timeout_ms (CV_RPC_FOREVER = forever) for the next message. CV_OK with *data (malloc'd, caller
 * frees; non-NULL even for an empty message) and *size; CV_OK with *data == NULL: the peer closed its sending
 * side (server: the client half-closed; client: the server finished with OK); CV_ERROR_TIMEOUT; CV_ERROR_CONNECTION:
 * the call failed, was cancelled or ended with a non-OK status, or the peer is gone (cv_last_error() says
 * why, with the gRPC status when known). Messages received before a failure are delivered first.
 * One thread at a time calls recv. */
cv_result cv_rpc_stream_recv(cv_rpc_stream *s, uint32_t timeout_ms, uint8_t **data, size_t *size);

/* Queues one message; thread-safe. Copies `data` (one copy, into a gRPC slice), so the caller keeps its buffer.
 * Blocks only while more than CV_RPC_SEND_QUEUE_BYTES wait to be sent (backpressure; one message larger than
 * that is accepted when the queue is empty). Fails with CV_ERROR_CONNECTION once the call is dead or over,
 * CV_ERROR_BAD_STATE after close_send/finish. Messages go out in the order the send() calls queued them. */
cv_result cv_rpc_stream_send(cv_rpc_stream *s, const void *data, size_t size);
/* As cv_rpc_stream_send, but takes the malloc'd buffer instead of copying it:
 * gRPC frees it (free()) once sent, also when the send fails. For large
 * messages the caller has just packed. */
cv_result cv_rpc_stream_send_owned(cv_rpc_stream *s, void *data, size_t size);

/* Client: half-close (no more sends), after the queued messages. CV_ERROR_BAD_STATE on a server stream. */
cv_result cv_rpc_stream_close_send(cv_rpc_stream *s);

/* Server: ends the call with a gRPC status code and message (after queued sends went out). Idempotent (the
 * first call wins); ignored on a client stream and on a call that already failed. */
void cv_rpc_stream_finish(cv_rpc_stream *s, int status, const char *message);

/* Client: the final status code, its message copied to `message` (cap bytes, may be NULL/0); -1 while the
 * call has not ended (use it after recv returned end-of-stream or an error). Server: the status given to
 * finish, -1 before. */
int cv_rpc_stream_status(cv_rpc_stream *s, char *message, size_t cap);

/* Cancels the call (either side): the peer sees CANCELLED; our pending recv and sends fail. */
void cv_rpc_stream_cancel(cv_rpc_stream *s);

/* Client only: cancels if still live, waits for the call's internal thread, frees. NULL is ignored.
 * (Server streams belong to the layer and are freed after the handler returns.) */
void cv_rpc_stream_destroy(cv_rpc_stream *s);

/* Server: "ipv4:127.0.0.1:53412", the client as gRPC names it. Client: the target it was created with.
 * Valid for the stream's life. */
const char *cv_rpc_stream_peer(cv_rpc_stream *s);

/* Server: the initial metadata value the client sent under `key`, NULL if absent (and on a client stream). */
const char *cv_rpc_stream_metadata(cv_rpc_stream *s, const char *key);

/* ---- helpers ---- */

/* Reads a secret (a bearer token) from a file: the first line, trailing whitespace removed. It must be 1..1024
 * printable ASCII characters without spaces. `out` gets it NUL-terminated (cap >= 1025 holds any). Errors name
 * the file; the secret never appears in a message. */
cv_result cv_rpc_read_token_file(const char *path, char *out, size_t cap);

/* Reads a whole (PEM) file into a malloc'd NUL-terminated string, at most 1 MiB. Errors name the file and `what`. */
cv_result cv_rpc_read_pem_file(const char *path, const char *what, char **out);

#endif
