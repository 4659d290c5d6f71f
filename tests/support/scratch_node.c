/* In-process corvid-node for tests (scratch_node.h). */
#include "scratch_node.h"

#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "check.h"
#include "corvid/backend.h"
#include "corvid/rpc.h"

static cv_result start(scratch_node *n, const cv_backend *backend, uint32_t count, bool validation,
                       uint32_t idle_timeout_ms, const char *cache_dir, const cv_node_config *security) {
    memset(n, 0, sizeof(*n));
    /* Whoever starts a node ends with it stopped, and with the clients of its proxy devices gone. */
    check_live_counter("nodes", cv_live_nodes);
    check_live_counter("rpc servers", cv_rpc_live_servers);
    check_live_counter("rpc clients", cv_rpc_live_clients);
    if (count == 0 || count > 8)
        return cv_error(CV_ERROR_OUT_OF_RANGE, "scratch node: %u devices (1..8)", count);
    if (cache_dir) {
        snprintf(n->cache_dir, sizeof(n->cache_dir), "%s", cache_dir);
    } else {
        snprintf(n->cache_dir, sizeof(n->cache_dir), "/tmp/corvid-node-test-XXXXXX");
        if (!mkdtemp(n->cache_dir))
            return cv_error(CV_ERROR_IO, "scratch node: cannot make a cache directory");
    }
    const char *adapter = getenv("CORVID_TEST_ADAPTER");
    for (uint32_t i = 0; i < count; i++) {
        n->devices[i].backend = backend;
        snprintf(n->devices[i].adapter, sizeof(n->devices[i].adapter), "%s",
                 strcmp(backend->name, "vulkan") == 0 ? (adapter && *adapter ? adapter : "llvmpipe") : "");
        snprintf(n->devices[i].label, sizeof(n->devices[i].label), "%s%u", backend->name, i);
    }
    n->config = (cv_node_config){ .listen = "127.0.0.1:0",
                                  .name = "scratch",
                                  .devices = n->devices,
                                  .device_count = count,
                                  .validation = validation,
                                  .cache_dir = n->cache_dir,
                                  .cache_bytes = 256ull << 20,
                                  .idle_timeout_ms = idle_timeout_ms,
                                  .log_sessions = getenv("CORVID_NODE_LOG") != NULL };
    if (security) {
        if (security->listen)
            n->config.listen = security->listen;
        n->config.token = security->token;
        n->config.tls_cert_file = security->tls_cert_file;
        n->config.tls_key_file = security->tls_key_file;
        n->config.tls_client_ca_file = security->tls_client_ca_file;
        n->config.quota = security->quota;
        n->config.memory_bytes = security->memory_bytes;
        n->config.log_sessions |= security->log_sessions;
        n->config.log_sink = security->log_sink;
        n->config.log_user = security->log_user;
        n->config.peer_token = security->peer_token;
        n->config.peer_deadline_ms = security->peer_deadline_ms;
        n->config.peer_keepalive_ms = security->peer_keepalive_ms;
        n->config.health_listen = security->health_listen;
        n->config.peers = security->peers;
    }
    cv_result r = cv_node_start(&n->config, &n->node);
    if (r != CV_OK) {
        char why[1024];
        snprintf(why, sizeof(why), "%s", cv_last_error());
        if (!cache_dir) {
            char cmd[300];
            snprintf(cmd, sizeof(cmd), "rm -rf '%s'", n->cache_dir);
            if (system(cmd) != 0)
                fprintf(stderr, "scratch node: could not remove %s\n", n->cache_dir);
        }
        return cv_error(r, "%s", why);
    }
    snprintf(n->endpoint, sizeof(n->endpoint), "127.0.0.1:%d", cv_node_port(n->node));
    return CV_OK;
}

cv_result scratch_node_start_with(scratch_node *n, const cv_backend *backend, uint32_t count, bool validation,
                                  uint32_t idle_timeout_ms, const char *cache_dir) {
    return start(n, backend, count, validation, idle_timeout_ms, cache_dir, NULL);
}

cv_result scratch_node_start_secured(scratch_node *n, const cv_backend *backend, uint32_t count,
                                     const cv_node_config *security) {
    return start(n, backend, count, false, 0, NULL, security);
}

cv_result scratch_node_start(scratch_node *n, const cv_backend *backend, uint32_t count, bool validation) {
    return scratch_node_start_with(n, backend, count, validation, 0, NULL);
}

