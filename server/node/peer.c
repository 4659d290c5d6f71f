/* Node-to-node transfers (peer.h): session inboxes keyed by capability, the
 * PeerPiece handler, and the sender thread with one channel per destination. */
#include "peer.h"

#include <inttypes.h>
#include <openssl/crypto.h>
#include <openssl/rand.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <zstd.h>

#include "corvid/clock.h"
#include "node_internal.h"
#include "peer_members.h"

enum {
    STATUS_OK = 0,
    STATUS_INVALID_ARGUMENT = 3,
    STATUS_PERMISSION_DENIED = 7,
    STATUS_RESOURCE_EXHAUSTED = 8,
    STATUS_FAILED_PRECONDITION = 9,
    STATUS_UNAVAILABLE = 14,
};

typedef struct inbox_entry {
    uint64_t transfer_id;
    uint64_t raw_size, compressed_size, received;
    uint8_t *data;
} inbox_entry;

struct peer_inbox {
    peer_state *ps;   /* its node's: ps->lock guards everything below */
    peer_inbox *next; /* in the node's list */
    uint8_t key[CV_NODE_SESSION_KEY_BYTES];
    pthread_cond_t arrived;
    inbox_entry entries[PEER_INBOX_MAX_ENTRIES];
    uint32_t count;
    uint64_t bytes;        /* compressed bytes held */
    uint64_t refuse_below; /* pieces for smaller ids are refused: they were awaited (or given up) */
    uint64_t aborted[16];  /* ids the client gave up (a ring): their awaits fail at once */
    uint32_t aborted_next;
};

typedef struct send_job {
    struct send_job *next;
    char destination[PEER_ADDRESS_MAX];
    uint8_t key[CV_NODE_SESSION_KEY_BYTES];
    uint64_t transfer_id, raw_size;
    uint8_t *data;
    size_t size;
} send_job;

typedef struct peer_channel {
    char destination[PEER_ADDRESS_MAX];
    cv_rpc_client *client;
} peer_channel;

#define MAX_CHANNELS 64u

struct peer_state {
    cv_node *node;
    pthread_mutex_t lock; /* inboxes, the send queue */
    peer_inbox *inboxes;
    pthread_cond_t queued;
    send_job *head, *tail;
    uint64_t queued_bytes;
    bool stopping;
    bool sender_started;
    pthread_t sender;
    peer_channel channels[MAX_CHANNELS]; /* the sender thread's alone */
    uint32_t channel_count;
};

/* ---- receiving ---------------------------------------------------------------- */

cv_result peer_inbox_open(cv_node *node, uint8_t key[CV_NODE_SESSION_KEY_BYTES], peer_inbox **out) {
    *out = NULL;
    peer_inbox *in = calloc(1, sizeof(*in));
    if (!in)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "session: peer inbox");
    if (RAND_bytes(in->key, CV_NODE_SESSION_KEY_BYTES) != 1) {
        free(in);
        return cv_error(CV_ERROR_BACKEND, "session: no random bytes for the session key");
    }
    cv_cond_init(&in->arrived);
    memcpy(key, in->key, CV_NODE_SESSION_KEY_BYTES);
    peer_state *ps = node->peer;
    in->ps = ps;
    pthread_mutex_lock(&ps->lock);
    in->next = ps->inboxes;
    ps->inboxes = in;
    pthread_mutex_unlock(&ps->lock);
    *out = in;
    return CV_OK;
}

static void drop_entry(peer_inbox *in, uint32_t i) {
    in->bytes -= in->entries[i].compressed_size;
    free(in->entries[i].data);
    in->entries[i] = in->entries[--in->count];
}

void peer_inbox_close(cv_node *node, peer_inbox *in) {
    if (!in)
        return;
    peer_state *ps = node->peer;
    pthread_mutex_lock(&ps->lock);
    for (peer_inbox **at = &ps->inboxes; *at; at = &(*at)->next)
        if (*at == in) {
            *at = in->next;
            break;
        }
    while (in->count)
        drop_entry(in, 0);
    pthread_mutex_unlock(&ps->lock);
    OPENSSL_cleanse(in->key, sizeof(in->key));
    pthread_cond_destroy(&in->arrived);
    free(in);
}

static bool is_aborted(const peer_inbox *in, uint64_t transfer_id) {
    for (uint32_t i = 0; i < 16; i++)
        if (in->aborted[i] == transfer_id)
            return true;
    return false;
}

