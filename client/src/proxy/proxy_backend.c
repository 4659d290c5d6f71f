/* The proxy backend's table (proxy.h): each call becomes node.proto messages on
 * the device's session (proxy_session.c). */
#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "corvid/clock.h"
#include "corvid/command_codec.h"
#include "corvid/parse.h"
#include "corvid/sha256.h"
#include "proxy_encode.h"
#include "proxy_options.h"
#include "proxy_peer.h"
#include "proxy_session.h"

static bool contains_nocase(const char *text, const char *needle) {
    size_t n = strlen(needle);
    for (; *text; text++)
        if (strncasecmp(text, needle, n) == 0)
            return true;
    return false;
}

/* The node device an adapter spec names: "" = 0, a decimal index, or the first
 * device whose label or adapter name contains the text (case-insensitive), as
 * local adapters are chosen. */
static cv_result resolve_device(const char *endpoint, const char *text, uint32_t *out) {
    if (!text || !*text) {
        *out = 0;
        return CV_OK;
    }
    uint64_t v;
    if (cv_parse_uint(text, 0, UINT64_MAX, &v)) {
        if (v >= CV_MAX_DEVICES)
            return cv_error(CV_ERROR_NOT_FOUND, "node '%s': device %s does not exist (at most %u)", endpoint, text,
                            CV_MAX_DEVICES);
        *out = (uint32_t)v; /* the node checks it against its own count at hello */
        return CV_OK;
    }
    cv_proxy_node_info *info = malloc(sizeof(*info));
    if (!info)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "proxy: node info");
    cv_result r = cv_proxy_query_node(endpoint, 0, info);
    if (r == CV_OK) {
        r = CV_ERROR_NOT_FOUND;
        for (uint32_t i = 0; i < info->device_count && r != CV_OK; i++)
            if (contains_nocase(info->labels[i], text) || contains_nocase(info->devices[i].name, text)) {
                *out = i;
                r = CV_OK;
            }
        if (r != CV_OK) {
            char list[512] = "";
            for (uint32_t i = 0; i < info->device_count; i++) {
                size_t used = strlen(list);
                snprintf(list + used, sizeof(list) - used, "%s%u: %s (%s)", i ? ", " : "", i, info->labels[i],
                         info->devices[i].name);
            }
            cv_error(CV_ERROR_NOT_FOUND, "node '%s' has no device matching '%s' (it has %s)", endpoint, text, list);
        }
    }
    free(info);
    return r;
}

static void free_device(proxy_device *p) {
    proxy_peer_unregister(p);
    cv_encoded_free(&p->encode_frame); /* a frame half-received when the session died */
    free(p->known);
    free(p->lists);
    pthread_cond_destroy(&p->cond);
    pthread_mutex_destroy(&p->lock);
    free(p);
}

static cv_result proxy_device_create(const cv_device_desc *desc, cv_device_info *info, cv_backend_device **out) {
    if (!desc->endpoint || !desc->endpoint[0])
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "proxy: no endpoint (\"host:port\" of a corvid-node)");
    if (strlen(desc->endpoint) >= sizeof(((proxy_device *)0)->endpoint))
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "proxy: endpoint of %zu characters is too long",
                        strlen(desc->endpoint));
    uint32_t remote = 0;
    cv_result r = resolve_device(desc->endpoint, desc->adapter, &remote);
    if (r != CV_OK)
        return r;
    proxy_device *p = calloc(1, sizeof(*p));
    if (!p)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "proxy device");
    snprintf(p->endpoint, sizeof(p->endpoint), "%s", desc->endpoint);
    p->remote_device = remote;
    proxy_settings *s = malloc(sizeof(*s));
    if (!s) {
        free(p);
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "proxy device");
    }
    proxy_settings_get(s);
    p->timeout_ms = s->options.timeout_ms;
    p->peer_deadline_ms = s->options.peer_deadline_ms;
    memset(s->token, 0, sizeof(s->token));
    free(s);
    pthread_mutex_init(&p->lock, NULL);
    cv_cond_init(&p->cond);
    proxy_peer_register(p);
    r = proxy_session_open(p, info);
    if (r != CV_OK) {
        char why[1024];
        snprintf(why, sizeof(why), "%s", cv_last_error());
        proxy_session_close(p);
        free_device(p);
        return cv_error(r, "%s", why);
    }
    *out = p;
    return CV_OK;
}

