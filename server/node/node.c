/* corvid-node's server (node.h): devices probed at start, the content store,
 * the gRPC service (sessions, Info, grpc.health.v1), drain and stop. */
#include <arpa/inet.h>
#include <inttypes.h>
#include <malloc.h>
#include <stdatomic.h>
#include <openssl/crypto.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <unistd.h>

#include "corvid/sha256.h"

#include "health.pb-c.h"
#include "node_internal.h"
#include "peer.h"
#include "peer_members.h"

enum {
    STATUS_OK = 0,
    STATUS_INVALID_ARGUMENT = 3,
    STATUS_NOT_FOUND = 5,
    STATUS_INTERNAL = 13,
    STATUS_UNAVAILABLE = 14,
    STATUS_UNAUTHENTICATED = 16
};

static const char *const stream_methods[] = { CV_NODE_METHOD_SESSION, NULL };
static const char *const unary_methods[] = { CV_NODE_METHOD_INFO, CV_HEALTH_METHOD_CHECK, CV_NODE_METHOD_PEER_PIECE,
                                             NULL };

/* Hands the heap's free pages back to the system after a session ended (node.h, "Memory"): without it a
 * burst of 256 lavapipe sessions left about 1 GiB resident in glibc's arenas after they all closed. Trims
 * run one at a time (malloc_trim walks every arena under its lock); a session that ends during a trim
 * leaves a request the trimming thread takes up, so the last one to end is always followed by a trim. */
static void give_back_memory(cv_node *node) {
#ifdef __GLIBC__
    atomic_fetch_add(&node->trim_requests, 1);
    while (atomic_load(&node->trim_requests) && !atomic_exchange(&node->trimming, true)) {
        atomic_store(&node->trim_requests, 0);
        malloc_trim(0);
        atomic_store(&node->trimming, false);
    }
#else
    (void)node;
#endif
}

static void on_stream(cv_rpc_stream *stream, const char *method, void *user) {
    (void)method; /* the only stream method */
    cv_node_session_run(user, stream);
    give_back_memory(user);
}

cv_result cv_node_memory_reserve(cv_node *node, uint64_t bytes) {
    uint_fast64_t used = atomic_load(&node->memory_used);
    do {
        if (bytes > node->memory_limit - used) {
            atomic_fetch_add(&node->quota_refusals, 1);
            return cv_error(CV_ERROR_LIMIT_EXCEEDED,
                            "node memory limit exceeded: create of %" PRIu64
                            " bytes: the node's sessions hold %" PRIu64
                            " bytes of device memory of its limit of %" PRIu64 " (corvid-node --memory-limit %" PRIu64
                            ")",
                            bytes, (uint64_t)used, node->memory_limit, node->memory_limit);
        }
    } while (!atomic_compare_exchange_weak(&node->memory_used, &used, used + bytes));
    return CV_OK;
}

void cv_node_memory_release(cv_node *node, uint64_t bytes) { atomic_fetch_sub(&node->memory_used, bytes); }

/* Contexts of abandoned sessions. process-wide rather than per node: they must outlive the node that
 * abandoned them (a GPU job that never ends keeps using their memory), and holding them here keeps them
 * reachable, so LeakSanitizer does not report the deliberate leak as a bug and fail the process. */
static pthread_mutex_t abandoned_lock = PTHREAD_MUTEX_INITIALIZER;
static cv_context **abandoned;
static size_t abandoned_count, abandoned_capacity;

void cv_node_keep_abandoned(cv_context *ctx) {
    pthread_mutex_lock(&abandoned_lock);
    if (abandoned_count == abandoned_capacity) {
        size_t cap = abandoned_capacity ? 2 * abandoned_capacity : 8;
        cv_context **grown = realloc(abandoned, cap * sizeof(*grown));
        if (grown) {
            abandoned = grown;
            abandoned_capacity = cap;
        }
    }
    if (abandoned_count < abandoned_capacity) /* else, out of memory: leaked unheld, as intended anyway */
        abandoned[abandoned_count++] = ctx;
    pthread_mutex_unlock(&abandoned_lock);
}

/* The default node-wide memory limit: the machine's physical memory (lavapipe's device memory is host
 * memory; a GPU server has at least as much host memory as its GPUs have device memory, as a rule). */