static int find_entry(const peer_inbox *in, uint64_t transfer_id) {
    for (uint32_t i = 0; i < in->count; i++)
        if (in->entries[i].transfer_id == transfer_id)
            return (int)i;
    return -1;
}

cv_result peer_inbox_take(peer_inbox *in, uint64_t transfer_id, uint64_t raw_bytes, uint32_t deadline_ms,
                          uint8_t **data, size_t *size) {
    *data = NULL;
    *size = 0;
    uint64_t deadline = cv_deadline_after_ms(deadline_ms);
    pthread_mutex_t *lock = &in->ps->lock;
    pthread_mutex_lock(lock);
    if (transfer_id < in->refuse_below) {
        pthread_mutex_unlock(lock);
        return cv_error(CV_ERROR_MALFORMED,
                        "await_transfer: transfer %" PRIu64 " after %" PRIu64
                        " (a session awaits transfers in increasing order)",
                        transfer_id, in->refuse_below - 1);
    }
    /* Older transfers were never awaited: nobody will take them. */
    for (uint32_t i = 0; i < in->count;)
        if (in->entries[i].transfer_id < transfer_id)
            drop_entry(in, i);
        else
            i++;
    in->refuse_below = transfer_id;
    int e;
    cv_result r = CV_OK;
    for (;;) {
        e = find_entry(in, transfer_id);
        if (e >= 0 && in->entries[e].received == in->entries[e].compressed_size)
            break;
        if (is_aborted(in, transfer_id)) {
            r = cv_error(CV_ERROR_CONNECTION,
                         "transfer %" PRIu64
                         " was given up by the client (its source device "
                         "was lost)",
                         transfer_id);
            break;
        }
        if (cv_cond_wait_until(&in->arrived, lock, deadline) != 0) {
            e = find_entry(in, transfer_id);
            r = cv_error(CV_ERROR_TIMEOUT,
                         "transfer %" PRIu64 " from a peer node: %" PRIu64 " of %" PRIu64
                         " bytes arrived within %u ms (the source node is gone, stalled or cannot reach this node)",
                         transfer_id, e >= 0 ? in->entries[e].received : 0,
                         e >= 0 ? in->entries[e].compressed_size : 0, deadline_ms);
            break;
        }
    }
    if (r == CV_OK && in->entries[e].raw_size != raw_bytes)
        r = cv_error(CV_ERROR_MALFORMED,
                     "transfer %" PRIu64 ": the peer sent %" PRIu64 " bytes, the region holds %" PRIu64, transfer_id,
                     in->entries[e].raw_size, raw_bytes);
    if (r == CV_OK) {
        *data = in->entries[e].data;
        *size = (size_t)in->entries[e].compressed_size;
        in->entries[e].data = NULL;
    }
    if (e >= 0)
        drop_entry(in, (uint32_t)e);
    in->refuse_below = transfer_id + 1;
    pthread_mutex_unlock(lock);
    return r;
}

/* Finds the inbox whose key this is (lock held). Every key is compared, each in constant time. */
static peer_inbox *inbox_by_key(peer_state *ps, const uint8_t *key) {
    peer_inbox *found = NULL;
    for (peer_inbox *in = ps->inboxes; in; in = in->next)
        if (CRYPTO_memcmp(in->key, key, CV_NODE_SESSION_KEY_BYTES) == 0)
            found = in;
    return found;
}

