/* corvid-node: the render-proxy server. Serves this machine's devices (real
 * GPUs, virtual GPUs, lavapipe, or mock devices) to remote clients over gRPC;
 * see server/node/node.h and proto/node.proto.
 *
 *   corvid-node --listen 0.0.0.0:7700 --token-file /etc/corvid/token --tls-cert node.pem --tls-key node.key \
 *               --adapters H100 --gpus 2
 *   corvid-node --listen 127.0.0.1:0 --backend mock      (prints the port it got)
 *
 * SIGTERM or SIGINT drains: new sessions are refused, health says NOT_SERVING,
 * running sessions get --drain-timeout seconds to finish, then the node exits 0. */
#include <errno.h>
#include <inttypes.h>
#include <limits.h>
#include <pthread.h>
#include <signal.h>
#include <stdio.h>
#include <time.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "corvid/file_util.h"
#include "corvid/log.h"
#include "corvid/parse.h"
#include "corvid/rpc.h"
#include "corvid/vulkan.h"
#include "env_log.h"
#include "env_client.h"
#include "env_vulkan.h"
#include "metrics_http.h"
#include "node.h"
#include "node_metrics_args.h"

typedef struct options {
    const char *listen;
    const char *backend;
    const char *cache_dir;
    const char *name;
    const char *port_file;
    const char *token_file;
    const char *tls_cert, *tls_key, *tls_client_ca;
    cv_node_quota quota;
    uint64_t memory_limit;
    uint64_t cache_bytes;
    uint32_t idle_timeout_s;
    uint32_t submit_timeout_s;
    uint32_t drain_timeout_s;
    uint32_t max_sessions;
    uint32_t mock_devices;
    uint32_t peer_deadline_ms, peer_keepalive_ms;
    const char *peer_tls_ca;
    const char *peers;
    const char *health_listen;
    bool validation;
    bool quiet;
} options;

