/* Content-addressed uploads through a node's real protocol (issue 23):
 *
 *  - eight sessions upload one blob at the same moment: every one succeeds,
 *    the blob is stored once, each session reads back the right bytes;
 *  - a session waiting for another's upload of its blob gets it stored all the
 *    same when the first uploader disconnects half way;
 *  - a store smaller than a blob: one stable error (code and message naming the
 *    blob's size and the store's limit), run after run, from the proxy and from
 *    the node; a node with an absurdly small store is refused at start;
 *  - the store's files are 0600 and its folders 0700; a blob corrupted on disk
 *    between two sessions is not used: the second session's query says it is
 *    absent, it uploads it again, and its data is right.
 *
 * The node serves mock devices. Threads speak node.proto with the helpers
 * below (check.h's counters are not for threads): results are checked on the
 * main thread. */
#include <inttypes.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "check.h"
#include "corvid/backend.h"
#include "corvid/context.h"
#include "corvid/device.h"
#include "corvid/node_protocol.h"
#include "corvid/proxy.h"
#include "corvid/rpc.h"
#include "corvid/sha256.h"
#include "raw_node_client.h"
#include "scratch_node.h"

#define BUF_ID cv_handle_pack(CV_HANDLE_BUFFER, 1, 1, 1)
#define SESSIONS 8

static void sleep_ms(long ms) { nanosleep(&(struct timespec){ ms / 1000, (ms % 1000) * 1000000L }, NULL); }

static uint8_t *make_bytes(size_t size, uint32_t seed) {
    uint8_t *p = malloc(size);
    uint32_t x = seed * 2654435761u + 1;
    for (size_t i = 0; i < size; i++) {
        x = x * 1664525u + 1013904223u;
        p[i] = (uint8_t)(x >> 24);
    }
    return p;
}

/* ---- a session without check.h (for threads) ---------------------------------- */

static bool send_msg(raw_client *c, Corvid__ClientMessage *m, uint64_t *seq) {
    m->seq = ++c->seq;
    if (seq)
        *seq = m->seq;
    uint8_t *buf;
    size_t size;
    if (cv_node_pack_client(m, &buf, &size) != CV_OK)
        return false;
    bool ok = cv_rpc_stream_send(c->stream, buf, size) == CV_OK;
    free(buf);
    return ok;
}

static Corvid__NodeMessage *recv_msg(raw_client *c) {
    uint8_t *data = NULL;
    size_t size = 0;
    if (cv_rpc_stream_recv(c->stream, 30000, &data, &size) != CV_OK || !data)
        return NULL;
    Corvid__NodeMessage *m = corvid__node_message__unpack(NULL, size, data);
    free(data);
    return m;
}

/* The reply to `seq`: its result, or CV_ERROR_CONNECTION if something else came. */
static cv_result await_reply(raw_client *c, uint64_t seq, char *message, size_t cap) {
    Corvid__NodeMessage *m = recv_msg(c);
    cv_result r = CV_ERROR_CONNECTION;
    if (m && m->msg_case == CORVID__NODE_MESSAGE__MSG_REPLY && m->seq == seq) {
        r = (cv_result)m->reply->result;
        if (message)
            snprintf(message, cap, "%s", m->reply->message ? m->reply->message : "");
    }
    if (m)
        corvid__node_message__free_unpacked(m, NULL);
    return r;
}

static bool send_chunk(raw_client *c, const uint8_t sha[32], uint64_t size, uint64_t offset, const uint8_t *data,
                       size_t len, uint64_t *seq) {
    Corvid__BlobChunk chunk = CORVID__BLOB_CHUNK__INIT;
    chunk.sha256 = (ProtobufCBinaryData){ 32, (uint8_t *)sha };
    chunk.size = size;
    chunk.offset = offset;
    chunk.data = (ProtobufCBinaryData){ len, (uint8_t *)data };
    Corvid__ClientMessage m = CORVID__CLIENT_MESSAGE__INIT;
    m.msg_case = CORVID__CLIENT_MESSAGE__MSG_BLOB_CHUNK;
    m.blob_chunk = &chunk;
    return send_msg(c, &m, seq);
}

/* Every chunk of the blob (1 MiB each), from `from` on. */
static bool send_blob(raw_client *c, const uint8_t sha[32], const uint8_t *data, size_t size, size_t from) {
    for (size_t off = from; off < size; off += CV_NODE_CHUNK_BYTES) {
        size_t n = size - off < CV_NODE_CHUNK_BYTES ? size - off : CV_NODE_CHUNK_BYTES;
        if (!send_chunk(c, sha, size, off, data + off, n, NULL))
            return false;
    }
    return true;
}