static uint64_t default_memory_limit(void) {
    long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGESIZE);
    return pages > 0 && page > 0 ? (uint64_t)pages * (uint64_t)page : CV_NODE_FALLBACK_MEMORY_LIMIT;
}

/* Every call but health must carry "authorization: Bearer <token>" when the node has a token. The presented
 * token is hashed and the two SHA-256 digests compared with CRYPTO_memcmp: the time taken depends on neither
 * the token's content nor its length. Refusals are counted and logged with the peer, never the token. */
static int on_call(const char *method, const char *peer, const cv_rpc_metadata *md, uint32_t count, char *message,
                   size_t cap, void *user) {
    cv_node *node = user;
    if (!node->has_token || strcmp(method, CV_HEALTH_METHOD_CHECK) == 0)
        return STATUS_OK;
    const char *auth = NULL;
    uint32_t seen = 0;
    for (uint32_t i = 0; i < count; i++)
        if (strcmp(md[i].key, "authorization") == 0) {
            auth = md[i].value;
            seen++;
        }
    const char *why = NULL;
    if (!auth)
        why = "no 'authorization' metadata";
    else if (seen > 1)
        why = "more than one 'authorization' metadata";
    else if (strncasecmp(auth, "Bearer ", 7) != 0)
        why = "'authorization' is not 'Bearer <token>'";
    else {
        uint8_t digest[CV_SHA256_SIZE];
        if (cv_sha256(auth + 7, strlen(auth + 7), digest) != CV_OK)
            why = "the token could not be checked";
        else if (CRYPTO_memcmp(digest, node->token_sha, sizeof(digest)) != 0)
            why = "wrong token";
        OPENSSL_cleanse(digest, sizeof(digest));
    }
    if (!why)
        return STATUS_OK;
    atomic_fetch_add(&node->unauthenticated, 1);
    node_log(&node->log, NODE_LOG_REFUSED_CALL, "refused %s from %s: %s", method, peer, why);
    snprintf(message, cap,
             "unauthenticated: %s (this node needs its bearer token: the client reads it from the "
             "file named by CORVID_NODE_TOKEN_FILE)",
             why);
    return STATUS_UNAUTHENTICATED;
}

cv_result cv_node_check_peers(const char *peers, const char *what) {
    peer_members *m;
    cv_result r = peer_members_create(peers, what, false, &m);
    peer_members_destroy(m);
    return r;
}

bool cv_node_listen_is_local(const char *listen) {
    if (!listen)
        return false;
    if (strncmp(listen, "unix:", 5) == 0 || strncmp(listen, "unix-abstract:", 14) == 0)
        return true;
    if (strncmp(listen, "ipv4:", 5) == 0 || strncmp(listen, "ipv6:", 5) == 0)
        listen += 5;
    char host[256];
    if (listen[0] == '[') {
        const char *end = strchr(listen, ']');
        if (!end || (size_t)(end - listen - 1) >= sizeof(host))
            return false;
        snprintf(host, sizeof(host), "%.*s", (int)(end - listen - 1), listen + 1);
    } else {
        const char *colon = strrchr(listen, ':');
        size_t n = colon ? (size_t)(colon - listen) : strlen(listen);
        if (n >= sizeof(host))
            return false;
        snprintf(host, sizeof(host), "%.*s", (int)n, listen);
    }
    if (strcasecmp(host, "localhost") == 0)
        return true;
    struct in_addr v4;
    if (inet_pton(AF_INET, host, &v4) == 1)
        return (ntohl(v4.s_addr) >> 24) == 127;
    struct in6_addr v6;
    if (inet_pton(AF_INET6, host, &v6) == 1)
        return IN6_IS_ADDR_LOOPBACK(&v6) || (IN6_IS_ADDR_V4MAPPED(&v6) && v6.s6_addr[12] == 127);
    return false; /* "", "0.0.0.0", "::", a host name: reachable from elsewhere */
}

/* InfoRequest has no fields in this protocol version: bytes that are not one, or fields a newer client may
 * send, are refused by name rather than ignored (the client would otherwise believe they were honoured). */
