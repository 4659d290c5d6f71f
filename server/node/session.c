/* One client session of corvid-node: a bidirectional stream of node.proto
 * messages, processed strictly in order on the stream's thread.
 *
 * The session owns a context, one device instance of the node device the client
 * chose in Hello, and the map from the client's handle ids to its own. Every
 * message is unpacked into a size-limited arena and checked before anything
 * runs; a malformed message or a protocol violation ends the session with
 * INVALID_ARGUMENT, a wrong request is answered with its cv_result and message,
 * and either way nothing of the node or of other sessions changes.
 *
 * A second thread, the completion watcher, waits for the device to finish each
 * submission in ticket order and sends Completed (with pass timings) to the
 * client, so the client learns of finished work without asking. It is also
 * the watchdog: a submission not finished within the node's budget
 * (cv_node_config.submit_timeout_ms) ends the session with DEADLINE_EXCEEDED,
 * and its device, whose GPU may still be running that work, is abandoned:
 * leaked rather than destroyed (destroying waits for the GPU, and freeing what
 * the GPU still uses is not safe), counted in cv_node_stats.devices_abandoned.
 * A session's teardown likewise waits a bounded time for its work, so a
 * drain (SIGTERM) never hangs on a GPU that does not finish. */
#include <inttypes.h>
#include <stdatomic.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "corvid/clock.h"
#include "corvid/command_codec.h"
#include "corvid/hash_map.h"
#include "corvid/sha256.h"
#include "node_internal.h"
#include "peer.h"
#include "proto_arena.h"
#include "session_encode.h"

/* grpc status codes used here (grpc/status.h; the session does not include gRPC). */
enum {
    STATUS_OK = 0,
    STATUS_INVALID_ARGUMENT = 3,
    STATUS_DEADLINE_EXCEEDED = 4,
    STATUS_RESOURCE_EXHAUSTED = 8,
    STATUS_FAILED_PRECONDITION = 9,
    STATUS_INTERNAL = 13,
};

#define MAX_PENDING_SUBMITS 1024u

typedef struct pending_submit {
    uint64_t client_ticket;
    uint64_t node_ticket; /* 0: the submit failed; result/message say why */
    cv_result result;
    char message[256];
    uint64_t transfer_failure; /* skipped because of this unacknowledged transfer failure */
    bool refused;              /* ran, with a command the device refused (cv_device_wait: OUT_OF_RANGE) */
} pending_submit;

typedef struct session {
    cv_node *node;
    cv_rpc_stream *stream;
    uint64_t id;
    char peer[128];
    cv_context *ctx;
    cv_device *dev;
    uint32_t device_index;
    session_encoders encoders; /* OpenEncoder's streams (session_encode.h) */
    cv_hash_map map;           /* the client's handle ids -> the node's own (a client reaches only what it made) */
    proto_arena arena;

    /* The blob being received, if any. */
    cv_content_upload *upload;
    uint8_t upload_sha[CV_SHA256_BYTES];
    bool upload_skipping; /* the store had it already or refused it, or the quota refused it: chunks are dropped */
    bool upload_refused;  /* ... the quota refused it */
    uint64_t upload_size;
    /* The last blob the content store refused (too large for it, or no room):
     * a write naming it gets the same answer as its upload, not "not found". */
    bool store_refused;
    uint8_t store_refused_sha[CV_SHA256_BYTES];
    cv_result store_refused_result;
    char store_refused_message[512];

    /* What the session holds, against the node's quotas (node->quota). */
    uint64_t memory_bytes;   /* device memory of its live resources */
    uint32_t resources;      /* live resources */
    uint64_t uploaded_bytes; /* added to the content store, over its life */
    uint32_t inflight;       /* real submissions not yet reported (under lock) */

    uint64_t last_client_ticket;
    uint64_t last_node_ticket; /* the latest real submission, 0: none */
    atomic_bool hung;          /* the watchdog gave up on the device (session thread reads it at the end) */

    /* Node-to-node transfers (peer.h): the inbox peers deliver into, and the
     * failed await the client has not yet acknowledged (0: none). */
    peer_inbox *inbox;
    uint64_t failure, last_failure;
    uint64_t failure_transfer; /* the transfer whose await started it */
    cv_result failure_result;
    char failure_message[768];

    /* Submissions handed to the watcher, oldest first (a ring). */
    pthread_mutex_t lock;
    pthread_cond_t cond;
    pending_submit *pending;
    uint32_t pending_head, pending_count;
    bool stopping;       /* report what is pending, then stop */
    atomic_bool abandon; /* the client is gone: report nothing more */
    bool watcher_started;
    pthread_t watcher;
} session;

/* One line about this session, escaped and rate-limited by kind (node_log.h). */
static void log_line(session *s, node_log_kind kind, const char *fmt, ...) __attribute__((format(printf, 3, 4)));
static void log_line(session *s, node_log_kind kind, const char *fmt, ...) {
    if (!s->node->config.log_sessions)
        return;
    char text[768];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(text, sizeof(text), fmt, ap);
    va_end(ap);
    node_log(&s->node->log, kind, "session %" PRIu64 " (%s): %s", s->id, s->peer, text);
}

/* ---- sending --------------------------------------------------------------- */

static cv_result send_node_message(session *s, const Corvid__NodeMessage *m) {
    uint8_t *buf;
    size_t size;
    cv_result r = cv_node_pack_node(m, &buf, &size);
    if (r != CV_OK)
        return r;
    /* Counted before the send, which may return after the client has the message:
     * a scrape then never shows less than the client received. */
    atomic_fetch_add(&s->node->bytes_out, size);
    r = cv_rpc_stream_send_owned(s->stream, buf, size);
    if (r != CV_OK)
        atomic_fetch_sub(&s->node->bytes_out, size);
    return r;
}

static void send_reply_failure(session *s, uint64_t seq, cv_result result, const char *message, uint64_t failure) {
    Corvid__Reply reply = CORVID__REPLY__INIT;
    reply.transfer_failure = failure;
    reply.result = result;
    char text[1024]; /* client labels in it, escaped: a proto3 string must be valid UTF-8 */
    cv_log_escape(text, sizeof(text), message);
    reply.message = text;
    Corvid__NodeMessage m = CORVID__NODE_MESSAGE__INIT;
    m.seq = seq;
    m.msg_case = CORVID__NODE_MESSAGE__MSG_REPLY;
    m.reply = &reply;
    if (result != CV_OK) {
        atomic_fetch_add(&s->node->errors, 1);
        log_line(s, NODE_LOG_REQUEST_ERROR, "request %" PRIu64 ": %s: %s", seq, cv_result_name(result), message);
    }
    send_node_message(s, &m);
}

static void send_reply(session *s, uint64_t seq, cv_result result, const char *message) {
    send_reply_failure(s, seq, result, message, 0);
}

/* Answers a request that failed with the thread's last error. */
static void reply_error(session *s, uint64_t seq, cv_result r) { send_reply(s, seq, r, cv_last_error()); }

/* ---- the completion watcher ------------------------------------------------ */