static bool send_blob_write(raw_client *c, const uint8_t sha[32], uint64_t *seq) {
    Corvid__WriteBuffer w = CORVID__WRITE_BUFFER__INIT;
    w.id = BUF_ID;
    w.source_case = CORVID__WRITE_BUFFER__SOURCE_BLOB;
    w.blob = (ProtobufCBinaryData){ 32, (uint8_t *)sha };
    Corvid__ClientMessage m = CORVID__CLIENT_MESSAGE__INIT;
    m.msg_case = CORVID__CLIENT_MESSAGE__MSG_WRITE_BUFFER;
    m.write_buffer = &w;
    return send_msg(c, &m, seq);
}

/* Reads the buffer back (it may come in several pieces) and compares. */
static bool reads_back(raw_client *c, const uint8_t *expected, size_t size) {
    Corvid__ReadBuffer r = CORVID__READ_BUFFER__INIT;
    r.id = BUF_ID;
    r.size = size;
    Corvid__ClientMessage m = CORVID__CLIENT_MESSAGE__INIT;
    m.msg_case = CORVID__CLIENT_MESSAGE__MSG_READ_BUFFER;
    m.read_buffer = &r;
    uint64_t seq;
    if (!send_msg(c, &m, &seq))
        return false;
    bool same = true;
    for (uint64_t got = 0;;) {
        Corvid__NodeMessage *d = recv_msg(c);
        bool ok = d && d->seq == seq && d->msg_case == CORVID__NODE_MESSAGE__MSG_READ_DATA &&
                  d->read_data->offset == got && d->read_data->data.len <= size - got;
        bool last = ok && d->read_data->last;
        if (ok) {
            same = same && memcmp(d->read_data->data.data, expected + got, d->read_data->data.len) == 0;
            got += d->read_data->data.len;
        }
        if (d)
            corvid__node_message__free_unpacked(d, NULL);
        if (!ok)
            return false;
        if (last)
            return same && got == size;
    }
}

/* Opens a session (hello) with one buffer of `size` bytes (checked: main thread only). */
static void open_session(raw_client *c, const char *endpoint, uint64_t size) {
    raw_open(c, endpoint);
    raw_send_hello(c, CV_NODE_PROTOCOL_VERSION, 0, "uploads");
    Corvid__NodeMessage *m = raw_recv(c);
    CHECK(m && m->msg_case == CORVID__NODE_MESSAGE__MSG_HELLO);
    if (m)
        corvid__node_message__free_unpacked(m, NULL);
    cv_resource_desc desc = { .type = CV_HANDLE_BUFFER, .buffer = { .size = size } };
    EXPECT_REPLY(c, raw_send_create(c, BUF_ID, &desc), CV_OK, NULL);
}

static int files_in(const char *dir) {
    char cmd[600];
    snprintf(cmd, sizeof(cmd), "find '%s' -type f | wc -l", dir);
    FILE *p = popen(cmd, "r");
    int n = -1;
    if (p) {
        if (fscanf(p, "%d", &n) != 1)
            n = -1;
        pclose(p);
    }
    return n;
}

/* ---- 1: eight sessions, one blob --------------------------------------------------- */

typedef struct uploader {
    raw_client c;
    const uint8_t *data;
    size_t size;
    const uint8_t *sha;
    pthread_barrier_t *start;
    cv_result write;
    char message[512];
    bool read_ok;
} uploader;

static void *upload_and_read(void *arg) {
    uploader *u = arg;
    pthread_barrier_wait(u->start);
    uint64_t seq = 0;
    u->write = CV_ERROR_CONNECTION;
    if (send_blob(&u->c, u->sha, u->data, u->size, 0) && send_blob_write(&u->c, u->sha, &seq))
        u->write = await_reply(&u->c, seq, u->message, sizeof(u->message));
    u->read_ok = u->write == CV_OK && reads_back(&u->c, u->data, u->size);
    return NULL;
}