static int deposit(peer_state *ps, const Corvid__PeerPiece *m, char *message, size_t cap) {
    if (m->session_key.len != CV_NODE_SESSION_KEY_BYTES) {
        snprintf(message, cap, "peer_piece.session_key: %zu bytes, a session key has %u", m->session_key.len,
                 CV_NODE_SESSION_KEY_BYTES);
        return STATUS_INVALID_ARGUMENT;
    }
    peer_inbox *in = inbox_by_key(ps, m->session_key.data);
    if (!in) {
        snprintf(message, cap, "peer_piece: no session of this node holds that session key");
        return STATUS_PERMISSION_DENIED;
    }
    if (m->abort) { /* the client gives it up: an await of it (now or later) fails at once */
        if (m->transfer_id >= in->refuse_below && !is_aborted(in, m->transfer_id)) {
            in->aborted[in->aborted_next++ % 16] = m->transfer_id;
            int e = find_entry(in, m->transfer_id);
            if (e >= 0)
                drop_entry(in, (uint32_t)e);
            pthread_cond_broadcast(&in->arrived);
        }
        return STATUS_OK;
    }
    if (m->transfer_id < in->refuse_below || is_aborted(in, m->transfer_id)) {
        snprintf(message, cap, "peer_piece: transfer %" PRIu64 " was already awaited (or given up) by the session",
                 m->transfer_id);
        return STATUS_FAILED_PRECONDITION;
    }
    int e = find_entry(in, m->transfer_id);
    if (m->offset == 0 && e < 0) {
        if (m->compressed_size == 0 || m->raw_size == 0 || m->raw_size > CV_NODE_PEER_MAX_BYTES ||
            m->compressed_size > ZSTD_compressBound((size_t)m->raw_size) || m->data.len > m->compressed_size) {
            snprintf(message, cap,
                     "peer_piece: transfer %" PRIu64 " of %" PRIu64 " bytes compressed to %" PRIu64
                     ", first piece %zu bytes (at most %llu bytes, compressed at most zstd's bound)",
                     m->transfer_id, m->raw_size, m->compressed_size, m->data.len,
                     (unsigned long long)CV_NODE_PEER_MAX_BYTES);
            return STATUS_INVALID_ARGUMENT;
        }
        if (in->count == PEER_INBOX_MAX_ENTRIES || m->compressed_size > PEER_INBOX_MAX_BYTES - in->bytes) {
            snprintf(message, cap,
                     "peer_piece: the session holds %u transfers (%" PRIu64
                     " bytes) not yet awaited, at most %u (%llu bytes)",
                     in->count, in->bytes, PEER_INBOX_MAX_ENTRIES, (unsigned long long)PEER_INBOX_MAX_BYTES);
            return STATUS_RESOURCE_EXHAUSTED;
        }
        uint8_t *data = malloc((size_t)m->compressed_size);
        if (!data) {
            snprintf(message, cap, "peer_piece: node out of memory");
            return STATUS_RESOURCE_EXHAUSTED;
        }
        e = (int)in->count++;
        in->entries[e] = (inbox_entry){ .transfer_id = m->transfer_id,
                                        .raw_size = m->raw_size,
                                        .compressed_size = m->compressed_size,
                                        .data = data };
        in->bytes += m->compressed_size;
    } else if (e < 0) {
        snprintf(message, cap, "peer_piece: transfer %" PRIu64 " at offset %" PRIu64 " before its first piece",
                 m->transfer_id, m->offset);
        return STATUS_INVALID_ARGUMENT;
    }
    inbox_entry *en = &in->entries[e];
    if (m->offset != en->received || m->raw_size != en->raw_size || m->compressed_size != en->compressed_size ||
        m->data.len > en->compressed_size - en->received) {
        snprintf(message, cap,
                 "peer_piece: transfer %" PRIu64 ": %zu bytes at offset %" PRIu64 " (sizes %" PRIu64 "/%" PRIu64
                 "), expected offset %" PRIu64 " of %" PRIu64 " (sizes %" PRIu64 "/%" PRIu64 ")",
                 m->transfer_id, m->data.len, m->offset, m->raw_size, m->compressed_size, en->received,
                 en->compressed_size, en->raw_size, en->compressed_size);
        return STATUS_INVALID_ARGUMENT;
    }
    memcpy(en->data + en->received, m->data.data, m->data.len);
    en->received += m->data.len;
    if (en->received == en->compressed_size)
        pthread_cond_broadcast(&in->arrived);
    return STATUS_OK;
}

int peer_on_piece(cv_node *node, const void *request, size_t size, char *message, size_t cap) {
    Corvid__PeerPiece *m = corvid__peer_piece__unpack(NULL, size, request);
    if (!m) {
        snprintf(message, cap, "peer_piece: %zu bytes are not a corvid.PeerPiece", size);
        return STATUS_INVALID_ARGUMENT;
    }
    peer_state *ps = node->peer;
    pthread_mutex_lock(&ps->lock);
    int status = deposit(ps, m, message, cap);
    pthread_mutex_unlock(&ps->lock);
    if (status == STATUS_OK && m->abort) /* a client gave a transfer up: its source node was lost */
        cv_node_metrics_node_loss(node->metrics);
    if (status == STATUS_OK)
        atomic_fetch_add(&node->peer_bytes_in, m->data.len);
    else {
        atomic_fetch_add(&node->errors, 1);
        node_log(node, NODE_LOG_PEER, "refused a peer piece: %s", message);
    }
    corvid__peer_piece__free_unpacked(m, NULL);
    return status;
}