static int check_info_request(const void *request, size_t size, char *message, size_t cap) {
    Corvid__InfoRequest *req = corvid__info_request__unpack(NULL, size, request);
    if (!req) {
        snprintf(message, cap, "Info: %zu bytes are not a corvid.InfoRequest", size);
        return STATUS_INVALID_ARGUMENT;
    }
    int status = STATUS_OK;
    if (req->base.n_unknown_fields) {
        snprintf(message, cap,
                 "Info: InfoRequest field %u is not served by this node (protocol version %u, whose InfoRequest has "
                 "no fields)",
                 req->base.unknown_fields[0].tag, CV_NODE_PROTOCOL_VERSION);
        status = STATUS_INVALID_ARGUMENT;
    }
    corvid__info_request__free_unpacked(req, NULL);
    return status;
}

static int answer_info(cv_node *node, void **response, size_t *size, char *message, size_t cap) {
    Corvid__DeviceInfo *items = calloc(node->config.device_count, sizeof(*items));
    Corvid__DeviceInfo **ptrs = calloc(node->config.device_count, sizeof(*ptrs));
    cv_node_info_storage *storage = calloc(node->config.device_count, sizeof(*storage));
    int status = STATUS_OK;
    if (!items || !ptrs || !storage) {
        snprintf(message, cap, "node out of memory");
        status = STATUS_INTERNAL;
    } else {
        for (uint32_t i = 0; i < node->config.device_count; i++) {
            cv_node_info_to_msg(&node->device_info[i], node->devices[i].label, &items[i], &storage[i]);
            ptrs[i] = &items[i];
        }
        Corvid__NodeInfo info = CORVID__NODE_INFO__INIT;
        info.protocol_version = CV_NODE_PROTOCOL_VERSION;
        info.node_name = node->name;
        info.n_devices = node->config.device_count;
        info.devices = ptrs;
        info.sessions = (uint32_t)atomic_load(&node->sessions_active);
        *size = corvid__node_info__get_packed_size(&info);
        *response = malloc(*size ? *size : 1);
        if (*response)
            corvid__node_info__pack(&info, *response);
        else {
            snprintf(message, cap, "node out of memory");
            status = STATUS_INTERNAL;
        }
    }
    free(items);
    free(ptrs);
    free(storage);
    return status;
}

static int answer_health(cv_node *node, const void *request, size_t request_size, void **response, size_t *size,
                         char *message, size_t cap) {
    Grpc__Health__V1__HealthCheckRequest *req = grpc__health__v1__health_check_request__unpack(NULL, request_size,
                                                                                               request);
    if (!req) {
        snprintf(message, cap, "not a grpc.health.v1.HealthCheckRequest");
        return STATUS_INVALID_ARGUMENT;
    }
    /* "" is the server as a whole; "corvid.Node" is its one service. */
    bool known = !req->service[0] || strcmp(req->service, "corvid.Node") == 0;
    if (!known)
        snprintf(message, cap, "unknown service '%.200s' (this node serves \"\" and \"corvid.Node\")", req->service);
    grpc__health__v1__health_check_request__free_unpacked(req, NULL);
    if (!known)
        return STATUS_NOT_FOUND;
    Grpc__Health__V1__HealthCheckResponse resp = GRPC__HEALTH__V1__HEALTH_CHECK_RESPONSE__INIT;
    resp.status = atomic_load(&node->draining) ? GRPC__HEALTH__V1__HEALTH_CHECK_RESPONSE__SERVING_STATUS__NOT_SERVING
                                               : GRPC__HEALTH__V1__HEALTH_CHECK_RESPONSE__SERVING_STATUS__SERVING;
    *size = grpc__health__v1__health_check_response__get_packed_size(&resp);
    *response = malloc(*size ? *size : 1);
    if (!*response) {
        snprintf(message, cap, "node out of memory");
        return STATUS_INTERNAL;
    }
    grpc__health__v1__health_check_response__pack(&resp, *response);
    return STATUS_OK;
}

static const char *const health_methods[] = { CV_HEALTH_METHOD_CHECK, NULL };

static int on_health_unary(const char *method, const void *request, size_t size, void **response,
                           size_t *response_size, char *message, size_t message_cap, void *user) {
    (void)method; /* the only method served there */
    return answer_health(user, request, size, response, response_size, message, message_cap);
}

static int on_unary(const char *method, const void *request, size_t size, void **response, size_t *response_size,
                    char *message, size_t message_cap, void *user) {
    cv_node *node = user;
    if (strcmp(method, CV_HEALTH_METHOD_CHECK) == 0)
        return answer_health(node, request, size, response, response_size, message, message_cap);
    if (strcmp(method, CV_NODE_METHOD_PEER_PIECE) == 0) {
        *response = NULL;
        *response_size = 0;
        return peer_on_piece(node->peer, request, size, message, message_cap);
    }
    int status = check_info_request(request, size, message, message_cap);
    return status != STATUS_OK ? status : answer_info(node, response, response_size, message, message_cap);
}