static void usage(FILE *f) {
    fprintf(f,
            "usage: corvid-node [options]\n"
            "Serves this machine's devices to Corvid clients (the proxy backend) over gRPC.\n\n"
            "  --listen HOST:PORT     address to listen on [127.0.0.1:7700]; port 0 picks a free one\n"
            "  --backend vulkan|mock  what the devices are [vulkan]\n"
            "  --adapters LIST        Vulkan adapters (index or name substring, comma-separated)\n"
            "  --gpus N               devices in all, round-robin over the adapters\n"
            "  --virtual-gpus N       device instances per adapter (also CORVID_VIRTUAL_GPUS)\n"
            "  --mock-devices N       devices of the mock backend [1] (1..64)\n"
            "  --cache-dir DIR        content-addressed upload cache [$XDG_CACHE_HOME/corvid-node, or\n"
            "                         ~/.cache/corvid-node]\n"
            "  --cache-size BYTES     cache size limit, with an optional K, M or G suffix [4G] (at least\n"
            "                         16M; a blob larger than the limit is refused with LIMIT_EXCEEDED)\n"
            "  --idle-timeout SEC     end sessions silent for this long [300] (1..86400)\n"
            "  --submit-timeout SEC   a submission not done this long after the one before it ends its session;\n"
            "                         the device is abandoned (its GPU may still run it) [60] (1..86400)\n"
            "  --drain-timeout SEC    on SIGTERM, how long running sessions may go on [30] (0..3600)\n"
            "  --max-sessions N       concurrent sessions [256] (1..65536)\n"
            "  --peer-deadline-ms MS  clusters: how long a session waits for a partition another node sends\n"
            "                         it, and a send to another node may take [10000] (100..600000)\n"
            "  --peer-keepalive-ms MS clusters: keepalive of the channels to other nodes [10000] (100..600000)\n"
            "  --peer-tls-ca FILE     clusters: reach other nodes over TLS, trusting this CA (they present\n"
            "                         this node's --token-file token, so a cluster shares one token)\n"
            "  --peers HOST:PORT,...  clusters: the only nodes this node sends partitions to, as clients name\n"
            "                         them (compared after normalisation, never resolved first) [none: a\n"
            "                         loopback node sends to loopback addresses only, any other to none]\n"
            "  --health-listen HOST:PORT  a plaintext port serving only grpc.health.v1 Health/Check, for\n"
            "                         probes that speak no TLS (Kubernetes) next to a TLS --listen [off]\n"
            "  --name NAME            the name clients see [the host name]\n"
            "  --port-file FILE       write the bound port to FILE once listening\n"
            "  --metrics-port PORT    serve Prometheus metrics at /metrics on PORT (0 picks a free one) [off]\n"
            "  --metrics-listen ADDR  numeric address for the metrics port [127.0.0.1]; anything but loopback\n"
            "                         wants --metrics-token-file (a warning says so)\n"
            "  --metrics-token-file FILE  scrapes must send 'Authorization: Bearer <token>' (the file's first\n"
            "                         line; may be the --token-file); others get 401\n"
            "  --validation           Vulkan validation layer on session devices\n"
            "  --quiet                no per-session log lines\n"
            "  --help                 this text\n"
            "\nSecurity (docs/node.md, \"Security\"):\n"
            "  --token-file FILE      clients must send this bearer token (the file's first line) on every\n"
            "                         session and Info call; also CORVID_NODE_TOKEN_FILE. Required unless\n"
            "                         --listen is loopback (127.0.0.0/8, ::1, localhost). Never on the command "
            "line.\n"
            "  --tls-cert FILE        TLS: the node's certificate chain (PEM); with --tls-key\n"
            "  --tls-key FILE         TLS: its private key (PEM)\n"
            "  --tls-client-ca FILE   mutual TLS: clients need a certificate signed by this CA (PEM)\n"
            "\nPer-session quotas (a request past one is refused, the session goes on):\n"
            "  --quota-memory BYTES   device memory: buffers + textures + acceleration structures [16G]\n"
            "  --quota-resources N    live resources of every type [65536] (1..16777216)\n"
            "  --quota-inflight N     lists submitted and not completed [256] (1..1024)\n"
            "  --quota-upload BYTES   bytes one session may add to the upload cache [8G]\n"
            "  (message size: 4 MiB per message, fixed by the protocol)\n"
            "\nNode-wide:\n"
            "  --memory-limit BYTES   device memory all sessions together may hold (counted as\n"
            "                         --quota-memory counts it) [the machine's physical memory]\n");
}

/* Numbers: plain decimal digits, as every Corvid program reads them (corvid/parse.h). */
static int parse_u32(const char *opt, const char *text, uint32_t lo, uint32_t hi, uint32_t *out) {
    uint64_t v;
    if (!cv_parse_uint(text, lo, hi, &v)) {
        fprintf(stderr, "corvid-node: %s: '%s' is not a whole number in %u..%u\n", opt, text ? text : "", lo, hi);
        return 2;
    }
    *out = (uint32_t)v;
    return 0;
}

/* Digits, then at most one of K, M, G (binary multiples). */
static int parse_size(const char *opt, const char *text, uint64_t *out) {
    size_t digits = strspn(text, "0123456789");
    char number[24] = "";
    uint64_t v = 0, scale = 1;
    if (digits < sizeof number)
        snprintf(number, sizeof number, "%.*s", (int)digits, text);
    if (text[digits]) {
        switch (text[digits]) {
        case 'K':
        case 'k': scale = 1ull << 10; break;
        case 'M':
        case 'm': scale = 1ull << 20; break;
        case 'G':
        case 'g': scale = 1ull << 30; break;
        default: scale = 0; break;
        }
        if (text[digits + 1])
            scale = 0;
    }
    if (scale == 0 || !cv_parse_uint(number, 1, UINT64_MAX / scale, &v)) {
        fprintf(stderr, "corvid-node: %s: '%s' is not a size (bytes, or a number with K, M or G)\n", opt,
                text ? text : "");
        return 2;
    }
    *out = v * scale;
    return 0;
}

