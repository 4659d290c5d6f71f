/* corvid-gateway: the REST gateway (seed 004) as a program. Serves the
 * versioned HTTP/JSON API of corvid/gateway.h (docs/openapi.yaml) with the web
 * server of corvid/web_server.h: browsers and scripts upload models, start
 * render jobs, follow them and fetch their PNG/EXR. Jobs render on local
 * devices (virtual GPUs of the adapters, --gpus) or on corvid-nodes
 * (--nodes), each job on devices of its own. Loopback by default; another
 * address needs --token-file (every request then carries `Authorization:
 * Bearer <token>`); TLS with --tls-cert and --tls-key. SIGINT or SIGTERM
 * stops it: the server first, then the jobs are cancelled. */
#include <errno.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "corvid/endpoint.h"
#include "corvid/gateway.h"
#include "corvid/parse.h"
#include "corvid/web_server.h"
#include "env_client.h"
#include "env_log.h"
#include "env_vulkan.h"
#include "job_devices.h"

typedef struct gateway_options {
    const char *host; /* NULL = 127.0.0.1 */
    uint32_t port;
    const char *token_file, *tls_cert, *tls_key;
    const char *nodes; /* NULL = local devices */
    uint64_t max_scene_bytes;
    uint32_t jobs;
    bool validation, help;
} gateway_options;

static void usage(FILE *f) {
    fprintf(f,
            "usage: corvid-gateway [options]\n"
            "Serves the REST API of docs/openapi.yaml under http://HOST:PORT/api/v1: upload glTF/GLB models, start\n"
            "render jobs, follow them, fetch their PNG/EXR, cancel them.\n\n"
            "  --port N              port (0..65535; default 7790; 0 = any free one, printed)\n"
            "  --host H              address to listen on (default 127.0.0.1; another needs --token-file)\n"
            "  --token-file F        its first line is the bearer token every request must carry\n"
            "  --tls-cert C --tls-key K  serve HTTPS with this PEM certificate and key\n"
            "  --gpus N              jobs render on N local devices (virtual GPUs added to reach N; default 1)\n"
            "  --virtual-gpus N      device instances per adapter (or CORVID_VIRTUAL_GPUS=N)\n"
            "  --adapters LIST       comma-separated adapter names or indices (e.g. llvmpipe, 0)\n"
            "  --nodes H:P,...       jobs render on these corvid-nodes' devices instead (or CORVID_NODES; token\n"
            "                        and TLS toward them from CORVID_NODE_*)\n"
            "  --max-scene-bytes N   largest model accepted (default 268435456; 413 above)\n"
            "  --jobs N              jobs rendering at once (1..64; default 2)\n"
            "  --validation          the Vulkan validation layer on local devices\n"
            "  --help                this text\n");
}

static int refuse(const char *name, const char *value, const char *expected) {
    fprintf(stderr, "corvid-gateway: %s: '%s' is not %s (see --help)\n", name, value, expected);
    return 2;
}

/* One option with its value (value NULL for a flag): 0, or 2 after a message. */
static int take_option(gateway_options *o, const char *name, const char *value) {
    uint64_t n;
    if (!strcmp(name, "--port")) {
        if (!cv_parse_uint(value, 0, 65535, &n))
            return refuse(name, value, "a port in 0..65535");
        o->port = (uint32_t)n;
    } else if (!strcmp(name, "--max-scene-bytes")) {
        if (!cv_parse_uint(value, 1, UINT64_MAX / 2, &o->max_scene_bytes))
            return refuse(name, value, "a number of bytes, at least 1");
    } else if (!strcmp(name, "--jobs")) {
        if (!cv_parse_uint(value, 1, 64, &n))
            return refuse(name, value, "a whole number in 1..64");
        o->jobs = (uint32_t)n;
    } else if (!strcmp(name, "--nodes")) {
        cv_endpoint nodes[CV_MAX_NODES];
        uint32_t count;
        if (cv_endpoints_parse(value, name, nodes, CV_MAX_NODES, &count) != CV_OK) {
            fprintf(stderr, "corvid-gateway: %s (see --help)\n", cv_last_error());
            return 2;
        }
        o->nodes = value;
    } else if (!value[0]) {
        return refuse(name, value, "a value");
    } else if (!strcmp(name, "--host")) {
        o->host = value;
    } else if (!strcmp(name, "--token-file")) {
        o->token_file = value;
    } else if (!strcmp(name, "--tls-cert")) {
        o->tls_cert = value;
    } else {
        o->tls_key = value;
    }
    return 0;
}

static int parse_args(int argc, char **argv, gateway_options *o) {
    static const char *const valued[] = { "--port",    "--host",  "--token-file",      "--tls-cert",
                                          "--tls-key", "--nodes", "--max-scene-bytes", "--jobs" };
    for (int i = 1; i < argc; i++) {
        const char *arg = argv[i], *eq = strchr(arg, '=');
        size_t len = eq ? (size_t)(eq - arg) : strlen(arg);
        char name[64];
        snprintf(name, sizeof(name), "%.*s", (int)len, arg);
        if (!strcmp(name, "--help") || !strcmp(name, "--validation")) {
            *(!strcmp(name, "--help") ? &o->help : &o->validation) = true;
            continue;
        }
        bool known = false;
        for (size_t k = 0; k < sizeof(valued) / sizeof(valued[0]); k++)
            known = known || !strcmp(name, valued[k]);
        if (!known) {
            fprintf(stderr, "corvid-gateway: unknown option '%s' (see --help)\n", arg);
            return 2;
        }
        const char *value = eq ? eq + 1 : (i + 1 < argc ? argv[++i] : NULL);
        if (!value) {
            fprintf(stderr, "corvid-gateway: %s needs a value (see --help)\n", name);
            return 2;
        }
        int code = take_option(o, name, value);
        if (code)
            return code;
    }
    if (!o->tls_cert != !o->tls_key) {
        fprintf(stderr, "corvid-gateway: --tls-cert and --tls-key go together (see --help)\n");
        return 2;
    }
    return 0;
}