/* Nodes started and not yet stopped. process-wide: it counts every node of the process, for the
 * end-of-test check that a test stopped what it started (cv_live_nodes, as cv_live_contexts). */
static atomic_uint live_nodes;

uint32_t cv_live_nodes(void) { return atomic_load(&live_nodes); }

static void free_node(cv_node *node) {
    atomic_fetch_sub(&live_nodes, 1);
    node_log_flush(&node->log);
    node_log_finish(&node->log);
    OPENSSL_cleanse(node->token_sha, sizeof(node->token_sha));
    peer_state_destroy(node->peer);
    peer_members_destroy(node->members);
    if (node->store)
        cv_content_store_close(node->store);
    cv_node_metrics_destroy(node->metrics);
    free(node->devices);
    free(node->device_info);
    free(node);
}

/* Opens each device once, to report what it is before any session asks. */
static cv_result probe_devices(cv_node *node) {
    cv_context *ctx;
    cv_result r = cv_context_create(NULL, &ctx);
    for (uint32_t i = 0; r == CV_OK && i < node->config.device_count; i++) {
        cv_device_desc desc = { .adapter = node->devices[i].adapter,
                                .validation = node->config.validation,
                                .backend_options = node->devices[i].backend_options };
        snprintf(desc.label, sizeof(desc.label), "%s", node->devices[i].label);
        cv_device *dev;
        r = cv_device_create(ctx, node->devices[i].backend, &desc, &dev);
        if (r != CV_OK)
            return cv_error(r, "node device %u ('%s'): %s", i, node->devices[i].label, cv_last_error());
        node->device_info[i] = *cv_device_get_info(dev);
        cv_device_destroy(dev);
    }
    if (ctx)
        cv_context_destroy(ctx);
    return r;
}

/* What cv_node_start refuses before it starts anything. */
static cv_result check_config(const cv_node_config *config) {
    if (config->device_count == 0 || config->device_count > CV_MAX_DEVICES)
        return cv_error(CV_ERROR_OUT_OF_RANGE, "node: %u devices (1..%u)", config->device_count, CV_MAX_DEVICES);
    if (config->token && !config->token[0])
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "node: the token is empty");
    if (!config->token && !cv_node_listen_is_local(config->listen))
        return cv_error(CV_ERROR_INVALID_ARGUMENT,
                        "node: listening on '%s', which is not loopback, needs a token "
                        "(corvid-node: --token-file FILE or CORVID_NODE_TOKEN_FILE, a file whose first line is the "
                        "token; clients read theirs from CORVID_NODE_TOKEN_FILE), or listen on 127.0.0.1",
                        config->listen);
    if (config->cache_bytes && config->cache_bytes < CV_NODE_MIN_CACHE_BYTES)
        return cv_error(CV_ERROR_OUT_OF_RANGE,
                        "node: a content store of %" PRIu64
                        " bytes (cache_bytes, corvid-node --cache-size) is too "
                        "small: at least %llu bytes (16M); a blob larger than the store is refused",
                        config->cache_bytes, CV_NODE_MIN_CACHE_BYTES);
    if (config->quota.inflight > CV_NODE_MAX_QUOTA_INFLIGHT)
        return cv_error(CV_ERROR_OUT_OF_RANGE, "node: quota of %u lists in flight (at most %u)",
                        config->quota.inflight, CV_NODE_MAX_QUOTA_INFLIGHT);
    return CV_OK;
}

/* The node's own copy of its configuration: devices, name, quota and limits with their defaults; what is used
 * only at start (addresses, the cache directory, TLS files, the peer settings that peer.h copies) or must not
 * be kept (the token: only its hash is) cleared. */