static void same_blob_sessions(void) {
    scratch_node n;
    CHECK_OK(scratch_node_start(&n, cv_mock_backend(), 1, false));
    size_t size = 3 * CV_NODE_CHUNK_BYTES + 4321;
    uint8_t *data = make_bytes(size, 1), sha[32];
    cv_sha256(data, size, sha);
    pthread_barrier_t start;
    pthread_barrier_init(&start, NULL, SESSIONS);
    uploader u[SESSIONS];
    pthread_t tid[SESSIONS];
    for (int i = 0; i < SESSIONS; i++) {
        u[i] = (uploader){ .data = data, .size = size, .sha = sha, .start = &start };
        open_session(&u[i].c, n.endpoint, size);
    }
    for (int i = 0; i < SESSIONS; i++)
        CHECK_EQ_INT(pthread_create(&tid[i], NULL, upload_and_read, &u[i]), 0);
    for (int i = 0; i < SESSIONS; i++) {
        pthread_join(tid[i], NULL);
        if (u[i].write != CV_OK)
            fprintf(stderr, "session %d: write %s: %s\n", i, cv_result_name(u[i].write), u[i].message);
        CHECK_OK(u[i].write);
        CHECK(u[i].read_ok);
        raw_close(&u[i].c);
    }
    pthread_barrier_destroy(&start);
    char objects[300];
    snprintf(objects, sizeof(objects), "%s/objects", n.cache_dir);
    CHECK_EQ_INT(files_in(objects), 1); /* stored once */
    CHECK_EQ_INT(cv_node_get_stats(n.node).cache_bytes, size);
    CHECK_EQ_INT(scratch_node_wait_sessions(&n, 5000), 0);
    snprintf(objects, sizeof(objects), "%s/tmp", n.cache_dir);
    CHECK_EQ_INT(files_in(objects), 0);
    scratch_node_stop(&n);
    free(data);
}

/* ---- 2: the first uploader disconnects half way ------------------------------------- */

static void uploader_disconnects(void) {
    scratch_node n;
    CHECK_OK(scratch_node_start(&n, cv_mock_backend(), 1, false));
    size_t size = 2 * CV_NODE_CHUNK_BYTES + 99;
    uint8_t *data = make_bytes(size, 2), sha[32];
    cv_sha256(data, size, sha);
    char tmp[300];
    snprintf(tmp, sizeof(tmp), "%s/tmp", n.cache_dir);

    raw_client first, second;
    open_session(&first, n.endpoint, size);
    raw_send_chunk(&first, sha, size, 0, data, CV_NODE_CHUNK_BYTES); /* and no more */
    for (int i = 0; i < 500 && files_in(tmp) != 1; i++)
        sleep_ms(10);
    CHECK_EQ_INT(files_in(tmp), 1); /* its upload is under way */

    open_session(&second, n.endpoint, size);
    uint64_t before = cv_node_get_stats(n.node).messages_in;
    CHECK(send_blob(&second, sha, data, size, 0));
    uint64_t seq = raw_send_blob_write(&second, BUF_ID, sha);
    /* Once the node has its first chunk, the second session waits for the first's upload. */
    for (int i = 0; i < 500 && cv_node_get_stats(n.node).messages_in <= before; i++)
        sleep_ms(10);
    sleep_ms(100);
    raw_close(&first); /* gone mid-upload: its upload is aborted, and the second receives the blob itself */
    EXPECT_REPLY(&second, seq, CV_OK, NULL);
    CHECK(reads_back(&second, data, size));
    raw_close(&second);
    CHECK_EQ_INT(cv_node_get_stats(n.node).cache_bytes, size);
    CHECK_EQ_INT(scratch_node_wait_sessions(&n, 5000), 0);
    CHECK_EQ_INT(files_in(tmp), 0);
    scratch_node_stop(&n);
    free(data);
}

/* ---- 3: a store smaller than a blob ------------------------------------------------ */

/* A node of mock devices whose content store holds cache_bytes (scratch_node_stop stops it). */
static cv_result start_node(scratch_node *n, uint64_t cache_bytes) {
    memset(n, 0, sizeof(*n));
    snprintf(n->cache_dir, sizeof(n->cache_dir), "/tmp/corvid-uploads-XXXXXX");
    if (!mkdtemp(n->cache_dir))
        return cv_error(CV_ERROR_IO, "cannot make a cache directory");
    n->devices[0] = (cv_node_device_spec){ .backend = cv_mock_backend(), .label = "mock0" };
    n->config = (cv_node_config){ .listen = "127.0.0.1:0",
                                  .name = "uploads",
                                  .devices = n->devices,
                                  .device_count = 1,
                                  .cache_dir = n->cache_dir,
                                  .cache_bytes = cache_bytes };
    cv_result r = cv_node_start(&n->config, &n->node);
    if (r == CV_OK)
        snprintf(n->endpoint, sizeof(n->endpoint), "127.0.0.1:%d", cv_node_port(n->node));
    return r;
}