static void send_completed(session *s, const pending_submit *p) {
    Corvid__Completed done = CORVID__COMPLETED__INIT;
    done.ticket = p->client_ticket;
    done.result = p->result;
    char message[4 * sizeof(p->message)]; /* client labels in it: escaped, as replies are */
    cv_log_escape(message, sizeof(message), p->message);
    done.message = message;
    done.transfer_failure = p->transfer_failure;
    done.refused = p->refused;
    cv_pass_timing timings[32];
    Corvid__PassTiming items[32];
    Corvid__PassTiming *ptrs[32];
    uint32_t n = 0;
    if (p->node_ticket && p->result == CV_OK && cv_device_timings(s->dev, p->node_ticket, timings, 32, &n) == CV_OK) {
        for (uint32_t i = 0; i < n && i < 32; i++) {
            corvid__pass_timing__init(&items[i]);
            items[i].label = timings[i].label;
            items[i].start_ms = timings[i].start_ms;
            items[i].duration_ms = timings[i].duration_ms;
            ptrs[i] = &items[i];
        }
        done.n_timings = n < 32 ? n : 32;
        done.timings = ptrs;
        cv_node_metrics_passes(s->node->metrics, timings, (uint32_t)done.n_timings);
    }
    Corvid__NodeMessage m = CORVID__NODE_MESSAGE__INIT;
    m.msg_case = CORVID__NODE_MESSAGE__MSG_COMPLETED;
    m.completed = &done;
    send_node_message(s, &m);
}

static uint32_t submit_budget_ms(const cv_node *node) {
    return node->config.submit_timeout_ms ? node->config.submit_timeout_ms : CV_NODE_DEFAULT_SUBMIT_TIMEOUT_MS;
}

/* The watchdog fired on p: the client hears why (in p's Completed and as the
 * stream's status), the device is abandoned, and the watcher stops. */
static void give_up(session *s, pending_submit *p) {
    uint32_t budget = submit_budget_ms(s->node);
    p->result = CV_ERROR_DEVICE_LOST;
    snprintf(p->message, sizeof(p->message),
             "submission of ticket %" PRIu64
             " did not complete in %u.%03u s (corvid-node --submit-timeout): "
             "session ended, its device abandoned",
             p->client_ticket, budget / 1000, budget % 1000);
    atomic_store(&s->hung, true);
    cv_device_abandon(s->dev); /* the session thread's host waits on it give up */
    atomic_fetch_add(&s->node->devices_abandoned, 1);
    atomic_fetch_add(&s->node->errors, 1);
    log_line(s, NODE_LOG_ALWAYS, "%s", p->message);
    pthread_mutex_lock(&s->lock);
    s->abandon = true; /* nothing more is reported: a submit waiting for room goes on */
    pthread_cond_broadcast(&s->cond);
    pthread_mutex_unlock(&s->lock);
    send_completed(s, p);
    cv_rpc_stream_finish(s->stream, STATUS_DEADLINE_EXCEEDED, p->message);
}

/* Waits for p's ticket in bounded slices, so an ending session is not held by
 * a long frame. Returns false when the watcher must stop: the session is
 * abandoned, or the watchdog fired. */
static bool wait_submission(session *s, pending_submit *p) {
    uint64_t deadline = cv_deadline_after_ms(submit_budget_ms(s->node));
    cv_result r;
    do {
        r = cv_device_wait(s->dev, p->node_ticket, 100ull * 1000 * 1000);
        if (r == CV_ERROR_TIMEOUT && cv_deadline_passed(deadline)) {
            give_up(s, p);
            return false;
        }
    } while (r == CV_ERROR_TIMEOUT && !s->abandon);
    if (r == CV_ERROR_TIMEOUT)
        return false;
    if (r != CV_OK) {
        p->result = r;
        p->refused = r == CV_ERROR_OUT_OF_RANGE;
        snprintf(p->message, sizeof(p->message), "%s", cv_last_error());
    }
    return true;
}

static void *watcher_main(void *arg) {
    session *s = arg;
    pthread_mutex_lock(&s->lock);
    for (;;) {
        while (!s->pending_count && !s->stopping)
            pthread_cond_wait(&s->cond, &s->lock);
        if (!s->pending_count || s->abandon)
            break; /* stopping with nothing left to report, or nobody to report to */
        pending_submit p = s->pending[s->pending_head];
        pthread_mutex_unlock(&s->lock);
        if (p.node_ticket && !wait_submission(s, &p))
            return NULL; /* the lock is not held here */
        /* Out of the in-flight count before the client hears of it: a client that keeps within the
         * quota it was told (HelloReply.quotas) is never refused. */
        pthread_mutex_lock(&s->lock);
        if (p.node_ticket)
            s->inflight--;
        pthread_mutex_unlock(&s->lock);
        send_completed(s, &p);
        pthread_mutex_lock(&s->lock);
        s->pending_head = (s->pending_head + 1) % MAX_PENDING_SUBMITS;
        s->pending_count--;
        pthread_cond_broadcast(&s->cond);
    }
    pthread_mutex_unlock(&s->lock);
    return NULL;
}

static void queue_completion(session *s, const pending_submit *p) {
    pthread_mutex_lock(&s->lock);
    /* The client keeps few submissions in flight; a flood waits here, which
     * stops reading from the stream and so pushes back on the client. */
    while (s->pending_count == MAX_PENDING_SUBMITS && !s->abandon)
        pthread_cond_wait(&s->cond, &s->lock);
    s->pending[(s->pending_head + s->pending_count) % MAX_PENDING_SUBMITS] = *p;
    s->pending_count++;
    if (p->node_ticket)
        s->inflight++;
    pthread_cond_broadcast(&s->cond);
    pthread_mutex_unlock(&s->lock);
}

/* ---- handles ----------------------------------------------------------------- */

/* The node handle for a client id of an expected type (CV_HANDLE_NONE: any). */
static cv_result translate(session *s, uint64_t client_id, cv_handle_type type, const char *what, uint64_t *out) {
    *out = 0; /* written on failure too */
    if (client_id == 0)
        return cv_error(CV_ERROR_INVALID_HANDLE, "%s: null handle", what);
    if (type != CV_HANDLE_NONE && cv_handle_type_of(client_id) != type)
        return cv_error(CV_ERROR_WRONG_HANDLE_TYPE, "%s: needs a %s handle, got a %s handle (0x%016" PRIx64 ")", what,
                        cv_handle_type_name(type), cv_handle_type_name(cv_handle_type_of(client_id)), client_id);
    uint64_t id;
    if (!cv_hash_map_get(&s->map, client_id, &id))
        return cv_error(CV_ERROR_INVALID_HANDLE,
                        "%s: %s handle 0x%016" PRIx64
                        " is unknown in this session "
                        "(never created here, or destroyed)",
                        what, cv_handle_type_name(cv_handle_type_of(client_id)), client_id);
    *out = id;
    return CV_OK;
}

typedef struct map_state {
    session *s;
    cv_result result;
    uint32_t command;
    char message[512];
} map_state;

static uint64_t map_list_handle(uint64_t client_id, void *user) {
    map_state *st = user;
    uint64_t id = 0;
    if (!cv_hash_map_get(&st->s->map, client_id, &id) && st->result == CV_OK) {
        st->result = CV_ERROR_INVALID_HANDLE;
        snprintf(st->message, sizeof(st->message),
                 "command %u: %s handle 0x%016" PRIx64
                 " is unknown in this "
                 "session",
                 st->command, cv_handle_type_name(cv_handle_type_of(client_id)), client_id);
    }
    return id ? id : client_id;
}

/* ---- quotas -------------------------------------------------------------------- */