/* One option that takes a value: 0 when taken, 2 after a message, -1 when no such option. */
static int parse_valued(const char *name, const char *value, options *o) {
    int bad = 0;
    if (!strcmp(name, "--listen")) {
        o->listen = value;
    } else if (!strcmp(name, "--backend")) {
        if (strcmp(value, "vulkan") && strcmp(value, "mock")) {
            fprintf(stderr, "corvid-node: --backend: '%s' is not vulkan or mock\n", value);
            return 2;
        }
        o->backend = value;
    } else if (!strcmp(name, "--mock-devices")) {
        bad = parse_u32(name, value, 1, 64, &o->mock_devices);
    } else if (!strcmp(name, "--cache-dir")) {
        o->cache_dir = value;
    } else if (!strcmp(name, "--cache-size")) {
        bad = parse_size(name, value, &o->cache_bytes);
        if (!bad && o->cache_bytes < CV_NODE_MIN_CACHE_BYTES) {
            fprintf(stderr,
                    "corvid-node: --cache-size: '%s' is too small: at least 16M (a smaller store could not "
                    "hold a scene; a blob larger than the store is refused)\n",
                    value);
            bad = 2;
        }
    } else if (!strcmp(name, "--idle-timeout")) {
        bad = parse_u32(name, value, 1, 86400, &o->idle_timeout_s);
    } else if (!strcmp(name, "--submit-timeout")) {
        bad = parse_u32(name, value, 1, 86400, &o->submit_timeout_s);
    } else if (!strcmp(name, "--drain-timeout")) {
        bad = parse_u32(name, value, 0, 3600, &o->drain_timeout_s);
    } else if (!strcmp(name, "--peer-deadline-ms")) {
        bad = parse_u32(name, value, 100, 600000, &o->peer_deadline_ms);
    } else if (!strcmp(name, "--peer-keepalive-ms")) {
        bad = parse_u32(name, value, 100, 600000, &o->peer_keepalive_ms);
    } else if (!strcmp(name, "--peer-tls-ca")) {
        o->peer_tls_ca = value;
    } else if (!strcmp(name, "--peers")) {
        if (cv_node_check_peers(value, "--peers") != CV_OK) {
            fprintf(stderr, "corvid-node: %s\n", cv_last_error());
            return 2;
        }
        o->peers = value;
    } else if (!strcmp(name, "--health-listen")) {
        if (!strrchr(value, ':')) {
            fprintf(stderr, "corvid-node: --health-listen: '%s' is not HOST:PORT\n", value);
            bad = 2;
        }
        o->health_listen = value;
    } else if (!strcmp(name, "--max-sessions")) {
        bad = parse_u32(name, value, 1, 65536, &o->max_sessions);
    } else if (!strcmp(name, "--name")) {
        o->name = value;
    } else if (!strcmp(name, "--port-file")) {
        o->port_file = value;
    } else if (!strcmp(name, "--token-file")) {
        o->token_file = value;
    } else if (!strcmp(name, "--tls-cert")) {
        o->tls_cert = value;
    } else if (!strcmp(name, "--tls-key")) {
        o->tls_key = value;
    } else if (!strcmp(name, "--tls-client-ca")) {
        o->tls_client_ca = value;
    } else if (!strcmp(name, "--quota-memory")) {
        bad = parse_size(name, value, &o->quota.memory_bytes);
    } else if (!strcmp(name, "--quota-resources")) {
        bad = parse_u32(name, value, 1, 1u << 24, &o->quota.resources);
    } else if (!strcmp(name, "--quota-inflight")) {
        bad = parse_u32(name, value, 1, CV_NODE_MAX_QUOTA_INFLIGHT, &o->quota.inflight);
    } else if (!strcmp(name, "--quota-upload")) {
        bad = parse_size(name, value, &o->quota.upload_bytes);
    } else if (!strcmp(name, "--memory-limit")) {
        bad = parse_size(name, value, &o->memory_limit);
    } else if (!strcmp(name, "--token")) {
        fprintf(stderr,
                "corvid-node: --token: a token on the command line is visible to every user (ps); put "
                "it in a file and give --token-file FILE\n");
        return 2;
    } else {
        return -1;
    }
    return bad;
}