/* One proxy device writes a buffer larger than the node's store: the error, and
 * whether the device goes on (a blob that fits is written and read back). */
static cv_result proxy_write_too_large(const char *endpoint, size_t size, char *message, size_t cap) {
    cv_context *ctx;
    cv_device *dev = NULL;
    CHECK_OK(cv_context_create(NULL, &ctx));
    CHECK_OK(cv_device_create(ctx, cv_proxy_backend(), &(cv_device_desc){ .endpoint = endpoint }, &dev));
    cv_result r = CV_ERROR_CONNECTION;
    if (dev) {
        cv_buffer big, small;
        size_t small_size = CV_NODE_BLOB_MIN_BYTES + 17;
        uint8_t *data = make_bytes(size, 3), *back = malloc(small_size);
        CHECK_OK(cv_buffer_create(ctx, &(cv_buffer_desc){ .size = size }, &big));
        CHECK_OK(cv_buffer_create(ctx, &(cv_buffer_desc){ .size = small_size }, &small));
        CHECK_OK(cv_device_load(dev, cv_any(big)));
        CHECK_OK(cv_device_load(dev, cv_any(small)));
        r = cv_device_write_buffer(dev, big, 0, size, data);
        snprintf(message, cap, "%s", cv_last_error());
        CHECK_OK(cv_device_write_buffer(dev, small, 0, small_size, data));
        CHECK_OK(cv_device_read_buffer(dev, small, 0, small_size, back));
        CHECK(memcmp(back, data, small_size) == 0);
        free(data);
        free(back);
        cv_device_destroy(dev);
    }
    cv_context_destroy(ctx);
    return r;
}

static void store_too_small(void) {
    scratch_node n;
    CHECK_RESULT(start_node(&n, 1u << 20), CV_ERROR_OUT_OF_RANGE);
    CHECK(strstr(cv_last_error(), "1048576 bytes") && strstr(cv_last_error(), "at least 16777216 bytes"));
    char rm[300];
    snprintf(rm, sizeof(rm), "rm -rf '%s'", n.cache_dir);
    CHECK_EQ_INT(system(rm), 0);

    uint64_t limit = CV_NODE_MIN_CACHE_BYTES;
    size_t size = (size_t)limit + 1;
    CHECK_OK(start_node(&n, limit));
    char limit_text[32], size_text[32];
    snprintf(limit_text, sizeof(limit_text), "%" PRIu64 " bytes", limit);
    snprintf(size_text, sizeof(size_text), "%zu bytes", size);

    /* Through the proxy: refused before anything is sent, the same way every run. */
    char first[CV_ERROR_MESSAGE_MAX] = "", again[CV_ERROR_MESSAGE_MAX];
    for (int run = 0; run < 3; run++) {
        char *message = run ? again : first;
        CHECK_RESULT(proxy_write_too_large(n.endpoint, size, message, CV_ERROR_MESSAGE_MAX), CV_ERROR_LIMIT_EXCEEDED);
        CHECK(strstr(message, limit_text) && strstr(message, size_text) && strstr(message, "--cache-size"));
        CHECK(run == 0 || strcmp(message, first) == 0);
    }
    printf("proxy: %s\n", first);

    /* A client that sends it anyway: its upload and the write naming it get the same refusal, and the
     * blob's later chunks are dropped without a reply each. */
    uint8_t *data = make_bytes(size, 4), sha[32];
    cv_sha256(data, size, sha);
    char store_says[200];
    snprintf(store_says, sizeof(store_says), "of %s is larger than the store's limit of %s", size_text, limit_text);
    for (int run = 0; run < 2; run++) {
        raw_client c;
        open_session(&c, n.endpoint, size);
        uint64_t seq = raw_send_chunk(&c, sha, size, 0, data, CV_NODE_CHUNK_BYTES);
        EXPECT_REPLY(&c, seq, CV_ERROR_LIMIT_EXCEEDED, store_says);
        CHECK(send_blob(&c, sha, data, size, CV_NODE_CHUNK_BYTES));
        EXPECT_REPLY(&c, raw_send_blob_write(&c, BUF_ID, sha), CV_ERROR_LIMIT_EXCEEDED, store_says);
        raw_close(&c);
    }
    free(data);
    CHECK_EQ_INT(cv_node_get_stats(n.node).cache_bytes, CV_NODE_BLOB_MIN_BYTES + 17); /* the small blob only */
    CHECK_EQ_INT(scratch_node_wait_sessions(&n, 5000), 0);
    scratch_node_stop(&n);
}