/* Refuses a request over a session quota: counted, and the session goes on. */
static cv_result quota_refuse(session *s, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static cv_result quota_refuse(session *s, const char *fmt, ...) {
    char text[512];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(text, sizeof(text), fmt, ap);
    va_end(ap);
    atomic_fetch_add(&s->node->quota_refusals, 1);
    return cv_error(CV_ERROR_LIMIT_EXCEEDED, "session quota exceeded: %s", text);
}

/* ---- requests ------------------------------------------------------------------ */

/* Counts a resource created (sign 1) or destroyed (-1): the session's quota
 * figures and the device's memory gauge. */
static void track_bytes(session *s, const cv_resource_desc *desc, int sign) {
    uint64_t bytes = cv_node_resource_bytes(desc);
    if (sign > 0) {
        s->resources++;
        s->memory_bytes += bytes;
    } else {
        s->resources--;
        s->memory_bytes -= bytes;
        cv_node_memory_release(s->node, bytes);
    }
    cv_node_metrics_device_bytes(s->node->metrics, s->device_index, sign * (int64_t)bytes);
}

static cv_result do_create(session *s, const Corvid__CreateResource *m) {
    cv_resource_desc desc;
    cv_result r = cv_node_desc_from_msg(m, &desc);
    if (r != CV_OK)
        return r;
    if (m->id == 0)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "create: handle 0 is the null handle");
    if (cv_hash_map_get(&s->map, m->id, NULL))
        return cv_error(CV_ERROR_ALREADY_LOADED, "create: handle 0x%016" PRIx64 " already exists in this session",
                        m->id);
    const cv_node_quota *q = &s->node->quota;
    if (s->resources >= q->resources)
        return quota_refuse(s,
                            "create: the session holds %u resources, its limit (corvid-node --quota-resources "
                            "%u)",
                            s->resources, q->resources);
    uint64_t bytes = cv_node_resource_bytes(&desc);
    if (bytes > q->memory_bytes - s->memory_bytes)
        return quota_refuse(s,
                            "create of %" PRIu64 " bytes: the session holds %" PRIu64
                            " bytes of device memory "
                            "of its limit of %" PRIu64 " (corvid-node --quota-memory %" PRIu64 ")",
                            bytes, s->memory_bytes, q->memory_bytes, q->memory_bytes);
    r = cv_node_memory_reserve(s->node, bytes); /* the node-wide limit, over every session */
    if (r != CV_OK)
        return r;
    cv_handle h = { 0 };
    switch (desc.type) {
    case CV_HANDLE_BUFFER: r = cv_buffer_create(s->ctx, &desc.buffer, (cv_buffer *)&h); break;
    case CV_HANDLE_TEXTURE: r = cv_texture_create(s->ctx, &desc.texture, (cv_texture *)&h); break;
    case CV_HANDLE_SAMPLER: r = cv_sampler_create(s->ctx, &desc.sampler, (cv_sampler *)&h); break;
    case CV_HANDLE_PIPELINE: r = cv_pipeline_create(s->ctx, desc.pipeline.name, (cv_pipeline *)&h); break;
    case CV_HANDLE_ACCEL: r = cv_accel_create(s->ctx, &desc.accel, (cv_accel *)&h); break;
    case CV_HANDLE_CMDLIST: r = cv_cmdlist_create(s->ctx, (cv_cmdlist *)&h); break;
    default: r = cv_error(CV_ERROR_MALFORMED, "create: unknown resource type"); break;
    }
    if (r != CV_OK) {
        cv_node_memory_release(s->node, bytes);
        return r;
    }
    if (desc.type != CV_HANDLE_CMDLIST)
        r = cv_device_load(s->dev, h);
    if (r == CV_OK)
        r = cv_hash_map_put(&s->map, m->id, h.id);
    if (r != CV_OK) {
        char why[512];
        snprintf(why, sizeof(why), "%s", cv_last_error());
        cv_destroy(s->ctx, h);
        cv_node_memory_release(s->node, bytes);
        return cv_error(r, "%s", why);
    }
    track_bytes(s, &desc, 1);
    return CV_OK;
}

static cv_result do_destroy(session *s, const Corvid__DestroyResource *m) {
    uint64_t id;
    cv_result r = translate(s, m->id, CV_HANDLE_NONE, "destroy", &id);
    cv_resource_desc desc = { .type = CV_HANDLE_CMDLIST }; /* lists have no description, and no bytes */
    if (r == CV_OK && cv_handle_type_of(id) != CV_HANDLE_CMDLIST)
        r = cv_context_describe(s->ctx, (cv_handle){ id }, &desc);
    if (r == CV_OK)
        r = cv_destroy(s->ctx, (cv_handle){ id });
    if (r == CV_OK) {
        cv_hash_map_remove(&s->map, m->id, NULL);
        track_bytes(s, &desc, -1);
    }
    return r;
}

static void end_upload(session *s) {
    if (s->upload)
        cv_content_upload_abort(s->upload);
    s->upload = NULL;
    s->upload_skipping = false;
    s->upload_refused = false;
    s->upload_size = 0;
}

static cv_result do_blob_query(session *s, uint64_t seq, const Corvid__BlobQuery *m) {
    if (m->n_sha256 > CV_NODE_MAX_BLOB_QUERY)
        return cv_error(CV_ERROR_LIMIT_EXCEEDED, "blob_query: %zu hashes, at most %u", m->n_sha256,
                        CV_NODE_MAX_BLOB_QUERY);
    for (size_t i = 0; i < m->n_sha256; i++) {
        cv_result r = cv_node_check_sha(m->sha256[i], "blob_query.sha256");
        if (r != CV_OK)
            return r;
    }
    protobuf_c_boolean *present = calloc(m->n_sha256 ? m->n_sha256 : 1, sizeof(*present));
    if (!present)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "blob_query");
    for (size_t i = 0; i < m->n_sha256; i++)
        present[i] = cv_content_store_has(s->node->store, m->sha256[i].data);
    Corvid__BlobStatus status = CORVID__BLOB_STATUS__INIT;
    status.n_present = m->n_sha256;
    status.present = present;
    Corvid__NodeMessage out = CORVID__NODE_MESSAGE__INIT;
    out.seq = seq;
    out.msg_case = CORVID__NODE_MESSAGE__MSG_BLOB_STATUS;
    out.blob_status = &status;
    send_node_message(s, &out);
    free(present);
    return CV_OK;
}

/* The store refused a blob's first chunk (cv_last_error says why): its later
 * chunks are dropped without a word each, and writes naming it get this answer. */
static cv_result refuse_blob(session *s, const Corvid__BlobChunk *m, cv_result r) {
    s->store_refused = true;
    memcpy(s->store_refused_sha, m->sha256.data, CV_SHA256_BYTES);
    s->store_refused_result = r;
    snprintf(s->store_refused_message, sizeof(s->store_refused_message), "%s", cv_last_error());
    memcpy(s->upload_sha, m->sha256.data, CV_SHA256_BYTES);
    s->upload_size = m->size;
    s->upload_skipping = m->offset + m->data.len < m->size;
    return cv_error(r, "blob_chunk: %s", s->store_refused_message);
}

