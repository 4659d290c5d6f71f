/* The REST gateway: its parts put together and the routes of /api/v1
 * (corvid/gateway.h). */
#include "corvid/gateway.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "routes.h"

struct cv_gateway {
    cv_gateway_desc desc; /* defaults filled in; the strings below */
    char temp_dir[512];
    gw_store *store;
    gw_jobs *jobs;
    gw_health *health;
    gw_routes routes;
};

static cv_result check_desc(const cv_gateway_desc *d) {
    if (!d || !d->open_devices)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "gateway: desc.open_devices is required");
    if (d->workers > 64)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "gateway: desc.workers %u is outside 1..64", d->workers);
    if (d->max_queued > 4096)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "gateway: desc.max_queued %u is outside 1..4096", d->max_queued);
    if (d->max_jobs > 65536)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "gateway: desc.max_jobs %u is outside 1..65536", d->max_jobs);
    if (d->health_interval_ms > 3600000)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "gateway: desc.health_interval_ms %u is outside 1..3600000",
                        d->health_interval_ms);
    if (d->temp_dir && strlen(d->temp_dir) > 400)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "gateway: desc.temp_dir is longer than 400 bytes");
    if (d->max_store_bytes && d->max_scene_bytes > d->max_store_bytes)
        return cv_error(CV_ERROR_INVALID_ARGUMENT,
                        "gateway: desc.max_scene_bytes %llu is over desc.max_store_bytes %llu",
                        (unsigned long long)d->max_scene_bytes, (unsigned long long)d->max_store_bytes);
    return CV_OK;
}

cv_result cv_gateway_create(const cv_gateway_desc *desc, cv_gateway **out) {
    cv_result r = check_desc(desc);
    if (r != CV_OK)
        return r;
    cv_gateway *g = calloc(1, sizeof(*g));
    if (!g)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "gateway");
    g->desc = *desc;
    cv_gateway_desc *d = &g->desc;
    d->health_interval_ms = d->health_interval_ms ? d->health_interval_ms : 5000;
    d->max_scene_bytes = d->max_scene_bytes ? d->max_scene_bytes : 256ull << 20;
    d->max_store_bytes = d->max_store_bytes ? d->max_store_bytes : 1ull << 30;
    if (d->max_scene_bytes > d->max_store_bytes)
        d->max_store_bytes = d->max_scene_bytes;
    d->workers = d->workers ? d->workers : 2;
    d->max_queued = d->max_queued ? d->max_queued : 16;
    d->max_jobs = d->max_jobs ? d->max_jobs : 64;
    d->max_pixels = d->max_pixels ? d->max_pixels : 3840ull * 2160;
    snprintf(g->temp_dir, sizeof(g->temp_dir), "%s", d->temp_dir ? d->temp_dir : "/tmp");
    d->temp_dir = g->temp_dir;
    d->nodes = NULL; /* the health thread keeps its own copy */
    r = gw_store_create(d->max_scene_bytes, d->max_store_bytes, g->temp_dir, &g->store);
    if (r == CV_OK)
        r = gw_health_create(desc->nodes, d->health_interval_ms, d->open_devices, d->user, &g->health);
    if (r == CV_OK)
        r = gw_jobs_create(&(gw_jobs_config){ .open_devices = d->open_devices,
                                              .user = d->user,
                                              .workers = d->workers,
                                              .max_queued = d->max_queued,
                                              .max_jobs = d->max_jobs,
                                              .temp_dir = g->temp_dir,
                                              .store = g->store,
                                              .log = d->log,
                                              .log_user = d->log_user },
                           &g->jobs);
    if (r != CV_OK) {
        cv_gateway_destroy(g);
        return r;
    }
    g->routes = (gw_routes){ .store = g->store,
                             .jobs = g->jobs,
                             .health = g->health,
                             .max_scene_bytes = d->max_scene_bytes,
                             .max_pixels = d->max_pixels,
                             .workers = d->workers,
                             .max_queued = d->max_queued };
    *out = g;
    return CV_OK;
}

void cv_gateway_destroy(cv_gateway *g) {
    if (!g)
        return;
    gw_jobs_destroy(g->jobs);
    gw_health_destroy(g->health);
    gw_store_destroy(g->store);
    free(g);
}

cv_result cv_gateway_wait_job(cv_gateway *g, uint64_t id, uint32_t frames, uint32_t timeout_ms) {
    return gw_jobs_wait(g->jobs, id, frames, timeout_ms);
}

void cv_gateway_handle(void *gateway, const cv_http_request *req, cv_http_response *resp) {
    gw_route(&((cv_gateway *)gateway)->routes, req, resp);
}