static cv_result copy_config(cv_node *node, const cv_node_config *config) {
    const cv_node_quota *q = &config->quota;
    node->quota = (cv_node_quota){
        .memory_bytes = q->memory_bytes ? q->memory_bytes : CV_NODE_DEFAULT_QUOTA_MEMORY,
        .resources = q->resources ? q->resources : CV_NODE_DEFAULT_QUOTA_RESOURCES,
        .inflight = q->inflight ? q->inflight : CV_NODE_DEFAULT_QUOTA_INFLIGHT,
        .upload_bytes = q->upload_bytes ? q->upload_bytes : CV_NODE_DEFAULT_QUOTA_UPLOAD,
    };
    node->memory_limit = config->memory_bytes ? config->memory_bytes : default_memory_limit();
    node->config = *config;
    node->devices = calloc(config->device_count, sizeof(*node->devices));
    node->device_info = calloc(config->device_count, sizeof(*node->device_info));
    node->metrics = cv_node_metrics_create(config->device_count);
    if (!node->devices || !node->device_info || !node->metrics)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "cv_node_start");
    memcpy(node->devices, config->devices, config->device_count * sizeof(*node->devices));
    node->config.devices = node->devices;
    for (uint32_t i = 0; i < config->device_count; i++) {
        node->devices[i].adapter[sizeof(node->devices[i].adapter) - 1] = '\0';
        node->devices[i].label[sizeof(node->devices[i].label) - 1] = '\0';
        if (!node->devices[i].label[0])
            snprintf(node->devices[i].label, sizeof(node->devices[i].label), "gpu%u", i);
    }
    if (config->name)
        snprintf(node->name, sizeof(node->name), "%s", config->name);
    else if (gethostname(node->name, sizeof(node->name) - 1) != 0)
        snprintf(node->name, sizeof(node->name), "corvid-node");
    node->config.name = node->name;
    node->config.listen = NULL;
    node->config.cache_dir = NULL;                                  /* used only at start */
    node->config.token = NULL;                                      /* only its hash is kept */
    node->config.peers = NULL;                                      /* parsed into node->members */
    node->config.peer_token = node->config.peer_tls_ca_file = NULL; /* peer.h keeps copies */
    node->config.tls_cert_file = node->config.tls_key_file = node->config.tls_client_ca_file = NULL;
    node->config.quota = node->quota;
    node->config.memory_bytes = node->memory_limit;
    return CV_OK;
}

/* The node's peer machinery, counting and logging into the node. */
static cv_result start_peer(cv_node *node, const cv_node_config *config) {
    peer_config pc = {
        .keepalive_ms = config->peer_keepalive_ms,
        .deadline_ms = config->peer_deadline_ms ? config->peer_deadline_ms : CV_NODE_DEFAULT_PEER_DEADLINE_MS,
        .token = config->peer_token,
        .tls_ca_file = config->peer_tls_ca_file,
        .members = node->members,
        .metrics = node->metrics,
        .log = &node->log,
        .errors = &node->errors,
    };
    return peer_state_create(&pc, &node->peer);
}

/* The sessions' server and, if asked for, the plaintext health server. */
static cv_result start_servers(cv_node *node, const cv_node_config *config) {
    cv_rpc_server_config rc = {
        .listen = config->listen,
        .max_message_bytes = CV_NODE_MAX_MESSAGE_BYTES,
        .max_streams = config->max_sessions ? config->max_sessions : 256,
        .on_stream = on_stream,
        .on_unary = on_unary,
        .stream_methods = stream_methods,
        .unary_methods = unary_methods,
        .on_call = on_call,
        .user = node,
        .tls_cert_file = config->tls_cert_file,
        .tls_key_file = config->tls_key_file,
        .tls_client_ca_file = config->tls_client_ca_file,
    };
    cv_result r = cv_rpc_server_start(&rc, &node->server);
    if (r != CV_OK || !config->health_listen)
        return r;
    cv_rpc_server_config hc = {
        .listen = config->health_listen,
        .max_message_bytes = 4096,
        .max_streams = 1,
        .on_unary = on_health_unary,
        .unary_methods = health_methods,
        .user = node,
    };
    r = cv_rpc_server_start(&hc, &node->health_server);
    if (r != CV_OK) {
        char why[1024];
        snprintf(why, sizeof(why), "%s", cv_last_error());
        cv_rpc_server_destroy(node->server, 0);
        return cv_error(r, "node: health port '%s': %s", config->health_listen, why);
    }
    return CV_OK;
}