static cv_result do_blob_chunk(session *s, const Corvid__BlobChunk *m) {
    cv_result r = cv_node_check_sha(m->sha256, "blob_chunk.sha256");
    if (r != CV_OK)
        return r;
    bool current = (s->upload || s->upload_skipping) && memcmp(s->upload_sha, m->sha256.data, CV_SHA256_BYTES) == 0;
    if (!current) {
        /* A new blob: an unfinished one before it was abandoned half way. */
        bool abandoned = s->upload != NULL;
        end_upload(s);
        if (m->offset != 0)
            return cv_error(CV_ERROR_OUT_OF_RANGE,
                            "blob_chunk: first chunk of a blob at offset %" PRIu64 " (must be 0)%s", m->offset,
                            abandoned ? "; the previous upload was abandoned" : "");
        /* Waits while another session uploads the same blob (content_store.h). */
        r = cv_content_upload_begin(s->node->store, m->sha256.data, m->size, &s->upload);
        if (s->store_refused && memcmp(s->store_refused_sha, m->sha256.data, CV_SHA256_BYTES) == 0)
            s->store_refused = false; /* asked again: the new answer counts */
        if (r == CV_ERROR_ALREADY_EXISTS) {
            s->upload = NULL;
            s->upload_skipping = true;
        } else if (r != CV_OK) {
            s->upload = NULL;
            return refuse_blob(s, m, r);
        }
        memcpy(s->upload_sha, m->sha256.data, CV_SHA256_BYTES);
        s->upload_size = m->size;
        uint64_t limit = s->node->quota.upload_bytes;
        if (s->upload && m->size > limit - s->uploaded_bytes) {
            /* Refused: the blob's later chunks are dropped, and nothing reaches the store. */
            cv_content_upload_abort(s->upload);
            s->upload = NULL;
            s->upload_skipping = s->upload_refused = true;
            if (m->offset + m->data.len >= s->upload_size)
                end_upload(s);
            return quota_refuse(s,
                                "upload of a %" PRIu64 "-byte blob: the session has sent %" PRIu64
                                " bytes to "
                                "the upload cache of its limit of %" PRIu64 " (corvid-node --quota-upload %" PRIu64
                                ")",
                                m->size, s->uploaded_bytes, limit, limit);
        }
        if (s->upload)
            s->uploaded_bytes += m->size;
    }
    if (m->size != s->upload_size)
        return cv_error(CV_ERROR_MALFORMED,
                        "blob_chunk: size %" PRIu64 " differs from the blob's first chunk (%" PRIu64 ")", m->size,
                        s->upload_size);
    if (s->upload_skipping) {
        if (m->offset + m->data.len >= s->upload_size)
            end_upload(s);
        return CV_OK;
    }
    r = cv_content_upload_write(s->upload, m->offset, m->data.data, m->data.len);
    if (r != CV_OK)
        return r;
    if (cv_content_upload_received(s->upload) == s->upload_size) {
        cv_content_upload *u = s->upload;
        s->upload = NULL;
        s->upload_size = 0;
        return cv_content_upload_finish(u);
    }
    return CV_OK;
}

static cv_result get_blob(session *s, ProtobufCBinaryData sha, const char *field, cv_content_blob **out) {
    cv_result r = cv_node_check_sha(sha, field);
    if (r != CV_OK)
        return r;
    if (s->store_refused && memcmp(s->store_refused_sha, sha.data, CV_SHA256_BYTES) == 0)
        return cv_error(s->store_refused_result, "%s: %s", field, s->store_refused_message);
    r = cv_content_store_get(s->node->store, sha.data, out);
    if (r != CV_OK) {
        char hex[65];
        cv_sha256_hex(sha.data, hex);
        return cv_error(r, "%s: blob %s is not in the node's cache (upload it first)", field, hex);
    }
    return CV_OK;
}

static cv_result do_write_buffer(session *s, const Corvid__WriteBuffer *m) {
    uint64_t id;
    cv_result r = translate(s, m->id, CV_HANDLE_BUFFER, "write_buffer", &id);
    if (r != CV_OK)
        return r;
    if (m->source_case == CORVID__WRITE_BUFFER__SOURCE_DATA)
        return cv_device_write_buffer(s->dev, (cv_buffer){ id }, m->offset, m->data.len, m->data.data);
    if (m->source_case != CORVID__WRITE_BUFFER__SOURCE_BLOB)
        return cv_error(CV_ERROR_MALFORMED, "write_buffer: no data and no blob");
    cv_content_blob *blob;
    r = get_blob(s, m->blob, "write_buffer.blob", &blob);
    if (r != CV_OK)
        return r;
    r = cv_device_write_buffer(s->dev, (cv_buffer){ id }, m->offset, cv_content_blob_size(blob),
                               cv_content_blob_data(blob));
    cv_content_blob_release(blob);
    return r;
}

static cv_result do_write_texture(session *s, const Corvid__WriteTexture *m) {
    uint64_t id;
    cv_result r = translate(s, m->id, CV_HANDLE_TEXTURE, "write_texture", &id);
    cv_resource_desc desc;
    if (r == CV_OK)
        r = cv_context_describe(s->ctx, (cv_handle){ id }, &desc);
    if (r != CV_OK)
        return r;
    uint64_t want = (uint64_t)m->width * m->height * cv_format_bytes(desc.texture.format);
    if (m->data.len != want)
        return cv_error(CV_ERROR_MALFORMED,
                        "write_texture: %zu bytes of data for %ux%u texels of %s (%" PRIu64 " bytes)", m->data.len,
                        m->width, m->height, cv_format_name(desc.texture.format), want);
    return cv_device_write_texture(s->dev, (cv_texture){ id }, (cv_rect){ m->x, m->y, m->width, m->height },
                                   m->data.data);
}

static cv_result do_write_accel(session *s, const Corvid__WriteAccel *m) {
    uint64_t id;
    cv_result r = translate(s, m->id, CV_HANDLE_ACCEL, "write_accel", &id);
    cv_resource_desc desc;
    if (r == CV_OK)
        r = cv_context_describe(s->ctx, (cv_handle){ id }, &desc);
    if (r != CV_OK)
        return r;
    cv_content_blob *nodes = NULL, *tris = NULL;
    r = get_blob(s, m->nodes_blob, "write_accel.nodes_blob", &nodes);
    if (r == CV_OK)
        r = get_blob(s, m->triangles_blob, "write_accel.triangles_blob", &tris);
    if (r == CV_OK && (cv_content_blob_size(nodes) != (uint64_t)desc.accel.node_count * CV_ACCEL_NODE_BYTES ||
                       cv_content_blob_size(tris) != (uint64_t)desc.accel.triangle_count * CV_ACCEL_TRIANGLE_BYTES))
        r = cv_error(CV_ERROR_OUT_OF_RANGE,
                     "write_accel: blobs of %" PRIu64 " and %" PRIu64
                     " bytes for %u nodes "
                     "and %u triangles (%u and %u bytes each)",
                     cv_content_blob_size(nodes), cv_content_blob_size(tris), desc.accel.node_count,
                     desc.accel.triangle_count, CV_ACCEL_NODE_BYTES, CV_ACCEL_TRIANGLE_BYTES);
    if (r == CV_OK)
        r = cv_device_write_accel(s->dev, (cv_accel){ id }, cv_content_blob_data(nodes), cv_content_blob_data(tris));
    if (nodes)
        cv_content_blob_release(nodes);
    if (tris)
        cv_content_blob_release(tris);
    return r;
}