/* What the options say together, once all are read: 0, or 2 after a message. */
static int check_args(options *o) {
    if (!o->listen[0] || !strchr(o->listen, ':')) {
        fprintf(stderr, "corvid-node: --listen: '%s' is not HOST:PORT\n", o->listen);
        return 2;
    }
    if (!o->tls_cert != !o->tls_key) {
        fprintf(stderr, "corvid-node: %s needs %s too\n", o->tls_cert ? "--tls-cert" : "--tls-key",
                o->tls_cert ? "--tls-key" : "--tls-cert");
        return 2;
    }
    if (o->tls_client_ca && !o->tls_cert) {
        fprintf(stderr, "corvid-node: --tls-client-ca needs --tls-cert and --tls-key (mutual TLS is TLS)\n");
        return 2;
    }
    if (!o->token_file) {
        const char *env = getenv("CORVID_NODE_TOKEN_FILE");
        o->token_file = env && *env ? env : NULL;
    }
    return 0;
}

/* Returns 0 to run, 1 after --help, 2 on a bad option (nothing started). */
static int parse_args(int argc, char **argv, options *o) {
    *o = (options){ .listen = "127.0.0.1:7700",
                    .backend = "vulkan",
                    .cache_bytes = 4ull << 30,
                    .idle_timeout_s = 300,
                    .submit_timeout_s = 60,
                    .drain_timeout_s = 30,
                    .max_sessions = 256,
                    .mock_devices = 1 };
    for (int i = 1; i < argc; i++) {
        char *arg = argv[i];
        char *eq = strncmp(arg, "--", 2) == 0 ? strchr(arg, '=') : NULL;
        char name[64];
        snprintf(name, sizeof(name), "%.*s", eq ? (int)(eq - arg) : (int)strlen(arg), arg);
        bool flag = !strcmp(name, "--help") || !strcmp(name, "-h") || !strcmp(name, "--validation") ||
                    !strcmp(name, "--quiet");
        const char *value = NULL;
        if (!flag) {
            value = eq ? eq + 1 : (i + 1 < argc ? argv[++i] : NULL);
            if (!value) {
                fprintf(stderr, "corvid-node: %s needs a value (see --help)\n", name);
                return 2;
            }
        } else if (eq) {
            fprintf(stderr, "corvid-node: %s takes no value\n", name);
            return 2;
        }
        int bad = 0;
        if (!strcmp(name, "--help") || !strcmp(name, "-h")) {
            usage(stdout);
            return 1;
        } else if (!strcmp(name, "--validation")) {
            o->validation = true;
        } else if (!strcmp(name, "--quiet")) {
            o->quiet = true;
        } else {
            bad = parse_valued(name, value, o);
            if (bad < 0) {
                fprintf(stderr, "corvid-node: unknown option '%s' (see --help)\n", arg);
                return 2;
            }
        }
        if (bad)
            return bad;
    }
    return check_args(o);
}

/* The default cache directory, following the XDG base directory convention. */
static int default_cache_dir(char *out, size_t cap) {
    const char *xdg = getenv("XDG_CACHE_HOME");
    const char *home = getenv("HOME");
    int n = xdg && *xdg     ? snprintf(out, cap, "%s/corvid-node", xdg)
            : home && *home ? snprintf(out, cap, "%s/.cache/corvid-node", home)
                            : snprintf(out, cap, "/var/tmp/corvid-node-cache");
    return n > 0 && (size_t)n < cap ? 0 : -1;
}

