/* The routes of /api/v1: each request's path and method to the scene store,
 * the jobs or the node health, and their answers to HTTP (docs/openapi.yaml
 * lists them; tests/gateway checks the two agree). */
#ifndef CORVID_GATEWAY_ROUTES_H
#define CORVID_GATEWAY_ROUTES_H

#include "corvid/web_server.h"
#include "jobs.h"
#include "node_health.h"
#include "scene_store.h"

typedef struct gw_routes {
    gw_store *store;
    gw_jobs *jobs;
    gw_health *health;
    uint64_t max_scene_bytes, max_pixels;
    uint32_t workers, max_queued;
} gw_routes;

/* Answers a request under /api/ (any other path: resp->status stays 0). */
void gw_route(const gw_routes *routes, const cv_http_request *req, cv_http_response *resp);

#endif