static cv_result send_read_piece(session *s, uint64_t seq, uint64_t offset, const void *data, size_t size,
                                 bool last) {
    Corvid__ReadData piece = CORVID__READ_DATA__INIT;
    piece.offset = offset;
    piece.data.data = (uint8_t *)data;
    piece.data.len = size;
    piece.last = last;
    Corvid__NodeMessage m = CORVID__NODE_MESSAGE__INIT;
    m.seq = seq;
    m.msg_case = CORVID__NODE_MESSAGE__MSG_READ_DATA;
    m.read_data = &piece;
    return send_node_message(s, &m);
}

/* Reads go out in pieces of CV_NODE_CHUNK_BYTES, each read from the device as
 * it is sent, so memory stays bounded whatever the resource's size. */
static cv_result do_read_buffer(session *s, uint64_t seq, const Corvid__ReadBuffer *m) {
    uint64_t id;
    cv_result r = translate(s, m->id, CV_HANDLE_BUFFER, "read_buffer", &id);
    if (r != CV_OK)
        return r;
    if (m->size == 0)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "read_buffer: size is 0");
    uint8_t *piece = malloc(CV_NODE_CHUNK_BYTES);
    if (!piece)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "read_buffer");
    /* Check the whole range first, so a failure sends no data at all. */
    cv_resource_desc desc;
    r = cv_context_describe(s->ctx, (cv_handle){ id }, &desc);
    if (r == CV_OK && (m->offset > desc.buffer.size || m->size > desc.buffer.size - m->offset))
        r = cv_error(CV_ERROR_OUT_OF_RANGE,
                     "read_buffer: %" PRIu64 " bytes at offset %" PRIu64 " of buffer '%s' (%" PRIu64 " bytes)",
                     m->size, m->offset, desc.buffer.label, desc.buffer.size);
    for (uint64_t done = 0; r == CV_OK && done < m->size;) {
        uint64_t n = m->size - done < CV_NODE_CHUNK_BYTES ? m->size - done : CV_NODE_CHUNK_BYTES;
        r = cv_device_read_buffer(s->dev, (cv_buffer){ id }, m->offset + done, n, piece);
        if (r == CV_OK)
            r = send_read_piece(s, seq, done, piece, n, done + n == m->size);
        done += n;
    }
    free(piece);
    return r;
}

static cv_result do_read_texture(session *s, uint64_t seq, const Corvid__ReadTexture *m) {
    uint64_t id;
    cv_result r = translate(s, m->id, CV_HANDLE_TEXTURE, "read_texture", &id);
    cv_resource_desc desc;
    if (r == CV_OK)
        r = cv_context_describe(s->ctx, (cv_handle){ id }, &desc);
    if (r != CV_OK)
        return r;
    const cv_texture_desc *d = &desc.texture;
    if (m->width == 0 || m->height == 0 || m->x > d->width || m->width > d->width - m->x || m->y > d->height ||
        m->height > d->height - m->y)
        return cv_error(CV_ERROR_OUT_OF_RANGE, "read_texture: %ux%u at (%u,%u) of texture '%s' (%ux%u)", m->width,
                        m->height, m->x, m->y, d->label, d->width, d->height);
    uint64_t row = (uint64_t)m->width * cv_format_bytes(d->format);
    uint32_t rows_per_piece = row >= CV_NODE_CHUNK_BYTES ? 1 : (uint32_t)(CV_NODE_CHUNK_BYTES / row);
    uint8_t *piece = malloc(row * (rows_per_piece < m->height ? rows_per_piece : m->height));
    if (!piece)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "read_texture: %" PRIu64 " bytes", row * rows_per_piece);
    for (uint32_t y = 0; r == CV_OK && y < m->height;) {
        uint32_t h = m->height - y < rows_per_piece ? m->height - y : rows_per_piece;
        r = cv_device_read_texture(s->dev, (cv_texture){ id }, (cv_rect){ m->x, m->y + y, m->width, h }, piece);
        if (r == CV_OK)
            r = send_read_piece(s, seq, (uint64_t)y * row, piece, (size_t)(row * h), y + h == m->height);
        y += h;
    }
    free(piece);
    return r;
}

/* The session's send and reply for its encode worker (session_encode.h). */
static cv_result encode_send(void *user, const Corvid__NodeMessage *m) { return send_node_message(user, m); }
static void encode_reply(void *user, uint64_t seq, cv_result result, const char *message) {
    send_reply(user, seq, result, message);
}

/* Reads the texels here, in order; the worker encodes and sends them while the session goes on. */
static cv_result do_read_encoded(session *s, uint64_t seq, const Corvid__ReadEncoded *m) {
    uint64_t id;
    cv_result r = translate(s, m->id, CV_HANDLE_TEXTURE, "read_encoded", &id);
    return r == CV_OK ? session_encode_read(&s->encoders, s->dev, s->ctx, (cv_texture){ id }, seq, m) : r;
}

static cv_result do_compile(session *s, const Corvid__CompileList *m) {
    uint64_t id;
    cv_result r = translate(s, m->id, CV_HANDLE_CMDLIST, "compile", &id);
    if (r != CV_OK)
        return r;
    cv_content_blob *blob = NULL;
    const uint8_t *data;
    size_t size;
    if (m->source_case == CORVID__COMPILE_LIST__SOURCE_BLOB) {
        r = get_blob(s, m->blob, "compile.blob", &blob);
        if (r != CV_OK)
            return r;
        data = cv_content_blob_data(blob);
        size = (size_t)cv_content_blob_size(blob);
    } else {
        data = m->encoded.data;
        size = m->encoded.len;
    }
    /* Decode into a scratch list, translate its handles, and only then replace
     * the session's list, so a bad list leaves the old one in place. */
    cv_command_list scratch;
    cv_command_list_init(&scratch);
    r = cv_command_list_decode(data, size, &scratch);
    if (blob)
        cv_content_blob_release(blob);
    map_state st = { .s = s, .result = CV_OK };
    for (uint32_t i = 0; r == CV_OK && i < scratch.count && st.result == CV_OK; i++) {
        st.command = i;
        cv_command_map_handles(&scratch, &scratch.commands[i], map_list_handle, &st);
    }
    if (r == CV_OK && st.result != CV_OK)
        r = cv_error(st.result, "compile: %s", st.message);
    uint8_t *encoded = NULL;
    size_t encoded_size = 0;
    if (r == CV_OK)
        r = cv_command_list_encode(&scratch, &encoded, &encoded_size);
    cv_command_list *list;
    if (r == CV_OK)
        r = cv_cmdlist_get(s->ctx, (cv_cmdlist){ id }, &list);
    if (r == CV_OK)
        r = cv_command_list_decode(encoded, encoded_size, list);
    free(encoded);
    cv_command_list_finish(&scratch);
    if (r == CV_OK)
        r = cv_device_compile(s->dev, (cv_cmdlist){ id });
    return r;
}

