/* A corvid-node started inside a test process, on a free loopback port, with
 * its content cache in a fresh temporary directory that stopping removes. */
#ifndef CORVID_TEST_SCRATCH_NODE_H
#define CORVID_TEST_SCRATCH_NODE_H

#include "node.h"

typedef struct scratch_node {
    cv_node *node;
    char endpoint[64]; /* "127.0.0.1:<port>" */
    char cache_dir[256];
    cv_node_config config;
    cv_node_device_spec devices[8];
} scratch_node;

/* `count` devices of `backend` (Vulkan: the lavapipe adapter, or
 * CORVID_TEST_ADAPTER). idle_timeout_ms 0 = the node's default. */
cv_result scratch_node_start_with(scratch_node *n, const cv_backend *backend, uint32_t count, bool validation,
                                  uint32_t idle_timeout_ms, const char *cache_dir);
cv_result scratch_node_start(scratch_node *n, const cv_backend *backend, uint32_t count, bool validation);
/* As scratch_node_start (no validation), with the security fields of `security` (token, TLS files, quota,
 * memory_bytes, log_sessions, log_sink) and its listen address if set (then `endpoint` names 127.0.0.1 with the
 * bound port). */
cv_result scratch_node_start_secured(scratch_node *n, const cv_backend *backend, uint32_t count,
                                     const cv_node_config *security);
/* Waits up to timeout_ms for the node's sessions to end; returns how many are left. */
uint64_t scratch_node_wait_sessions(scratch_node *n, uint32_t timeout_ms);
/* Stops the node; removes the cache directory unless `keep_cache`. */
void scratch_node_stop_keep(scratch_node *n, bool keep_cache);
void scratch_node_stop(scratch_node *n);

/* A corvid-node in its own process (so a test can SIGKILL it), serving `gpus` devices of the test adapter on
 * 127.0.0.1:`port` (0 picks a free one; give the old port to restart a node where it was), its cache and log
 * in a fresh temporary directory. extra: more options for corvid-node, NULL-terminated (may be NULL). Waits
 * until it listens (its --port-file). */
typedef struct scratch_process_node {
    int pid; /* 0: not running */
    int port;
    char endpoint[64];
    char dir[256];
} scratch_process_node;

cv_result scratch_process_node_start(scratch_process_node *n, const char *binary, uint32_t gpus, int port,
                                     const char *const *extra);
/* SIGKILL, and reaps it; the directory stays (for a restart). */
void scratch_process_node_kill(scratch_process_node *n);
/* SIGTERM (it drains), reaps it, removes the directory. */
void scratch_process_node_stop(scratch_process_node *n);

#endif