static void proxy_device_destroy(cv_backend_device *p) {
    proxy_session_close(p);
    free_device(p);
}

static Corvid__ClientMessage client_message(void) {
    Corvid__ClientMessage m = CORVID__CLIENT_MESSAGE__INIT;
    return m;
}

static cv_result proxy_resource_create(cv_backend_device *p, uint64_t id, const cv_resource_desc *desc,
                                       const cv_pipeline_info *pipeline, void **out_obj) {
    (void)pipeline; /* the node resolves the name from its own registry */
    proxy_resource *res = malloc(sizeof(*res));
    if (!res)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "proxy resource");
    Corvid__CreateResource create;
    cv_node_desc_storage storage;
    cv_node_desc_to_msg(id, desc, &create, &storage);
    Corvid__ClientMessage m = client_message();
    m.msg_case = CORVID__CLIENT_MESSAGE__MSG_CREATE;
    m.create = &create;
    proxy_pending pending = { 0 };
    cv_result r = proxy_request(p, &m, &pending);
    if (r != CV_OK) {
        free(res);
        return r;
    }
    res->id = id;
    *out_obj = res;
    return CV_OK;
}

static void send_destroy(proxy_device *p, uint64_t id) {
    Corvid__DestroyResource destroy = CORVID__DESTROY_RESOURCE__INIT;
    destroy.id = id;
    Corvid__ClientMessage m = client_message();
    m.msg_case = CORVID__CLIENT_MESSAGE__MSG_DESTROY;
    m.destroy = &destroy;
    proxy_send(p, &m); /* a dead session frees everything on the node anyway */
}

static void proxy_resource_destroy(cv_backend_device *p, cv_handle_type type, void *obj) {
    (void)type;
    proxy_resource *res = obj;
    send_destroy(p, res->id);
    free(res);
}

/* ---- content-addressed blobs ----------------------------------------------- */

static bool known_blob(proxy_device *p, const uint8_t sha[CV_SHA256_BYTES]) {
    for (uint32_t i = 0; i < p->known_count; i++)
        if (memcmp(p->known[i], sha, CV_SHA256_BYTES) == 0)
            return true;
    return false;
}

static void remember_blob(proxy_device *p, const uint8_t sha[CV_SHA256_BYTES]) {
    if (known_blob(p, sha))
        return;
    if (p->known_count == p->known_capacity) {
        uint32_t cap = p->known_capacity ? p->known_capacity * 2 : 16;
        void *k = realloc(p->known, (size_t)cap * CV_SHA256_BYTES);
        if (!k)
            return; /* only an optimisation: the next use asks the node again */
        p->known = k;
        p->known_capacity = cap;
    }
    memcpy(p->known[p->known_count++], sha, CV_SHA256_BYTES);
}