static cv_result do_submit(session *s, const Corvid__SubmitList *m) {
    if (m->ticket != s->last_client_ticket + 1)
        return cv_error(CV_ERROR_MALFORMED, "submit: ticket %" PRIu64 " after %" PRIu64 " (tickets increase by one)",
                        m->ticket, s->last_client_ticket);
    s->last_client_ticket = m->ticket;
    pending_submit p = { .client_ticket = m->ticket };
    uint64_t id;
    cv_result r = translate(s, m->id, CV_HANDLE_CMDLIST, "submit", &id);
    if (r == CV_OK && s->failure) {
        /* The frame this belongs to lacks a partition: it does not run, and the client
         * learns why from its Completed (and acknowledges with ResumeAfterFailure). */
        r = cv_error(s->failure_result, "submission skipped: %s", s->failure_message);
        p.transfer_failure = s->failure;
    }
    pthread_mutex_lock(&s->lock);
    uint32_t inflight = s->inflight;
    pthread_mutex_unlock(&s->lock);
    uint32_t limit = s->node->quota.inflight;
    if (r == CV_OK && inflight >= limit)
        r = quota_refuse(s,
                         "submit of ticket %" PRIu64
                         ": the session has %u lists in flight, its limit "
                         "(corvid-node --quota-inflight %u); wait for one to complete",
                         m->ticket, inflight, limit);
    if (r == CV_OK)
        r = cv_device_submit(s->dev, (cv_cmdlist){ id }, &p.node_ticket);
    if (r == CV_OK)
        s->last_node_ticket = p.node_ticket;
    if (r != CV_OK) {
        /* Completed in order with its error, so the client's wait ends. */
        p.node_ticket = 0;
        p.result = r;
        snprintf(p.message, sizeof(p.message), "%s", cv_last_error());
        atomic_fetch_add(&s->node->errors, 1);
        log_line(s, NODE_LOG_REQUEST_ERROR, "submit of ticket %" PRIu64 ": %s", m->ticket, p.message);
    }
    atomic_fetch_add(&s->node->submissions, 1);
    queue_completion(s, &p);
    return CV_OK;
}

/* ---- node-to-node transfers (peer.h) ------------------------------------------------ */

/* The resource and region of a PushTransfer / AwaitTransfer: translated, described and checked. */
static cv_result transfer_region(session *s, uint64_t client_id, uint32_t x, uint32_t y, uint32_t width,
                                 uint32_t height, uint64_t offset, uint64_t size, const char *what, uint64_t *id,
                                 cv_resource_desc *desc, uint64_t *bytes) {
    *bytes = 0;
    cv_result r = translate(s, client_id, CV_HANDLE_NONE, what, id);
    if (r == CV_OK)
        r = cv_context_describe(s->ctx, (cv_handle){ *id }, desc);
    if (r == CV_OK)
        r = cv_node_check_region(desc, x, y, width, height, offset, size, what, bytes);
    return r;
}

/* Reads the region once the work before it is done (the device orders it), and queues it for the peer. */
static cv_result do_push(session *s, const Corvid__PushTransfer *m) {
    uint64_t id, bytes;
    cv_resource_desc desc;
    cv_result r = transfer_region(s, m->id, m->x, m->y, m->width, m->height, m->offset, m->size, "push_transfer", &id,
                                  &desc, &bytes);
    if (r != CV_OK)
        return r;
    if (m->session_key.len != CV_NODE_SESSION_KEY_BYTES)
        return cv_error(CV_ERROR_MALFORMED, "push_transfer.session_key: %zu bytes, a session key has %u",
                        m->session_key.len, CV_NODE_SESSION_KEY_BYTES);
    char target[PEER_ADDRESS_MAX];
    r = peer_check_destination(s->node->peer, m->destination, target, sizeof(target));
    if (r != CV_OK)
        return r;
    uint8_t *raw = malloc((size_t)bytes);
    if (!raw)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "push_transfer: %" PRIu64 " bytes", bytes);
    r = desc.type == CV_HANDLE_TEXTURE
            ? cv_device_read_texture(s->dev, (cv_texture){ id }, (cv_rect){ m->x, m->y, m->width, m->height }, raw)
            : cv_device_read_buffer(s->dev, (cv_buffer){ id }, m->offset, m->size, raw);
    if (r == CV_OK)
        r = peer_send(s->node->peer, target, m->session_key.data, m->transfer_id, raw, (size_t)bytes);
    free(raw);
    return r;
}

/* Starts a failure the client must acknowledge: later submissions are skipped, reads refused. */
static uint64_t fail_transfers(session *s, uint64_t transfer_id, cv_result r, const char *why) {
    s->failure = ++s->last_failure;
    s->failure_transfer = transfer_id;
    s->failure_result = r;
    snprintf(s->failure_message, sizeof(s->failure_message), "%s", why);
    atomic_fetch_add(&s->node->transfer_failures, 1);
    log_line(s, NODE_LOG_REQUEST_ERROR, "transfer failure %" PRIu64 ": %s", s->failure, why);
    return s->failure;
}

/* Holds the session until the peer's data is here and written (handle() starts a failure if not). */
static cv_result do_await(session *s, const Corvid__AwaitTransfer *m) {
    if (s->failure)
        return cv_error(s->failure_result, "await_transfer %" PRIu64 " skipped: %s", m->transfer_id,
                        s->failure_message);
    uint64_t id, bytes;
    cv_resource_desc desc;
    cv_result r = transfer_region(s, m->id, m->x, m->y, m->width, m->height, m->offset, m->size, "await_transfer",
                                  &id, &desc, &bytes);
    if (r != CV_OK)
        return r;
    uint32_t limit = s->node->config.peer_deadline_ms ? s->node->config.peer_deadline_ms
                                                      : CV_NODE_DEFAULT_PEER_DEADLINE_MS;
    uint32_t deadline = m->deadline_ms && m->deadline_ms < limit ? m->deadline_ms : limit;
    uint8_t *data = NULL;
    size_t size = 0;
    r = peer_inbox_take(s->inbox, m->transfer_id, bytes, deadline, &data, &size);
    uint8_t *raw = NULL;
    if (r == CV_OK && !(raw = malloc((size_t)bytes)))
        r = cv_error(CV_ERROR_OUT_OF_MEMORY, "await_transfer: %" PRIu64 " bytes", bytes);
    if (r == CV_OK)
        r = peer_decompress(data, size, raw, (size_t)bytes);
    free(data);
    if (r == CV_OK)
        r = desc.type == CV_HANDLE_TEXTURE
                ? cv_device_write_texture(s->dev, (cv_texture){ id }, (cv_rect){ m->x, m->y, m->width, m->height },
                                          raw)
                : cv_device_write_buffer(s->dev, (cv_buffer){ id }, m->offset, m->size, raw);
    free(raw);
    return r == CV_OK ? r : cv_error(r, "await_transfer %" PRIu64 ": %s", m->transfer_id, cv_last_error());
}

static cv_result do_resume(session *s, const Corvid__ResumeAfterFailure *m) {
    if (m->failure == 0 && m->transfer_id) { /* given up by the client, which reported that frame */
        if (s->failure && s->failure_transfer <= m->transfer_id)
            s->failure = 0;
        return CV_OK;
    }
    if (m->failure == 0 || m->failure > s->last_failure)
        return cv_error(CV_ERROR_MALFORMED,
                        "resume: failure %" PRIu64 " never happened here (the last was %" PRIu64 ")", m->failure,
                        s->last_failure);
    if (m->failure == s->failure)
        s->failure = 0; /* an older one: already resumed */
    return CV_OK;
}

/* ---- the session ------------------------------------------------------------------ */