/* Node devices from the Vulkan GPU table (or N mock devices). */
static cv_result make_devices(const options *o, const cv_vulkan_gpu_config *gpus, cv_node_device_spec *out,
                              uint32_t *count) {
    if (!strcmp(o->backend, "mock")) {
        for (uint32_t i = 0; i < o->mock_devices; i++) {
            out[i] = (cv_node_device_spec){ .backend = cv_mock_backend() };
            snprintf(out[i].label, sizeof(out[i].label), "mock%u", i);
        }
        *count = o->mock_devices;
        return CV_OK;
    }
    cv_vulkan_gpu_table table;
    cv_result r = cv_vulkan_gpu_table_build(gpus, &table);
    if (r != CV_OK)
        return r;
    for (uint32_t i = 0; i < table.count; i++) {
        out[i] = (cv_node_device_spec){ .backend = cv_vulkan_backend(), .backend_options = &gpus->device };
        snprintf(out[i].adapter, sizeof(out[i].adapter), "%u", table.gpus[i].adapter);
        snprintf(out[i].label, sizeof(out[i].label), "gpu%u", i);
    }
    *count = table.count;
    return CV_OK;
}

/* The /metrics endpoint, with its token (read before anything started; wiped here) if one is given; a warning
 * when it is open beyond this machine without one. */
static int start_metrics(cv_node *node, const node_metrics_options *mo, char *token, size_t token_cap,
                         cv_metrics_server **out) {
    char listen[80];
    snprintf(listen, sizeof(listen), "%s:%d", mo->listen ? mo->listen : "127.0.0.1", mo->port);
    if (!mo->token_file && !cv_node_listen_is_local(listen))
        fprintf(stderr,
                "corvid-node: warning: --metrics-listen %s without --metrics-token-file: anyone who reaches "
                "that port reads the metrics\n",
                mo->listen);
    cv_metrics_server_config mc = { .address = mo->listen, .port = mo->port, .token = mo->token_file ? token : NULL };
    cv_result r = cv_metrics_server_start(node, &mc, out);
    memset(token, 0, token_cap);
    if (r != CV_OK) {
        fprintf(stderr, "corvid-node: --metrics-port: %s\n", cv_last_error());
        return 1;
    }
    return 0;
}

/* The node's session log keeps its "corvid-node: " lines on stderr (deployments read them); other
 * libraries' messages read "corvid <origin>: ...". */
static void log_to_stderr(cv_log_level level, const char *origin, const char *message, void *user) {
    (void)level;
    (void)user;
    if (strcmp(origin, "node") == 0)
        fprintf(stderr, "corvid-node: %s\n", message);
    else
        fprintf(stderr, "corvid %s: %s\n", origin, message);
}

/* The node's token and the metrics token: read before anything starts, so a bad file is a clear error at
 * once; and a node open beyond this machine must have a token. 0, or 2 after a message. */
static int read_tokens(const options *o, const node_metrics_options *mo, char *token, size_t token_cap,
                       char *metrics_token, size_t metrics_cap) {
    if (o->token_file) {
        if (cv_rpc_read_token_file(o->token_file, token, token_cap) != CV_OK) {
            fprintf(stderr, "corvid-node: --token-file: %s\n", cv_last_error());
            return 2;
        }
        struct stat st;
        if (stat(o->token_file, &st) == 0 && (st.st_mode & (S_IRWXG | S_IRWXO)))
            fprintf(stderr, "corvid-node: warning: token file '%s' can be read by other users (chmod 600 it)\n",
                    o->token_file);
    }
    if (mo->token_file && cv_rpc_read_token_file(mo->token_file, metrics_token, metrics_cap) != CV_OK) {
        fprintf(stderr, "corvid-node: --metrics-token-file: %s\n", cv_last_error());
        return 2;
    }
    if (!cv_node_listen_is_local(o->listen)) {
        if (!o->token_file) {
            fprintf(stderr,
                    "corvid-node: --listen %s is not loopback: give a token with --token-file FILE (or "
                    "CORVID_NODE_TOKEN_FILE), a file whose first line is the token; clients set "
                    "CORVID_NODE_TOKEN_FILE to a file with the same token\n",
                    o->listen);
            return 2;
        }
        if (!o->tls_cert)
            fprintf(stderr,
                    "corvid-node: warning: --listen %s without --tls-cert: the token and all data travel "
                    "unencrypted\n",
                    o->listen);
    }
    return 0;
}