/* Makes sure the node's cache holds these bytes; *sha gets their hash. */
static cv_result ensure_blob(proxy_device *p, const void *data, uint64_t size, uint8_t sha[CV_SHA256_BYTES]) {
    if (p->max_blob && size > p->max_blob)
        return cv_error(CV_ERROR_LIMIT_EXCEEDED,
                        "node '%s': a blob of %" PRIu64 " bytes is larger than the node's content store (%" PRIu64
                        " bytes, corvid-node --cache-size); refused here, the device goes on",
                        p->endpoint, size, p->max_blob);
    cv_sha256(data, (size_t)size, sha);
    bool present = known_blob(p, sha);
    if (!present) {
        ProtobufCBinaryData key = { CV_SHA256_BYTES, sha };
        Corvid__BlobQuery query = CORVID__BLOB_QUERY__INIT;
        query.n_sha256 = 1;
        query.sha256 = &key;
        Corvid__ClientMessage m = client_message();
        m.msg_case = CORVID__CLIENT_MESSAGE__MSG_BLOB_QUERY;
        m.blob_query = &query;
        proxy_pending pending = { .present = &present, .present_count = 1 };
        cv_result r = proxy_request(p, &m, &pending);
        if (r != CV_OK)
            return r;
    }
    if (present) {
        pthread_mutex_lock(&p->lock);
        p->stats.upload_bytes_skipped += size;
        pthread_mutex_unlock(&p->lock);
        remember_blob(p, sha);
        return CV_OK;
    }
    pthread_mutex_lock(&p->lock);
    uint64_t sent = p->stats.upload_bytes_sent;
    pthread_mutex_unlock(&p->lock);
    if (p->quota_upload && size > p->quota_upload - (sent < p->quota_upload ? sent : p->quota_upload))
        return cv_error(CV_ERROR_LIMIT_EXCEEDED,
                        "node '%s': an upload of %" PRIu64 " bytes would pass the session's upload quota (%" PRIu64
                        " bytes sent of %" PRIu64 ", corvid-node --quota-upload); refused here, the device goes on",
                        p->endpoint, size, sent, p->quota_upload);
    for (uint64_t off = 0; off < size; off += CV_NODE_CHUNK_BYTES) {
        uint64_t n = size - off < CV_NODE_CHUNK_BYTES ? size - off : CV_NODE_CHUNK_BYTES;
        Corvid__BlobChunk chunk = CORVID__BLOB_CHUNK__INIT;
        chunk.sha256 = (ProtobufCBinaryData){ CV_SHA256_BYTES, sha };
        chunk.size = size;
        chunk.offset = off;
        chunk.data = (ProtobufCBinaryData){ (size_t)n, (uint8_t *)data + off };
        Corvid__ClientMessage m = client_message();
        m.msg_case = CORVID__CLIENT_MESSAGE__MSG_BLOB_CHUNK;
        m.blob_chunk = &chunk;
        cv_result r = proxy_send(p, &m);
        if (r != CV_OK)
            return r;
    }
    pthread_mutex_lock(&p->lock);
    p->stats.upload_bytes_sent += size;
    pthread_mutex_unlock(&p->lock);
    remember_blob(p, sha);
    return CV_OK;
}

/* ---- data ---------------------------------------------------------------------- */

static cv_result proxy_buffer_write(cv_backend_device *p, void *buf, uint64_t offset, uint64_t size,
                                    const void *data) {
    proxy_resource *res = buf;
    uint8_t sha[CV_SHA256_BYTES];
    if (size >= CV_NODE_BLOB_MIN_BYTES) {
        cv_result r = ensure_blob(p, data, size, sha);
        if (r != CV_OK)
            return r;
        Corvid__WriteBuffer w = CORVID__WRITE_BUFFER__INIT;
        w.id = res->id;
        w.offset = offset;
        w.source_case = CORVID__WRITE_BUFFER__SOURCE_BLOB;
        w.blob = (ProtobufCBinaryData){ CV_SHA256_BYTES, sha };
        Corvid__ClientMessage m = client_message();
        m.msg_case = CORVID__CLIENT_MESSAGE__MSG_WRITE_BUFFER;
        m.write_buffer = &w;
        proxy_pending pending = { 0 };
        return proxy_request(p, &m, &pending);
    }
    Corvid__WriteBuffer w = CORVID__WRITE_BUFFER__INIT;
    w.id = res->id;
    w.offset = offset;
    w.source_case = CORVID__WRITE_BUFFER__SOURCE_DATA;
    w.data = (ProtobufCBinaryData){ (size_t)size, (uint8_t *)data };
    Corvid__ClientMessage m = client_message();
    m.msg_case = CORVID__CLIENT_MESSAGE__MSG_WRITE_BUFFER;
    m.write_buffer = &w;
    return proxy_send(p, &m);
}

static cv_result proxy_buffer_read(cv_backend_device *p, void *buf, uint64_t offset, uint64_t size, void *out) {
    proxy_resource *res = buf;
    Corvid__ReadBuffer rd = CORVID__READ_BUFFER__INIT;
    rd.id = res->id;
    rd.offset = offset;
    rd.size = size;
    Corvid__ClientMessage m = client_message();
    m.msg_case = CORVID__CLIENT_MESSAGE__MSG_READ_BUFFER;
    m.read_buffer = &rd;
    proxy_pending pending = { .read_into = out, .read_size = size };
    return proxy_request(p, &m, &pending);
}