static cv_result do_hello(session *s, uint64_t seq, const Corvid__Hello *m, int *status) {
    cv_node *node = s->node;
    if (m->protocol_version != CV_NODE_PROTOCOL_VERSION) {
        *status = STATUS_FAILED_PRECONDITION;
        return cv_error(CV_ERROR_UNSUPPORTED, "protocol version %u is not served here: this node speaks version %u",
                        m->protocol_version, CV_NODE_PROTOCOL_VERSION);
    }
    if (m->device >= node->config.device_count) {
        *status = STATUS_FAILED_PRECONDITION;
        return cv_error(CV_ERROR_NOT_FOUND, "hello: device %u does not exist (this node has %u: 0..%u)", m->device,
                        node->config.device_count, node->config.device_count - 1);
    }
    const cv_node_device_spec *spec = &node->devices[m->device];
    cv_result r = cv_context_create(NULL, &s->ctx);
    cv_device_desc desc = { .adapter = spec->adapter,
                            .validation = node->config.validation,
                            .backend_options = spec->backend_options };
    /* "<device>/s<session>", the device label cut to leave room for the session number. */
    snprintf(desc.label, sizeof(desc.label), "%.24s/s%" PRIu64, spec->label, s->id % UINT64_C(1000000000000));
    if (r == CV_OK)
        r = cv_device_create(s->ctx, spec->backend, &desc, &s->dev);
    if (r == CV_OK && pthread_create(&s->watcher, NULL, watcher_main, s) != 0)
        r = cv_error(CV_ERROR_OUT_OF_MEMORY, "session: cannot start the completion thread");
    if (r != CV_OK) {
        *status = STATUS_RESOURCE_EXHAUSTED;
        return r;
    }
    s->watcher_started = true;
    s->device_index = m->device;
    uint8_t key[CV_NODE_SESSION_KEY_BYTES];
    r = peer_inbox_open(node->peer, key, &s->inbox);
    if (r != CV_OK) {
        *status = STATUS_RESOURCE_EXHAUSTED;
        return r;
    }
    char client[64];
    snprintf(client, sizeof(client), "%.60s", m->client_name ? m->client_name : "");
    log_line(s, NODE_LOG_ALWAYS, "client '%s' on device %u (%s)", client, m->device, spec->label);

    Corvid__DeviceInfo info;
    cv_node_info_storage storage;
    cv_node_info_to_msg(cv_device_get_info(s->dev), spec->label, &info, &storage);
    Corvid__HelloReply reply = CORVID__HELLO_REPLY__INIT;
    reply.protocol_version = CV_NODE_PROTOCOL_VERSION;
    reply.node_name = node->name;
    reply.device = &info;
    reply.session_id = s->id;
    reply.max_message_bytes = CV_NODE_MAX_MESSAGE_BYTES;
    reply.session_key = (ProtobufCBinaryData){ CV_NODE_SESSION_KEY_BYTES, key };
    Corvid__Quotas quotas = CORVID__QUOTAS__INIT;
    quotas.memory_bytes = node->quota.memory_bytes;
    quotas.resources = node->quota.resources;
    quotas.inflight = node->quota.inflight;
    quotas.upload_bytes = node->quota.upload_bytes;
    quotas.max_blob_bytes = cv_content_store_stats(node->store).max_bytes;
    reply.quotas = &quotas;
    Corvid__NodeMessage out = CORVID__NODE_MESSAGE__INIT;
    out.seq = seq;
    out.msg_case = CORVID__NODE_MESSAGE__MSG_HELLO;
    out.hello = &reply;
    return send_node_message(s, &out);
}

/* Handles one request. Returns false when the session must end; *status and
 * the thread's last error then say why. */
static bool handle(session *s, const Corvid__ClientMessage *m, int *status) {
    cv_result r = CV_OK;
    uint64_t seq = m->seq;
    if (m->msg_case == CORVID__CLIENT_MESSAGE__MSG__NOT_SET) {
        *status = STATUS_INVALID_ARGUMENT;
        cv_error(CV_ERROR_MALFORMED, "message %" PRIu64 ": no request in it", seq);
        return false;
    }
    if ((m->msg_case == CORVID__CLIENT_MESSAGE__MSG_HELLO) != (s->dev == NULL)) {
        *status = STATUS_INVALID_ARGUMENT;
        cv_error(CV_ERROR_BAD_STATE,
                 s->dev ? "message %" PRIu64 ": a second hello"
                        : "message %" PRIu64 ": the first message of a session must be hello",
                 seq);
        return false;
    }
    switch (m->msg_case) {
    case CORVID__CLIENT_MESSAGE__MSG_HELLO: return do_hello(s, seq, m->hello, status) == CV_OK;
    case CORVID__CLIENT_MESSAGE__MSG_CREATE:
        r = do_create(s, m->create);
        send_reply(s, seq, r, r == CV_OK ? "" : cv_last_error());
        return true;
    case CORVID__CLIENT_MESSAGE__MSG_DESTROY: r = do_destroy(s, m->destroy); break;
    case CORVID__CLIENT_MESSAGE__MSG_BLOB_QUERY: r = do_blob_query(s, seq, m->blob_query); break;
    case CORVID__CLIENT_MESSAGE__MSG_BLOB_CHUNK: r = do_blob_chunk(s, m->blob_chunk); break;
    case CORVID__CLIENT_MESSAGE__MSG_WRITE_BUFFER:
        r = do_write_buffer(s, m->write_buffer);
        if (m->write_buffer->source_case == CORVID__WRITE_BUFFER__SOURCE_BLOB) {
            send_reply(s, seq, r, r == CV_OK ? "" : cv_last_error());
            return true;
        }
        break;
    case CORVID__CLIENT_MESSAGE__MSG_WRITE_TEXTURE: r = do_write_texture(s, m->write_texture); break;
    case CORVID__CLIENT_MESSAGE__MSG_WRITE_ACCEL:
        r = do_write_accel(s, m->write_accel);
        send_reply(s, seq, r, r == CV_OK ? "" : cv_last_error());
        return true;
    case CORVID__CLIENT_MESSAGE__MSG_READ_BUFFER:
    case CORVID__CLIENT_MESSAGE__MSG_READ_TEXTURE:
    case CORVID__CLIENT_MESSAGE__MSG_READ_ENCODED:
        if (s->failure) { /* what it would read lacks a partition */
            char why[800];
            snprintf(why, sizeof(why), "read refused: %s", s->failure_message);
            send_reply_failure(s, seq, s->failure_result, why, s->failure);
            return true;
        }
        r = m->msg_case == CORVID__CLIENT_MESSAGE__MSG_READ_BUFFER    ? do_read_buffer(s, seq, m->read_buffer)
            : m->msg_case == CORVID__CLIENT_MESSAGE__MSG_READ_TEXTURE ? do_read_texture(s, seq, m->read_texture)
                                                                      : do_read_encoded(s, seq, m->read_encoded);
        break;
    case CORVID__CLIENT_MESSAGE__MSG_OPEN_ENCODER:
        r = session_encode_open(&s->encoders, m->open_encoder);
        send_reply(s, seq, r, r == CV_OK ? "" : cv_last_error());
        return true;
    case CORVID__CLIENT_MESSAGE__MSG_CLOSE_ENCODER: r = session_encode_close(&s->encoders, m->close_encoder); break;
    case CORVID__CLIENT_MESSAGE__MSG_PUSH_TRANSFER: r = do_push(s, m->push_transfer); break;
    case CORVID__CLIENT_MESSAGE__MSG_AWAIT_TRANSFER:
        r = do_await(s, m->await_transfer);
        if (r != CV_OK) {
            char why[768];
            snprintf(why, sizeof(why), "%s", cv_last_error());
            uint64_t failure = s->failure ? s->failure : fail_transfers(s, m->await_transfer->transfer_id, r, why);
            send_reply_failure(s, seq, r, why, failure);
        }
        return true;
    case CORVID__CLIENT_MESSAGE__MSG_RESUME: r = do_resume(s, m->resume); break;
    case CORVID__CLIENT_MESSAGE__MSG_COMPILE: r = do_compile(s, m->compile); break;
    case CORVID__CLIENT_MESSAGE__MSG_SUBMIT:
        r = do_submit(s, m->submit);
        if (r != CV_OK) { /* a ticket out of sequence: the client is broken */
            *status = STATUS_INVALID_ARGUMENT;
            return false;
        }
        break;
    default:
        *status = STATUS_INVALID_ARGUMENT;
        cv_error(CV_ERROR_MALFORMED, "message %" PRIu64 ": unknown request %d", seq, (int)m->msg_case);
        return false;
    }
    if (r != CV_OK)
        reply_error(s, seq, r);
    return true;
}