cv_result cv_node_start(const cv_node_config *config, cv_node **out) {
    if (!config || !out || !config->devices || !config->listen || !config->cache_dir)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_node_start: NULL config, devices, listen or cache_dir");
    cv_result r = check_config(config);
    if (r != CV_OK)
        return r;
    peer_members *members;
    r = peer_members_create(config->peers, "node: peers", cv_node_listen_is_local(config->listen), &members);
    if (r != CV_OK)
        return r;
    cv_node *node = calloc(1, sizeof(*node));
    if (!node) {
        peer_members_destroy(members);
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "cv_node_start");
    }
    atomic_fetch_add(&live_nodes, 1); /* free_node takes it off again */
    node->members = members;
    node_log_init(&node->log, config->log_sessions, config->log_sink, config->log_user);
    if (config->token) {
        r = cv_sha256(config->token, strlen(config->token), node->token_sha);
        node->has_token = r == CV_OK;
    }
    if (r == CV_OK)
        r = copy_config(node, config);
    if (r == CV_OK)
        r = probe_devices(node);
    if (r == CV_OK)
        r = start_peer(node, config);
    if (r == CV_OK)
        r = cv_content_store_open(config->cache_dir, config->cache_bytes ? config->cache_bytes : 4ull << 30,
                                  &node->store);
    if (r == CV_OK)
        r = start_servers(node, config);
    if (r != CV_OK) {
        free_node(node);
        return r;
    }
    node->config.health_listen = NULL;
    *out = node;
    return CV_OK;
}

int cv_node_port(const cv_node *node) { return cv_rpc_server_port(node->server); }

int cv_node_health_port(const cv_node *node) {
    return node->health_server ? cv_rpc_server_port(node->health_server) : 0;
}

void cv_node_drain(cv_node *node) {
    atomic_store(&node->draining, true);
    cv_rpc_server_drain(node->server);
}

uint32_t cv_node_wait_sessions(cv_node *node, uint32_t timeout_ms) {
    return cv_rpc_server_wait_streams(node->server, timeout_ms);
}

void cv_node_cancel_sessions(cv_node *node, const char *reason) {
    if (!node || atomic_load(&node->stopping_sessions))
        return; /* the first reason stands */
    snprintf(node->stop_reason, sizeof(node->stop_reason), "%s", reason && *reason ? reason : "node stopped");
    atomic_store(&node->stopping_sessions, true);
    char message[sizeof(node->stop_reason) + 32];
    snprintf(message, sizeof(message), "node shutting down: %s", node->stop_reason);
    cv_rpc_server_finish_streams(node->server, STATUS_UNAVAILABLE, message);
}

void cv_node_stop(cv_node *node, uint32_t timeout_ms) {
    if (!node)
        return;
    cv_node_drain(node);
    if (cv_rpc_server_wait_streams(node->server, timeout_ms) > 0) {
        char reason[96];
        snprintf(reason, sizeof(reason), "stop timeout (%u ms) expired", timeout_ms);
        cv_node_cancel_sessions(node, reason);
    }
    /* Told to end, a session returns once its current request is done: a bounded wait, then the calls go. */
    cv_rpc_server_destroy(node->server, CV_NODE_CANCEL_GRACE_MS);
    cv_rpc_server_destroy(node->health_server, 0); /* NOT_SERVING until here */
    free_node(node);
}

cv_node_stats cv_node_get_stats(cv_node *node) {
    cv_content_stats cs = cv_content_store_stats(node->store);
    peer_counters peer = peer_get_counters(node->peer);
    return (cv_node_stats){
        .sessions_started = atomic_load(&node->sessions_started),
        .sessions_active = atomic_load(&node->sessions_active),
        .messages_in = atomic_load(&node->messages_in),
        .bytes_in = atomic_load(&node->bytes_in),
        .bytes_out = atomic_load(&node->bytes_out),
        .submissions = atomic_load(&node->submissions),
        .errors = atomic_load(&node->errors),
        .cache_hits = cs.hits,
        .cache_misses = cs.misses,
        .cache_bytes = cs.bytes,
        .unauthenticated = atomic_load(&node->unauthenticated),
        .quota_refusals = atomic_load(&node->quota_refusals),
        .memory_bytes = atomic_load(&node->memory_used),
        .memory_limit = node->memory_limit,
        .peer_raw_out = peer.raw_out,
        .peer_bytes_out = peer.bytes_out,
        .peer_bytes_in = peer.bytes_in,
        .peer_failures = peer.failures,
        .transfer_failures = atomic_load(&node->transfer_failures),
        .devices_abandoned = atomic_load(&node->devices_abandoned),
    };
}