/* Texture writes go in bands of rows of at most a chunk each, without waiting. */
static cv_result proxy_texture_write(cv_backend_device *p, void *tex, const cv_texture_desc *desc, cv_rect rect,
                                     const void *data) {
    proxy_resource *res = tex;
    uint64_t row = (uint64_t)rect.width * cv_format_bytes(desc->format);
    uint32_t band = row >= CV_NODE_CHUNK_BYTES ? 1 : (uint32_t)(CV_NODE_CHUNK_BYTES / row);
    for (uint32_t y = 0; y < rect.height; y += band) {
        uint32_t h = rect.height - y < band ? rect.height - y : band;
        Corvid__WriteTexture w = CORVID__WRITE_TEXTURE__INIT;
        w.id = res->id;
        w.x = rect.x;
        w.y = rect.y + y;
        w.width = rect.width;
        w.height = h;
        w.data = (ProtobufCBinaryData){ (size_t)(row * h), (uint8_t *)data + row * y };
        Corvid__ClientMessage m = client_message();
        m.msg_case = CORVID__CLIENT_MESSAGE__MSG_WRITE_TEXTURE;
        m.write_texture = &w;
        cv_result r = proxy_send(p, &m);
        if (r != CV_OK)
            return r;
    }
    return CV_OK;
}

static cv_result proxy_texture_read(cv_backend_device *p, void *tex, const cv_texture_desc *desc, cv_rect rect,
                                    void *out) {
    proxy_resource *res = tex;
    Corvid__ReadTexture rd = CORVID__READ_TEXTURE__INIT;
    rd.id = res->id;
    rd.x = rect.x;
    rd.y = rect.y;
    rd.width = rect.width;
    rd.height = rect.height;
    Corvid__ClientMessage m = client_message();
    m.msg_case = CORVID__CLIENT_MESSAGE__MSG_READ_TEXTURE;
    m.read_texture = &rd;
    proxy_pending pending = { .read_into = out,
                              .read_size = (uint64_t)rect.width * rect.height * cv_format_bytes(desc->format) };
    return proxy_request(p, &m, &pending);
}

static cv_result proxy_accel_write(cv_backend_device *p, void *accel, const cv_accel_desc *desc, const void *nodes,
                                   const void *triangles) {
    proxy_resource *res = accel;
    uint8_t nodes_sha[CV_SHA256_BYTES], tris_sha[CV_SHA256_BYTES];
    cv_result r = ensure_blob(p, nodes, (uint64_t)desc->node_count * CV_ACCEL_NODE_BYTES, nodes_sha);
    if (r == CV_OK)
        r = ensure_blob(p, triangles, (uint64_t)desc->triangle_count * CV_ACCEL_TRIANGLE_BYTES, tris_sha);
    if (r != CV_OK)
        return r;
    Corvid__WriteAccel w = CORVID__WRITE_ACCEL__INIT;
    w.id = res->id;
    w.nodes_blob = (ProtobufCBinaryData){ CV_SHA256_BYTES, nodes_sha };
    w.triangles_blob = (ProtobufCBinaryData){ CV_SHA256_BYTES, tris_sha };
    Corvid__ClientMessage m = client_message();
    m.msg_case = CORVID__CLIENT_MESSAGE__MSG_WRITE_ACCEL;
    m.write_accel = &w;
    proxy_pending pending = { 0 };
    return proxy_request(p, &m, &pending);
}

/* ---- lists ----------------------------------------------------------------------- */

static proxy_known_list *find_list(proxy_device *p, uint64_t id) {
    for (uint32_t i = 0; i < p->list_count; i++)
        if (p->lists[i].id == id)
            return &p->lists[i];
    return NULL;
}

