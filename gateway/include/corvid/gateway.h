/* The REST gateway (seed 004): a versioned HTTP/JSON API through which
 * browsers and scripts give the render proxy work and fetch the results.
 *
 * The gateway is a cv_http_handler (corvid/web_server.h): the web server
 * (or a test) hands it each request under /api/, it answers at once and
 * renders on worker threads of its own. docs/openapi.yaml describes every
 * endpoint; in short, under /api/v1:
 *
 *   GET    /api/v1                        {"version": 1, ...}
 *   GET    /api/v1/nodes                  the devices jobs render on, with their health
 *   PUT    /api/v1/scenes/{sha256}        a glTF/GLB whose SHA-256 is the path's: parsed, stored
 *   POST   /api/v1/scenes                 the same, the hash computed here: 201 {"scene": sha256}
 *   HEAD   /api/v1/scenes/{sha256}        200 if stored (a known model is not sent again), else 404
 *   GET    /api/v1/scenes/{sha256}        its figures
 *   POST   /api/v1/jobs                   {"scene", "width", "height", "frames", "camera", "settings"}:
 *                                         checked whole, then queued: 201 {"id": N}
 *   GET    /api/v1/jobs                   every job kept
 *   GET    /api/v1/jobs/{id}              state (queued/running/done/failed/cancelled), frames done, error
 *   GET    /api/v1/jobs/{id}/image.png    the tone-mapped image (409 until done)
 *   GET    /api/v1/jobs/{id}/image.exr    the HDR planes (409 until done)
 *   DELETE /api/v1/jobs/{id}              cancels a queued or running job (409 once it has ended)
 *
 * Refusals are 4xx with {"error": "..."} naming the field ("settings.ao-samples:
 * '40' is not a whole number in 1..32"); a refused request changes nothing.
 * Security (bearer token, loopback, TLS) is the web server's.
 *
 * Each job renders on devices of its own, which the program's open_devices
 * opens on the job's worker thread (local virtual GPUs, or proxy devices of
 * corvid-nodes) and the gateway destroys when the job ends; a device that
 * fails (a node that died) fails the job with its error.
 *
 *     static cv_result open_gpus(void *user, cv_gateway_devices *out) {
 *         ... cv_context_create(NULL, &out->ctx); cv_device_create(out->ctx, ..., &out->devices[0]); ...
 *     }
 *     cv_gateway *gw;
 *     if (cv_gateway_create(&(cv_gateway_desc){ .open_devices = open_gpus }, &gw) != CV_OK)
 *         fprintf(stderr, "%s\n", cv_last_error());
 *     // web server desc: .handler = cv_gateway_handle, .handler_user = gw
 *     ...
 *     cv_gateway_destroy(gw); // cancels the jobs, joins the workers
 */
#ifndef CORVID_GATEWAY_H
#define CORVID_GATEWAY_H

#include <stdint.h>

#include "corvid/gateway_types.h"
#include "corvid/log.h"
#include "corvid/result.h"
#include "corvid/web_server.h"

typedef struct cv_gateway cv_gateway;

typedef struct cv_gateway_desc {
    /* Opens the devices of one job into *out (called on the job's worker thread, so it may take time); on
     * failure it leaves nothing open, and the job fails with its error. Required. */
    cv_gateway_open_devices_fn open_devices;
    void *user;
    /* Where the devices are, for GET /api/v1/nodes: a node list ("host:port,...", corvid/endpoint.h), each
     * node polled with cv_proxy_query_node every health_interval_ms (0 = 5000) on a thread of the gateway's;
     * NULL or "" = local devices, opened once through open_devices at create to list them. */
    const char *nodes;
    uint32_t health_interval_ms;
    uint64_t max_scene_bytes; /* one uploaded model; 0 = 256 MiB; more is 413 */
    uint64_t max_store_bytes; /* all stored models' uploads; 0 = 1 GiB (unused models are dropped first) */
    uint32_t workers;         /* jobs rendering at once, 1..64; 0 = 2 */
    uint32_t max_queued;      /* jobs waiting for a worker; 0 = 16; more is 429 */
    uint32_t max_jobs;        /* jobs kept (the oldest ended ones are dropped); 0 = 64 */
    uint64_t max_pixels;      /* width * height of a job; 0 = 3840 * 2160 */
    const char *temp_dir;     /* private temporary files (model parsing, EXR/PNG writing); NULL = "/tmp" */
    /* Where the gateway's messages go (job started, ended, failed); NULL = cv_log, origin "gateway". */
    cv_log_fn log;
    void *log_user;
} cv_gateway_desc;

/* Checks the desc (a field out of range is CV_ERROR_INVALID_ARGUMENT naming it), starts the workers and the
 * health thread. */
cv_result cv_gateway_create(const cv_gateway_desc *desc, cv_gateway **out);

/* Cancels every job (queued ones end cancelled at once, running ones between frames), joins the threads and
 * frees everything. NULL is allowed. Requests must have stopped (the server stopped first). */
void cv_gateway_destroy(cv_gateway *g);

/* The cv_http_handler: answers one request under /api/ (anything else is left unhandled: status 0). Thread-safe;
 * never waits for a render. */
void cv_gateway_handle(void *gateway, const cv_http_request *req, cv_http_response *resp);

/* Waits until job `id` has ended (done, failed or cancelled) or has rendered at least `frames` frames, at most
 * timeout_ms: CV_OK, CV_ERROR_TIMEOUT, or CV_ERROR_NOT_FOUND for no such job. For programs that drive jobs
 * in-process and for tests (no polling). */
cv_result cv_gateway_wait_job(cv_gateway *g, uint64_t id, uint32_t frames, uint32_t timeout_ms);

#endif