/* ---- 4: file modes, and a blob corrupted on disk between two sessions ------------ */

static mode_t mode_of(const char *path) {
    struct stat st;
    return stat(path, &st) == 0 ? st.st_mode & 07777 : (mode_t)-1;
}

/* What a client does: asks, uploads if absent, writes the buffer from the blob, reads it back. */
static bool session_writes(const char *endpoint, const uint8_t *data, size_t size, const uint8_t sha[32],
                           bool *was_present) {
    raw_client c;
    open_session(&c, endpoint, size);
    Corvid__BlobQuery q = CORVID__BLOB_QUERY__INIT;
    ProtobufCBinaryData key = { 32, (uint8_t *)sha };
    q.n_sha256 = 1;
    q.sha256 = &key;
    Corvid__ClientMessage m = CORVID__CLIENT_MESSAGE__INIT;
    m.msg_case = CORVID__CLIENT_MESSAGE__MSG_BLOB_QUERY;
    m.blob_query = &q;
    raw_send(&c, &m);
    Corvid__NodeMessage *status = raw_recv(&c);
    CHECK(status && status->msg_case == CORVID__NODE_MESSAGE__MSG_BLOB_STATUS && status->blob_status->n_present == 1);
    *was_present = status && status->msg_case == CORVID__NODE_MESSAGE__MSG_BLOB_STATUS &&
                   status->blob_status->n_present == 1 && status->blob_status->present[0];
    if (status)
        corvid__node_message__free_unpacked(status, NULL);
    if (!*was_present)
        CHECK(send_blob(&c, sha, data, size, 0));
    EXPECT_REPLY(&c, raw_send_blob_write(&c, BUF_ID, sha), CV_OK, NULL);
    bool same = reads_back(&c, data, size);
    raw_close(&c);
    return same;
}

static void files_private_and_checked(void) {
    scratch_node n;
    CHECK_OK(scratch_node_start(&n, cv_mock_backend(), 1, false));
    size_t size = 600 * 1024;
    uint8_t *data = make_bytes(size, 5), sha[32];
    cv_sha256(data, size, sha);
    bool present = true;
    CHECK(session_writes(n.endpoint, data, size, sha, &present));
    CHECK(!present);

    char hex[CV_SHA256_HEX_SIZE], path[600];
    cv_sha256_hex(sha, hex);
    CHECK_EQ_INT(mode_of(n.cache_dir), 0700);
    snprintf(path, sizeof(path), "%s/objects", n.cache_dir);
    CHECK_EQ_INT(mode_of(path), 0700);
    snprintf(path, sizeof(path), "%s/tmp", n.cache_dir);
    CHECK_EQ_INT(mode_of(path), 0700);
    snprintf(path, sizeof(path), "%s/objects/%.2s", n.cache_dir, hex);
    CHECK_EQ_INT(mode_of(path), 0700);
    snprintf(path, sizeof(path), "%s/objects/%.2s/%s", n.cache_dir, hex, hex);
    CHECK_EQ_INT(mode_of(path), 0600);

    /* One byte changed on disk while the node runs: the next session is told the blob is absent. */
    FILE *f = fopen(path, "r+b");
    CHECK(f != NULL);
    if (f) {
        fseek(f, 4242, SEEK_SET);
        fputc(data[4242] ^ 0x10, f);
        fclose(f);
    }
    present = true;
    CHECK(session_writes(n.endpoint, data, size, sha, &present));
    CHECK(!present);
    CHECK(session_writes(n.endpoint, data, size, sha, &present)); /* uploaded again, and used again */
    CHECK(present);
    CHECK_EQ_INT(mode_of(path), 0600);
    CHECK_EQ_INT(scratch_node_wait_sessions(&n, 5000), 0);
    scratch_node_stop(&n);
    free(data);
}

int main(void) {
    same_blob_sessions();
    uploader_disconnects();
    store_too_small();
    files_private_and_checked();
    CHECK_NOTHING_LIVE();
    return check_report("node_uploads");
}