uint64_t scratch_node_wait_sessions(scratch_node *n, uint32_t timeout_ms) {
    for (uint32_t waited = 0;; waited += 10) {
        uint64_t active = cv_node_get_stats(n->node).sessions_active;
        if (active == 0 || waited >= timeout_ms)
            return active;
        nanosleep(&(struct timespec){ 0, 10 * 1000 * 1000 }, NULL);
    }
}

void scratch_node_stop_keep(scratch_node *n, bool keep_cache) {
    if (!n->node)
        return;
    cv_node_stop(n->node, 5000);
    n->node = NULL;
    if (!keep_cache) {
        char cmd[300];
        snprintf(cmd, sizeof(cmd), "rm -rf '%s'", n->cache_dir);
        if (system(cmd) != 0)
            fprintf(stderr, "scratch node: could not remove %s\n", n->cache_dir);
    }
}

void scratch_node_stop(scratch_node *n) { scratch_node_stop_keep(n, false); }

/* ---- process nodes ---------------------------------------------------------------- */

cv_result scratch_process_node_start(scratch_process_node *n, const char *binary, uint32_t gpus, int port,
                                     const char *const *extra) {
    if (!n->dir[0]) {
        snprintf(n->dir, sizeof(n->dir), "/tmp/corvid-pnode-XXXXXX");
        if (!mkdtemp(n->dir))
            return cv_error(CV_ERROR_IO, "scratch process node: cannot make a directory");
    }
    n->pid = 0;
    char listen[64], port_file[300], cache[300], log[300], count[16];
    snprintf(listen, sizeof(listen), "127.0.0.1:%d", port);
    snprintf(port_file, sizeof(port_file), "%s/port", n->dir);
    snprintf(cache, sizeof(cache), "%s/cache", n->dir);
    snprintf(log, sizeof(log), "%s/log", n->dir);
    snprintf(count, sizeof(count), "%u", gpus);
    unlink(port_file);
    const char *adapter = getenv("CORVID_TEST_ADAPTER");
    const char *argv[48] = { binary,        "--listen",   listen,
                             "--port-file", port_file,    "--cache-dir",
                             cache,         "--adapters", adapter && *adapter ? adapter : "llvmpipe",
                             "--gpus",      count };
    uint32_t argc = 11;
    for (uint32_t i = 0; extra && extra[i] && argc < 46; i++)
        argv[argc++] = extra[i];
    argv[argc] = NULL;
    pid_t pid = fork();
    if (pid < 0)
        return cv_error(CV_ERROR_IO, "scratch process node: fork failed");
    if (pid == 0) {
        FILE *f = freopen(log, "a", stderr);
        (void)f;
        execv(binary, (char *const *)argv);
        _exit(127);
    }
    n->pid = (int)pid;
    for (int waited = 0; waited < 30000; waited += 20) {
        FILE *f = fopen(port_file, "r");
        int p = 0;
        char line[32] = "";
        if (f) { /* whole once it ends with a newline */
            if (fgets(line, sizeof(line), f) && strchr(line, '\n'))
                p = atoi(line);
            fclose(f);
        }
        if (p > 0) {
            n->port = p;
            snprintf(n->endpoint, sizeof(n->endpoint), "127.0.0.1:%d", p);
            return CV_OK;
        }
        int status;
        if (waitpid(pid, &status, WNOHANG) == pid) {
            n->pid = 0;
            return cv_error(CV_ERROR_IO, "scratch process node: %s exited (status %d) before listening; see %s",
                            binary, status, log);
        }
        nanosleep(&(struct timespec){ 0, 20 * 1000 * 1000 }, NULL);
    }
    scratch_process_node_kill(n);
    return cv_error(CV_ERROR_TIMEOUT, "scratch process node: %s did not listen within 30 s; see %s", binary, log);
}

void scratch_process_node_kill(scratch_process_node *n) {
    if (n->pid > 0) {
        kill((pid_t)n->pid, SIGKILL);
        waitpid((pid_t)n->pid, NULL, 0);
    }
    n->pid = 0;
}

void scratch_process_node_stop(scratch_process_node *n) {
    if (n->pid > 0) {
        kill((pid_t)n->pid, SIGTERM);
        waitpid((pid_t)n->pid, NULL, 0);
    }
    n->pid = 0;
    if (n->dir[0]) {
        char cmd[300];
        snprintf(cmd, sizeof(cmd), "rm -rf '%s'", n->dir);
        if (system(cmd) != 0)
            fprintf(stderr, "scratch process node: could not remove %s\n", n->dir);
        n->dir[0] = '\0';
    }
}