/* The node's configuration from the options (token: read by read_tokens; "" without --token-file). */
static cv_node_config node_config(const options *o, const cv_node_device_spec *devices, uint32_t device_count,
                                  const char *cache_dir, const char *token) {
    return (cv_node_config){
        .listen = o->listen,
        .name = o->name,
        .devices = devices,
        .device_count = device_count,
        .validation = o->validation,
        .cache_dir = o->cache_dir ? o->cache_dir : cache_dir,
        .cache_bytes = o->cache_bytes,
        .idle_timeout_ms = o->idle_timeout_s * 1000u,
        .submit_timeout_ms = o->submit_timeout_s * 1000u,
        .max_sessions = o->max_sessions,
        .log_sessions = !o->quiet,
        .token = o->token_file ? token : NULL,
        .tls_cert_file = o->tls_cert,
        .tls_key_file = o->tls_key,
        .tls_client_ca_file = o->tls_client_ca,
        .quota = o->quota,
        .memory_bytes = o->memory_limit,
        .peer_token = o->token_file ? token : NULL,
        .peer_tls_ca_file = o->peer_tls_ca,
        .peer_deadline_ms = o->peer_deadline_ms,
        .peer_keepalive_ms = o->peer_keepalive_ms,
        .peers = o->peers,
        .health_listen = o->health_listen,
    };
}

/* --port-file, then the lines that say where the node listens: 0, or 1 after a message. */
static int announce(cv_node *node, const options *o, const cv_node_config *config, const node_metrics_options *mo,
                    cv_metrics_server *metrics) {
    int port = cv_node_port(node);
    if (o->port_file) {
        FILE *f = NULL;
        cv_result pr = cv_file_fopen_regular(o->port_file, "w", &f);
        if (pr == CV_OK) {
            bool written = fprintf(f, "%d\n", port) >= 0;
            if (fclose(f) != 0 || !written)
                pr = cv_error(CV_ERROR_IO, "%s: %s", o->port_file, strerror(errno));
        }
        if (pr != CV_OK) {
            fprintf(stderr, "corvid-node: --port-file: %s\n", cv_last_error());
            return 1;
        }
    }
    /* A unix socket has no port (gRPC reports 1 for it): the address is the path. */
    char where[PATH_MAX + 16];
    const char *colon = strrchr(o->listen, ':');
    if (!strncmp(o->listen, "unix:", 5) || !strncmp(o->listen, "unix-abstract:", 14))
        snprintf(where, sizeof(where), "%s", o->listen);
    else
        snprintf(where, sizeof(where), "%.*s:%d", (int)(colon - o->listen), o->listen, port);
    printf("corvid-node: listening on %s with %u device%s (%s), cache %s, %s, %s\n", where, config->device_count,
           config->device_count == 1 ? "" : "s", o->backend, config->cache_dir,
           o->tls_client_ca ? "mutual TLS"
           : o->tls_cert    ? "TLS"
                            : "plaintext",
           o->token_file ? "token required" : "no token");
    if (metrics)
        printf("corvid-node: metrics at http://%s:%d/metrics%s\n", mo->listen ? mo->listen : "127.0.0.1",
               cv_metrics_server_port(metrics), mo->token_file ? " (bearer token required)" : "");
    if (o->health_listen)
        printf("corvid-node: plaintext health (grpc.health.v1 only) on port %d\n", cv_node_health_port(node));
    fflush(stdout);
    return 0;
}