/* ---- sending ---------------------------------------------------------------------- */

cv_result peer_decompress(const void *data, size_t size, void *out, size_t raw_size) {
    unsigned long long content = ZSTD_getFrameContentSize(data, size);
    if (content == ZSTD_CONTENTSIZE_ERROR || content == ZSTD_CONTENTSIZE_UNKNOWN || content != raw_size)
        return cv_error(CV_ERROR_MALFORMED, "peer transfer: the compressed data is not one zstd frame of %zu bytes",
                        raw_size);
    size_t n = ZSTD_decompress(out, raw_size, data, size);
    if (ZSTD_isError(n) || n != raw_size)
        return cv_error(CV_ERROR_MALFORMED, "peer transfer: corrupt compressed data (%s)",
                        ZSTD_isError(n) ? ZSTD_getErrorName(n) : "short");
    return CV_OK;
}

cv_result peer_check_destination(cv_node *node, const char *destination, char *target, size_t cap) {
    return peer_members_check(node->members, destination, target, cap);
}

cv_result peer_send(cv_node *node, const char *destination, const uint8_t key[CV_NODE_SESSION_KEY_BYTES],
                    uint64_t transfer_id, const void *raw, size_t raw_size) {
    send_job *job = calloc(1, sizeof(*job));
    size_t bound = ZSTD_compressBound(raw_size);
    uint8_t *data = malloc(bound ? bound : 1);
    if (!job || !data) {
        free(job);
        free(data);
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "push_transfer: %zu bytes", bound);
    }
    /* Level 1: visibility and guides compress 2-5x, and the node's time matters more than the link's. */
    size_t n = ZSTD_compress(data, bound, raw, raw_size, 1);
    if (ZSTD_isError(n)) {
        free(job);
        free(data);
        return cv_error(CV_ERROR_BACKEND, "push_transfer: zstd: %s", ZSTD_getErrorName(n));
    }
    snprintf(job->destination, sizeof(job->destination), "%s", destination);
    memcpy(job->key, key, CV_NODE_SESSION_KEY_BYTES);
    job->transfer_id = transfer_id;
    job->raw_size = raw_size;
    job->data = data;
    job->size = n;
    atomic_fetch_add(&node->peer_raw_out, raw_size);
    peer_state *ps = node->peer;
    pthread_mutex_lock(&ps->lock);
    if (ps->tail)
        ps->tail->next = job;
    else
        ps->head = job;
    ps->tail = job;
    pthread_cond_broadcast(&ps->queued);
    pthread_mutex_unlock(&ps->lock);
    return CV_OK;
}

static cv_rpc_client *channel_to(peer_state *ps, const char *destination) {
    for (uint32_t i = 0; i < ps->channel_count; i++)
        if (strcmp(ps->channels[i].destination, destination) == 0)
            return ps->channels[i].client;
    cv_node *node = ps->node;
    cv_rpc_client_config cc = {
        .max_message_bytes = CV_NODE_MAX_MESSAGE_BYTES,
        .keepalive_ms = node->config.peer_keepalive_ms,
        .keepalive_timeout_ms = node->config.peer_keepalive_ms,
        .bearer_token = node->peer_token[0] ? node->peer_token : NULL,
        .tls_ca_file = node->peer_tls_ca[0] ? node->peer_tls_ca : NULL,
    };
    cv_rpc_client *c;
    if (cv_rpc_client_create(destination, &cc, &c) != CV_OK)
        return NULL;
    if (ps->channel_count == MAX_CHANNELS) { /* the oldest goes */
        cv_rpc_client_destroy(ps->channels[0].client);
        memmove(&ps->channels[0], &ps->channels[1], (MAX_CHANNELS - 1) * sizeof(ps->channels[0]));
        ps->channel_count--;
    }
    peer_channel *ch = &ps->channels[ps->channel_count++];
    snprintf(ch->destination, sizeof(ch->destination), "%s", destination);
    ch->client = c;
    return c;
}