/* The first line of --token-file: 0, or 1 after a message. */
static int read_token(const char *file, char *token, size_t size) {
    FILE *f = fopen(file, "r");
    if (!f || !fgets(token, (int)size, f)) {
        fprintf(stderr, "corvid-gateway: --token-file %s: %s\n", file, f ? "empty" : strerror(errno));
        if (f)
            fclose(f);
        return 1;
    }
    fclose(f);
    token[strcspn(token, "\r\n")] = 0;
    if (!token[0]) {
        fprintf(stderr, "corvid-gateway: --token-file %s: the first line is empty\n", file);
        return 1;
    }
    return 0;
}

static int serve(const gateway_options *o, job_devices *devices, const char *token, const sigset_t *stop) {
    cv_gateway *gateway = NULL;
    cv_web_server *server = NULL;
    cv_result r = cv_gateway_create(&(cv_gateway_desc){ .open_devices = job_devices_open,
                                                        .user = devices,
                                                        .nodes = o->nodes,
                                                        .max_scene_bytes = o->max_scene_bytes,
                                                        .workers = o->jobs },
                                    &gateway);
    size_t max_body = o->max_scene_bytes ? (size_t)o->max_scene_bytes : (size_t)256 << 20;
    if (r == CV_OK)
        r = cv_web_server_start(&(cv_web_desc){ .host = o->host,
                                                .port = (uint16_t)o->port,
                                                .token = token[0] ? token : NULL,
                                                .tls_cert = o->tls_cert,
                                                .tls_key = o->tls_key,
                                                .max_body_bytes = max_body + 1,
                                                .api = cv_gateway_handle,
                                                .api_user = gateway },
                                &server);
    if (r == CV_OK) {
        printf("corvid-gateway: serving http%s://%s:%u/api/v1\n", o->tls_cert ? "s" : "",
               o->host ? o->host : "127.0.0.1", cv_web_server_port(server));
        fflush(stdout);
        int sig = 0;
        while (sig != SIGINT && sig != SIGTERM)
            sigwait(stop, &sig);
        fprintf(stderr, "corvid-gateway: stopping (the jobs still running are cancelled)\n");
    } else {
        fprintf(stderr, "corvid-gateway: %s\n", cv_last_error());
    }
    cv_web_server_stop(server); /* first: no request reaches the gateway any more */
    cv_gateway_destroy(gateway);
    return r == CV_OK ? 0 : 1;
}

int main(int argc, char **argv) {
    /* Before any thread starts, so that every thread inherits the mask and only serve() takes the signals. */
    sigset_t stop;
    sigemptyset(&stop);
    sigaddset(&stop, SIGINT);
    sigaddset(&stop, SIGTERM);
    pthread_sigmask(SIG_BLOCK, &stop, NULL);
    signal(SIGPIPE, SIG_IGN); /* a client that goes away is a closed connection, not a crash */
    gateway_options o = { .port = 7790 };
    job_devices devices = { 0 };
    if (cv_env_vulkan_gpu_args(&argc, argv, &devices.gpu_config) != CV_OK) {
        fprintf(stderr, "corvid-gateway: %s (see --help)\n", cv_last_error());
        return 2;
    }
    int code = parse_args(argc, argv, &o);
    if (code)
        return code;
    if (o.help) {
        usage(stdout);
        return 0;
    }
    bool local_choice = devices.gpu_config.total || devices.gpu_config.virtual_per_adapter ||
                        devices.gpu_config.adapters;
    const char *env_nodes = getenv("CORVID_NODES"); /* as corvid-render's and corvid-view's --nodes */
    cv_endpoint nodes[CV_MAX_NODES];
    uint32_t node_count;
    if (!o.nodes && !local_choice && env_nodes && env_nodes[0]) {
        if (cv_endpoints_parse(env_nodes, "CORVID_NODES", nodes, CV_MAX_NODES, &node_count) != CV_OK) {
            fprintf(stderr, "corvid-gateway: %s\n", cv_last_error());
            return 2;
        }
        o.nodes = env_nodes;
    }
    if (o.nodes && local_choice) {
        fprintf(stderr,
                "corvid-gateway: --nodes renders on the nodes' devices; --gpus, --virtual-gpus and --adapters "
                "choose local ones: give one or the other\n");
        return 2;
    }
    char token[1040] = "";
    if (o.token_file && read_token(o.token_file, token, sizeof(token)))
        return 1;
    env_log_apply();
    cv_result r = cv_env_client_configure(CV_ENV_CLIENT_ALL);
    if (r == CV_OK)
        r = job_devices_configure(&devices, o.nodes, o.validation);
    if (r != CV_OK) {
        fprintf(stderr, "corvid-gateway: %s\n", cv_last_error());
        return 1;
    }
    return serve(&o, &devices, token, &stop);
}