/* The node's list for `id`, created there on first use. */
static cv_result acquire_list(proxy_device *p, uint64_t id) {
    proxy_known_list *known = find_list(p, id);
    if (known) {
        known->refs++;
        return CV_OK;
    }
    if (p->list_count == p->list_capacity) {
        uint32_t cap = p->list_capacity ? p->list_capacity * 2 : 16;
        proxy_known_list *l = realloc(p->lists, cap * sizeof(*l));
        if (!l)
            return cv_error(CV_ERROR_OUT_OF_MEMORY, "proxy: list table");
        p->lists = l;
        p->list_capacity = cap;
    }
    Corvid__CreateResource create;
    cv_node_desc_storage storage;
    cv_node_desc_to_msg(id, NULL, &create, &storage);
    Corvid__ClientMessage m = client_message();
    m.msg_case = CORVID__CLIENT_MESSAGE__MSG_CREATE;
    m.create = &create;
    proxy_pending pending = { 0 };
    cv_result r = proxy_request(p, &m, &pending);
    if (r != CV_OK)
        return r;
    p->lists[p->list_count++] = (proxy_known_list){ .id = id, .refs = 1 };
    return CV_OK;
}

static void release_list(proxy_device *p, uint64_t id) {
    proxy_known_list *known = find_list(p, id);
    if (!known || --known->refs)
        return;
    *known = p->lists[--p->list_count];
    send_destroy(p, id);
}

static cv_result proxy_list_compile(cv_backend_device *p, cv_device *dev, const cv_command_list *list,
                                    void **out_compiled) {
    (void)dev;
    proxy_list *compiled = calloc(1, sizeof(*compiled));
    if (!compiled)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "proxy: compiled list");
    uint8_t *encoded = NULL;
    size_t size = 0;
    cv_result r = cv_command_list_encode(list, &encoded, &size);
    if (r == CV_OK)
        r = acquire_list(p, list->id);
    if (r != CV_OK) {
        free(encoded);
        free(compiled);
        return r;
    }
    Corvid__CompileList c = CORVID__COMPILE_LIST__INIT;
    c.id = list->id;
    uint8_t sha[CV_SHA256_BYTES];
    if (size > CV_NODE_CHUNK_BYTES) {
        r = ensure_blob(p, encoded, size, sha);
        c.source_case = CORVID__COMPILE_LIST__SOURCE_BLOB;
        c.blob = (ProtobufCBinaryData){ CV_SHA256_BYTES, sha };
    } else {
        c.source_case = CORVID__COMPILE_LIST__SOURCE_ENCODED;
        c.encoded = (ProtobufCBinaryData){ size, encoded };
    }
    Corvid__ClientMessage m = client_message();
    m.msg_case = CORVID__CLIENT_MESSAGE__MSG_COMPILE;
    m.compile = &c;
    if (r == CV_OK)
        r = proxy_send(p, &m);
    free(encoded);
    if (r != CV_OK) {
        release_list(p, list->id);
        free(compiled);
        return r;
    }
    compiled->id = list->id;
    *out_compiled = compiled;
    return CV_OK;
}

static void proxy_list_release(cv_backend_device *p, void *obj) {
    proxy_list *compiled = obj;
    /* Released before its Completed only when the session is dead (which reports every ticket
     * finished): the receiver then ignores every message (proxy_session.c, on_message). */
    release_list(p, compiled->id);
    free(compiled);
}

static cv_result proxy_submit(cv_backend_device *p, void *obj, uint64_t ticket) {
    proxy_list *compiled = obj;
    /* At most the ring's size, and the node's in-flight quota, submitted and not completed. */
    uint64_t most = p->quota_inflight && p->quota_inflight < PROXY_INFLIGHT - 1 ? p->quota_inflight
                                                                                : PROXY_INFLIGHT - 1;
    pthread_mutex_lock(&p->lock);
    bool full = ticket - p->completed > most;
    pthread_mutex_unlock(&p->lock);
    while (full) { /* let the oldest finish first */
        cv_result r = proxy_health(p);
        if (r != CV_OK)
            return r;
        pthread_mutex_lock(&p->lock);
        pthread_cond_wait(&p->cond, &p->lock);
        full = ticket - p->completed > most && p->dead == CV_OK;
        pthread_mutex_unlock(&p->lock);
    }
    Corvid__SubmitList s = CORVID__SUBMIT_LIST__INIT;
    s.id = compiled->id;
    s.ticket = ticket;
    Corvid__ClientMessage m = client_message();
    m.msg_case = CORVID__CLIENT_MESSAGE__MSG_SUBMIT;
    m.submit = &s;
    pthread_mutex_lock(&p->lock);
    p->inflight[ticket % PROXY_INFLIGHT] = (proxy_inflight){ ticket, compiled };
    pthread_mutex_unlock(&p->lock);
    cv_result r = proxy_send(p, &m);
    if (r != CV_OK) {
        pthread_mutex_lock(&p->lock);
        p->inflight[ticket % PROXY_INFLIGHT] = (proxy_inflight){ 0 };
        pthread_mutex_unlock(&p->lock);
    }
    return r;
}