static void deliver(peer_state *ps, const send_job *job) {
    cv_node *node = ps->node;
    cv_rpc_client *c = channel_to(ps, job->destination);
    uint32_t timeout = node->config.peer_deadline_ms ? node->config.peer_deadline_ms
                                                     : CV_NODE_DEFAULT_PEER_DEADLINE_MS;
    cv_result r = c ? CV_OK : CV_ERROR_CONNECTION;
    char why[512] = "";
    if (!c)
        snprintf(why, sizeof(why), "%s", cv_last_error());
    for (size_t off = 0; r == CV_OK && off < job->size; off += PEER_PIECE_BYTES) {
        size_t n = job->size - off < PEER_PIECE_BYTES ? job->size - off : PEER_PIECE_BYTES;
        Corvid__PeerPiece piece = CORVID__PEER_PIECE__INIT;
        piece.session_key = (ProtobufCBinaryData){ CV_NODE_SESSION_KEY_BYTES, (uint8_t *)job->key };
        piece.transfer_id = job->transfer_id;
        piece.raw_size = job->raw_size;
        piece.compressed_size = job->size;
        piece.offset = off;
        piece.data = (ProtobufCBinaryData){ n, job->data + off };
        size_t packed = corvid__peer_piece__get_packed_size(&piece);
        uint8_t *buf = malloc(packed ? packed : 1);
        if (!buf) {
            r = cv_error(CV_ERROR_OUT_OF_MEMORY, "peer piece");
            snprintf(why, sizeof(why), "%s", cv_last_error());
            break;
        }
        corvid__peer_piece__pack(&piece, buf);
        void *resp = NULL;
        size_t resp_size = 0;
        int status = 0;
        r = cv_rpc_client_unary(c, CV_NODE_METHOD_PEER_PIECE, buf, packed, timeout, &resp, &resp_size, &status);
        free(buf);
        free(resp);
        if (r != CV_OK)
            snprintf(why, sizeof(why), "%s", cv_last_error());
        else
            atomic_fetch_add(&node->peer_bytes_out, packed);
    }
    if (r != CV_OK) {
        atomic_fetch_add(&node->peer_failures, 1);
        atomic_fetch_add(&node->errors, 1);
        node_log(node, NODE_LOG_PEER, "transfer %" PRIu64 " to %s not delivered: %s", job->transfer_id,
                 job->destination, why);
    }
}

static void *sender_main(void *arg) {
    peer_state *ps = arg;
    pthread_mutex_lock(&ps->lock);
    for (;;) {
        while (!ps->head && !ps->stopping)
            pthread_cond_wait(&ps->queued, &ps->lock);
        if (ps->stopping)
            break;
        send_job *job = ps->head;
        ps->head = job->next;
        if (!ps->head)
            ps->tail = NULL;
        pthread_mutex_unlock(&ps->lock);
        deliver(ps, job);
        free(job->data);
        free(job);
        pthread_mutex_lock(&ps->lock);
    }
    pthread_mutex_unlock(&ps->lock);
    return NULL;
}

cv_result peer_state_create(cv_node *node, peer_state **out) {
    *out = NULL;
    peer_state *ps = calloc(1, sizeof(*ps));
    if (!ps)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "node: peer state");
    ps->node = node;
    pthread_mutex_init(&ps->lock, NULL);
    pthread_cond_init(&ps->queued, NULL);
    if (pthread_create(&ps->sender, NULL, sender_main, ps) != 0) {
        peer_state_destroy(ps);
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "node: cannot start the peer sender thread");
    }
    ps->sender_started = true;
    *out = ps;
    return CV_OK;
}

void peer_state_destroy(peer_state *ps) {
    if (!ps)
        return;
    pthread_mutex_lock(&ps->lock);
    ps->stopping = true;
    pthread_cond_broadcast(&ps->queued);
    pthread_mutex_unlock(&ps->lock);
    if (ps->sender_started)
        pthread_join(ps->sender, NULL);
    while (ps->head) {
        send_job *job = ps->head;
        ps->head = job->next;
        free(job->data);
        free(job);
    }
    for (uint32_t i = 0; i < ps->channel_count; i++)
        cv_rpc_client_destroy(ps->channels[i].client);
    pthread_cond_destroy(&ps->queued);
    pthread_mutex_destroy(&ps->lock);
    free(ps);
}