/* Stops the completion watcher: after reporting every pending submission, or
 * at once when nobody is left to report to. */
static void stop_watcher(session *s, bool abandon) {
    if (!s->watcher_started)
        return;
    pthread_mutex_lock(&s->lock);
    s->stopping = true;
    s->abandon = abandon;
    pthread_cond_broadcast(&s->cond);
    pthread_mutex_unlock(&s->lock);
    pthread_join(s->watcher, NULL);
    s->watcher_started = false;
}

/* Whether the session's device may be destroyed: the watchdog did not give up
 * on it, and its work finishes within a bounded wait (the submission budget; 1
 * s once the node drains, whose clients are gone). Else it is abandoned. */
static bool work_finished(session *s) {
    if (atomic_load(&s->hung))
        return false;
    if (!s->last_node_ticket)
        return true;
    uint64_t budget_ns = atomic_load(&s->node->draining) ? 1000000000ull : submit_budget_ms(s->node) * 1000000ull;
    if (cv_device_wait(s->dev, s->last_node_ticket, budget_ns) != CV_ERROR_TIMEOUT)
        return true;
    cv_device_abandon(s->dev);
    atomic_fetch_add(&s->node->devices_abandoned, 1);
    log_line(s, NODE_LOG_ALWAYS, "ticket %" PRIu64 " still running at the session's end: its device abandoned",
             s->last_client_ticket);
    return false;
}

static void session_finish(session *s) {
    end_upload(s);
    stop_watcher(s, true);
    session_encode_finish(&s->encoders);
    peer_inbox_close(s->node->peer, s->inbox);
    cv_node_metrics_device_bytes(s->node->metrics, s->device_index, -(int64_t)s->memory_bytes);
    /* An abandoned device's GPU may still use its memory: the context and device are
     * deliberately leaked (see the top of this file). */
    if (s->ctx && (!s->dev || work_finished(s)))
        cv_context_destroy(s->ctx); /* waits for the device, frees every resource */
    else if (s->ctx)
        cv_node_keep_abandoned(s->ctx);
    cv_node_memory_release(s->node, s->memory_bytes);
    cv_hash_map_finish(&s->map);
    proto_arena_finish(&s->arena);
    free(s->pending);
    pthread_cond_destroy(&s->cond);
    pthread_mutex_destroy(&s->lock);
}

void cv_node_session_run(cv_node *node, cv_rpc_stream *stream) {
    session *s = calloc(1, sizeof(*s));
    pending_submit *pending = calloc(MAX_PENDING_SUBMITS, sizeof(*pending));
    if (!s || !pending) {
        free(s);
        free(pending);
        cv_rpc_stream_finish(stream, STATUS_RESOURCE_EXHAUSTED, "node out of memory for a new session");
        return;
    }
    s->node = node;
    s->stream = stream;
    s->pending = pending;
    s->id = atomic_fetch_add(&node->next_session_id, 1) + 1;
    snprintf(s->peer, sizeof(s->peer), "%s", cv_rpc_stream_peer(stream) ? cv_rpc_stream_peer(stream) : "?");
    pthread_mutex_init(&s->lock, NULL);
    pthread_cond_init(&s->cond, NULL);
    cv_hash_map_init(&s->map, cv_hash_map_random_seed()); /* the client chooses the keys */
    proto_arena_init(&s->arena);
    session_encode_init(&s->encoders, &(session_encode_sink){ encode_send, encode_reply, s });
    atomic_fetch_add(&node->sessions_started, 1);
    atomic_fetch_add(&node->sessions_active, 1);

    uint32_t idle = node->config.idle_timeout_ms ? node->config.idle_timeout_ms : 300000;
    int status = STATUS_OK;
    char why[1024] = "";
    for (;;) {
        uint8_t *data = NULL;
        size_t size = 0;
        cv_result r = cv_rpc_stream_recv(stream, idle, &data, &size);
        if (r == CV_ERROR_TIMEOUT) {
            status = STATUS_DEADLINE_EXCEEDED;
            snprintf(why, sizeof(why), "session idle for %u ms: closed", idle);
            break;
        }
        if (r != CV_OK) { /* the client is gone: nobody to tell */
            snprintf(why, sizeof(why), "connection lost: %s", cv_last_error());
            status = -1;
            break;
        }
        if (!data)
            break; /* the client closed its side: a clean end */
        atomic_fetch_add(&node->messages_in, 1);
        atomic_fetch_add(&node->bytes_in, size);
        proto_arena_reset(&s->arena, CV_NODE_UNPACK_BUDGET(size));
        Corvid__ClientMessage *m = corvid__client_message__unpack(&s->arena.allocator, size, data);
        free(data);
        if (!m) {
            status = STATUS_INVALID_ARGUMENT;
            snprintf(why, sizeof(why), "message of %zu bytes is not a corvid.ClientMessage%s", size,
                     s->arena.over_limit ? " (it unpacks to more than its size allows)" : "");
            break;
        }
        if (!handle(s, m, &status)) {
            snprintf(why, sizeof(why), "%s", cv_last_error());
            break;
        }
    }
    if (status <= 0 && atomic_load(&node->stopping_sessions)) { /* the node ended it: its client was told why */
        status = -1;
        snprintf(why, sizeof(why), "%s", node->stop_reason);
    }
    stop_watcher(s, status != STATUS_OK);
    session_encode_stop(&s->encoders); /* its last frame goes out before the stream ends */
    if (status > 0) {
        atomic_fetch_add(&node->errors, 1);
        log_line(s, NODE_LOG_ALWAYS, "ended with status %d: %s", status, why);
        char text[4 * sizeof(why)];
        cv_log_escape(text, sizeof(text), why);
        cv_rpc_stream_finish(stream, status, text);
    } else {
        log_line(s, NODE_LOG_ALWAYS, "ended: %s", status < 0 ? why : "client closed the session");
        if (status == 0)
            cv_rpc_stream_finish(stream, STATUS_OK, "");
    }
    session_finish(s);
    free(s);
    atomic_fetch_sub(&node->sessions_active, 1);
}
