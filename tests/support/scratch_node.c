/* In-process corvid-node for tests (scratch_node.h). */
#include "scratch_node.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "corvid/backend.h"

static cv_result start(scratch_node *n, const cv_backend *backend, uint32_t count, bool validation,
                       uint32_t idle_timeout_ms, const char *cache_dir, const cv_node_config *security) {
    memset(n, 0, sizeof(*n));
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
        n->config.log_sessions |= security->log_sessions;
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