int main(int argc, char **argv) {
    cv_log_set_sink(log_to_stderr, NULL, env_log_level());
    cv_vulkan_gpu_config gpus = { 0 };
    if (cv_env_vulkan_gpu_args(&argc, argv, &gpus) != CV_OK || cv_env_vulkan_gpu_config(&gpus) != CV_OK) {
        fprintf(stderr, "corvid-node: %s (see --help)\n", cv_last_error());
        return 2;
    }
    node_metrics_options metrics_opts;
    if (node_metrics_args(&argc, argv, &metrics_opts) != 0)
        return 2;
    options o;
    int parsed = parse_args(argc, argv, &o);
    if (parsed)
        return parsed == 1 ? 0 : 2;
    if (cv_env_client_configure(CV_ENV_CLIENT_TRANSFER) != CV_OK) {
        fprintf(stderr, "corvid-node: %s\n", cv_last_error());
        return 2;
    }
    /* The tokens: read before anything starts, so a bad file is a clear error at once. */
    static char token[1040], metrics_token[1040];
    if (read_tokens(&o, &metrics_opts, token, sizeof(token), metrics_token, sizeof(metrics_token)) != 0)
        return 2;
    char cache_dir[PATH_MAX];
    if (!o.cache_dir && default_cache_dir(cache_dir, sizeof(cache_dir)) != 0) {
        fprintf(stderr, "corvid-node: no cache directory: give --cache-dir\n");
        return 2;
    }
    cv_node_device_spec devices[CV_MAX_DEVICES];
    uint32_t device_count = 0;
    cv_result r = make_devices(&o, &gpus, devices, &device_count);
    if (r != CV_OK) {
        fprintf(stderr, "corvid-node: %s\n", cv_last_error());
        return 1;
    }

    /* Signals are taken by sigwait below, so every thread (gRPC's too) blocks them. */
    sigset_t signals;
    sigemptyset(&signals);
    sigaddset(&signals, SIGTERM);
    sigaddset(&signals, SIGINT);
    pthread_sigmask(SIG_BLOCK, &signals, NULL);
    signal(SIGPIPE, SIG_IGN);

    cv_node_config config = node_config(&o, devices, device_count, cache_dir, token);
    cv_node *node;
    r = cv_node_start(&config, &node);
    memset(token, 0, sizeof(token)); /* the node keeps its hash, and a copy to present to peer nodes */
    if (r != CV_OK) {
        fprintf(stderr, "corvid-node: %s\n", cv_last_error());
        return 1;
    }
    cv_metrics_server *metrics = NULL;
    if (metrics_opts.enabled &&
        start_metrics(node, &metrics_opts, metrics_token, sizeof(metrics_token), &metrics) != 0) {
        cv_node_stop(node, 0);
        return 1;
    }
    if (announce(node, &o, &config, &metrics_opts, metrics) != 0) {
        cv_metrics_server_stop(metrics);
        cv_node_stop(node, 0);
        return 1;
    }

    int sig = 0;
    sigwait(&signals, &sig);
    fprintf(stderr, "corvid-node: %s: draining (new sessions refused, %u s for running ones)\n",
            sig == SIGTERM ? "SIGTERM" : "SIGINT", o.drain_timeout_s);
    cv_node_drain(node);
    /* Metrics stay up while the running sessions finish, so a scrape during the drain shows it
     * (corvid_node_draining 1, the sessions going down); then they go, before the node (they read it). */
    if (cv_node_wait_sessions(node, o.drain_timeout_s * 1000u) > 0) {
        char reason[64];
        snprintf(reason, sizeof(reason), "drain timeout (%u s) expired", o.drain_timeout_s);
        cv_node_cancel_sessions(node, reason);
    }
    cv_node_stats stats = cv_node_get_stats(node);
    cv_metrics_server_stop(metrics);
    cv_node_stop(node, 0);
    fprintf(stderr,
            "corvid-node: stopped after %" PRIu64 " sessions, %" PRIu64 " submissions, %" PRIu64 " bytes in, %" PRIu64
            " bytes out\n",
            stats.sessions_started, stats.submissions, stats.bytes_in, stats.bytes_out);
    return 0;
}