static cv_result proxy_wait(cv_backend_device *p, uint64_t ticket, uint64_t timeout_ns) {
    uint64_t deadline = cv_deadline_after_ns(timeout_ns); /* UINT64_MAX: CV_DEADLINE_NEVER */
    pthread_mutex_lock(&p->lock);
    cv_result r = CV_OK;
    if (p->completed < ticket && p->dead == CV_OK)
        p->stats.blocking_waits++;
    while (p->completed < ticket && p->dead == CV_OK) {
        /* In slices: an await this ticket may be held by loses its source meanwhile (proxy_peer.c). */
        pthread_mutex_unlock(&p->lock);
        proxy_peer_abort_dead(p);
        pthread_mutex_lock(&p->lock);
        if (p->completed >= ticket || p->dead != CV_OK)
            break;
        uint64_t slice = cv_deadline_after_ms(100);
        bool last = slice >= deadline;
        if (cv_cond_wait_until(&p->cond, &p->lock, cv_deadline_min(slice, deadline)) != 0 && last &&
            p->completed < ticket && p->dead == CV_OK) {
            r = cv_error(CV_ERROR_TIMEOUT, "node '%s': ticket %" PRIu64 " not finished in time", p->endpoint, ticket);
            break;
        }
    }
    pthread_mutex_unlock(&p->lock);
    if (r == CV_OK)
        r = proxy_health(p);
    return r == CV_OK ? proxy_report_failure(p, ticket) : r;
}

static cv_result proxy_refused(cv_backend_device *p, uint64_t ticket) {
    cv_result r = CV_OK;
    pthread_mutex_lock(&p->lock);
    if (p->refused_ticket && p->refused_ticket <= ticket) {
        r = cv_error(p->refused_result, "node '%s': %s", p->endpoint, p->refused_message);
        p->refused_ticket = 0;
    }
    pthread_mutex_unlock(&p->lock);
    return r;
}

static uint64_t proxy_completed(cv_backend_device *p) {
    pthread_mutex_lock(&p->lock);
    /* A dead session finishes nothing more: report everything finished so the
     * core releases what it deferred instead of waiting forever. */
    uint64_t c = p->dead != CV_OK ? UINT64_MAX : p->completed;
    pthread_mutex_unlock(&p->lock);
    return c;
}

static bool proxy_lost(cv_backend_device *p) {
    pthread_mutex_lock(&p->lock);
    bool lost = p->dead != CV_OK;
    p->loss_reported |= lost; /* the caller learns it now */
    pthread_mutex_unlock(&p->lock);
    return lost;
}

static cv_result proxy_timings(cv_backend_device *p, void *obj, cv_pass_timing *out, uint32_t capacity,
                               uint32_t *count) {
    proxy_list *compiled = obj;
    pthread_mutex_lock(&p->lock);
    uint32_t n = compiled->timing_count < capacity ? compiled->timing_count : capacity;
    memcpy(out, compiled->timings, n * sizeof(*out));
    *count = n;
    pthread_mutex_unlock(&p->lock);
    return CV_OK;
}

static const cv_backend proxy_backend = {
    .name = "proxy",
    .orders_host_access = true,
    .device_create = proxy_device_create,
    .device_destroy = proxy_device_destroy,
    .resource_create = proxy_resource_create,
    .resource_destroy = proxy_resource_destroy,
    .buffer_write = proxy_buffer_write,
    .buffer_read = proxy_buffer_read,
    .texture_write = proxy_texture_write,
    .texture_read = proxy_texture_read,
    .accel_write = proxy_accel_write,
    .list_compile = proxy_list_compile,
    .list_release = proxy_list_release,
    .submit = proxy_submit,
    .wait = proxy_wait,
    .completed = proxy_completed,
    .refused = proxy_refused,
    .lost = proxy_lost,
    .timings = proxy_timings,
    .peer_capable = proxy_peer_capable,
    .peer_move = proxy_peer_move,
    .encoder_open = proxy_encoder_open,
    .encoder_send = proxy_encoder_send,
    .encoder_receive = proxy_encoder_receive,
    .encoder_close = proxy_encoder_close,
};

const cv_backend *cv_proxy_backend(void) { return &proxy_backend; }

cv_result cv_proxy_get_stats(cv_device *dev, cv_proxy_stats *out) {
    if (!dev || !out || strcmp(cv_device_get_info(dev)->backend, "proxy") != 0)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_proxy_get_stats: not a proxy device");
    proxy_device *p = cv_device_backend_data(dev);
    pthread_mutex_lock(&p->lock);
    *out = p->stats;
    pthread_mutex_unlock(&p->lock);
    return CV_OK;
}

cv_result cv_proxy_query_node(const char *endpoint, uint32_t timeout_ms, cv_proxy_node_info *out) {
    if (!endpoint || !out)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_proxy_query_node: NULL argument");
    cv_rpc_client *client;
    proxy_settings *s = malloc(sizeof(*s));
    if (!s)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "cv_proxy_query_node: settings");
    proxy_settings_get(s);
    cv_rpc_client_config cc;
    proxy_client_config(s, &cc);
    cv_result r = cv_rpc_client_create(endpoint, &cc, &client);
    memset(s->token, 0, sizeof(s->token));
    free(s);
    if (r != CV_OK) /* this client's settings (token and TLS files): creating connects nothing yet */
        return cv_error(r, "node '%s': %s", endpoint, cv_last_error());
    Corvid__InfoRequest req = CORVID__INFO_REQUEST__INIT;
    uint8_t buf[16];
    size_t n = corvid__info_request__pack(&req, buf);
    void *resp = NULL;
    size_t resp_size = 0;
    int status = 0;
    r = cv_rpc_client_unary(client, CV_NODE_METHOD_INFO, buf, n, timeout_ms ? timeout_ms : 10000, &resp, &resp_size,
                            &status);
    cv_rpc_client_destroy(client);
    if (r != CV_OK)
        return cv_error(CV_ERROR_CONNECTION, "node '%s': %s", endpoint, cv_last_error());
    Corvid__NodeInfo *info = corvid__node_info__unpack(NULL, resp_size, resp);
    free(resp);
    if (!info)
        return cv_error(CV_ERROR_MALFORMED, "node '%s': the answer to Info is not a corvid.NodeInfo", endpoint);
    memset(out, 0, sizeof(*out));
    snprintf(out->name, sizeof(out->name), "%s", info->node_name ? info->node_name : "");
    out->protocol_version = info->protocol_version;
    out->sessions = info->sessions;
    out->device_count = info->n_devices < 64 ? (uint32_t)info->n_devices : 64;
    for (uint32_t i = 0; i < out->device_count; i++) {
        cv_node_info_from_msg(info->devices[i], &out->devices[i]);
        snprintf(out->labels[i], CV_LABEL_MAX, "%s", info->devices[i]->label ? info->devices[i]->label : "");
        out->devices[i].adapter_index = i;
    }
    corvid__node_info__free_unpacked(info, NULL);
    if (out->protocol_version != CV_NODE_PROTOCOL_VERSION)
        return cv_error(CV_ERROR_UNSUPPORTED, "node '%s' speaks protocol version %u, this client %u", endpoint,
                        out->protocol_version, CV_NODE_PROTOCOL_VERSION);
    return CV_OK;
}
