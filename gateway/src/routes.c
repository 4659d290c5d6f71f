/* The routes of /api/v1 (routes.h): a table of method, path pattern and
 * handler; a {name} segment of a pattern matches any one segment of the path
 * and is handed to the handler. tests/gateway/openapi_routes_test.py reads the
 * table's rows ({ "GET", "/jobs/{id}", ... }) and checks docs/openapi.yaml
 * lists exactly these. */
#include "routes.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "corvid/gateway_types.h"
#include "corvid/parse.h"
#include "corvid/render_options.h"
#include "reply.h"

#define API "/api/v1"

/* A route's handler: `param` is the path's {segment}, "" when the pattern has none. */
typedef void (*route_fn)(const gw_routes *g, const cv_http_request *req, const char *param, cv_http_response *resp);

static void reply_result(cv_http_response *resp, cv_result r, cJSON *json) {
    if (r != CV_OK)
        gw_reply_error(resp, gw_status_of(r), "%s", cv_last_error());
    else
        gw_reply_json(resp, 200, json);
}

/* The settings a job takes ("settings": {...}): the options of the table, their ranges and defaults. */
static cJSON *settings_json(void) {
    cJSON *list = cJSON_CreateArray();
    for (uint32_t i = 0; list && i < CV_RENDER_SETTING_COUNT; i++) {
        const cv_render_setting *row = &cv_render_setting_rows[i];
        bool exposure = i == CV_RENDER_SETTING_exposure;
        if ((!row->option && !exposure) ||
            (row->option && cv_render_option_find(row->option, strlen(row->option)) != row))
            continue; /* not an option, or a later row of a compound option */
        const char *name = exposure && !row->option ? "exposure" : row->option + 2;
        if (strcmp(name, "size") == 0 || strcmp(name, "frames") == 0 || strcmp(name, "camera") == 0)
            continue; /* the job's own fields */
        char range[128];
        cv_render_setting_range(row, range, sizeof(range));
        cJSON *o = cJSON_CreateObject();
        if (!o || !cJSON_AddItemToArray(list, o) || !cJSON_AddStringToObject(o, "name", name) ||
            !cJSON_AddStringToObject(o, "value", row->metavar ? row->metavar : "X") ||
            !cJSON_AddStringToObject(o, "range", range) || !cJSON_AddNumberToObject(o, "default", row->def) ||
            !cJSON_AddStringToObject(o, "help", row->help)) {
            cJSON_Delete(o);
            cJSON_Delete(list);
            list = NULL;
        }
    }
    return list;
}

static void get_root(const gw_routes *g, const cv_http_request *req, const char *param, cv_http_response *resp) {
    (void)req;
    (void)param;
    cJSON *o = cJSON_CreateObject();
    cJSON *limits = o ? cJSON_AddObjectToObject(o, "limits") : NULL;
    bool ok = limits && cJSON_AddNumberToObject(o, "version", CV_GATEWAY_API_VERSION) &&
              cJSON_AddStringToObject(o, "api", API) &&
              cJSON_AddNumberToObject(limits, "max_scene_bytes", (double)g->max_scene_bytes) &&
              cJSON_AddNumberToObject(limits, "max_pixels", (double)g->max_pixels) &&
              cJSON_AddNumberToObject(limits, "workers", g->workers) &&
              cJSON_AddNumberToObject(limits, "max_queued", g->max_queued);
    cJSON *settings = ok ? settings_json() : NULL;
    if (!settings || !cJSON_AddItemToObject(o, "settings", settings)) {
        cJSON_Delete(settings);
        cJSON_Delete(o);
        o = NULL;
    }
    gw_reply_json(resp, 200, o);
}

static void get_nodes(const gw_routes *g, const cv_http_request *req, const char *param, cv_http_response *resp) {
    (void)req;
    (void)param;
    gw_reply_json(resp, 200, gw_health_describe(g->health));
}

/* PUT /scenes/{sha256} (expected set) and POST /scenes. */
static void store_scene(const gw_routes *g, const cv_http_request *req, const char *expected,
                        cv_http_response *resp) {
    char sha[CV_SHA256_HEX_SIZE];
    bool created = false;
    cv_result r = gw_store_put(g->store, req->body, req->body_size, expected, sha, &created);
    if (r != CV_OK) {
        gw_reply_error(resp, gw_status_of(r), "%s", cv_last_error());
        return;
    }
    cJSON *o = cJSON_CreateObject();
    if (o && (!cJSON_AddStringToObject(o, "scene", sha) || !cJSON_AddBoolToObject(o, "created", created))) {
        cJSON_Delete(o);
        o = NULL;
    }
    gw_reply_json(resp, created ? 201 : 200, o);
}

static void post_scene(const gw_routes *g, const cv_http_request *req, const char *param, cv_http_response *resp) {
    (void)param;
    store_scene(g, req, NULL, resp);
}

/* The path's hash in lowercase, or a 400 said. */
static bool scene_hash(const char *param, char sha[CV_SHA256_HEX_SIZE], cv_http_response *resp) {
    uint8_t digest[CV_SHA256_SIZE];
    if (!cv_sha256_parse_hex(param, digest)) {
        gw_reply_error(resp, 400, "path: '%s' is not a SHA-256 (64 hex digits)", param);
        return false;
    }
    cv_sha256_hex(digest, sha);
    return true;
}

static void put_scene(const gw_routes *g, const cv_http_request *req, const char *param, cv_http_response *resp) {
    char sha[CV_SHA256_HEX_SIZE];
    if (scene_hash(param, sha, resp))
        store_scene(g, req, sha, resp);
}

static void head_scene(const gw_routes *g, const cv_http_request *req, const char *param, cv_http_response *resp) {
    (void)req;
    char sha[CV_SHA256_HEX_SIZE];
    uint64_t bytes, triangles;
    if (!scene_hash(param, sha, resp))
        return;
    resp->status = gw_store_describe(g->store, sha, &bytes, &triangles) ? 200 : 404;
    snprintf(resp->content_type, sizeof(resp->content_type), "application/json");
}

static void get_scene(const gw_routes *g, const cv_http_request *req, const char *param, cv_http_response *resp) {
    (void)req;
    char sha[CV_SHA256_HEX_SIZE];
    uint64_t bytes = 0, triangles = 0;
    if (!scene_hash(param, sha, resp))
        return;
    if (!gw_store_describe(g->store, sha, &bytes, &triangles)) {
        gw_reply_error(resp, 404, "scene: no stored model has the SHA-256 %s (upload it first)", sha);
        return;
    }
    cJSON *o = cJSON_CreateObject();
    if (o && (!cJSON_AddStringToObject(o, "scene", sha) || !cJSON_AddNumberToObject(o, "bytes", (double)bytes) ||
              !cJSON_AddNumberToObject(o, "triangles", (double)triangles))) {
        cJSON_Delete(o);
        o = NULL;
    }
    gw_reply_json(resp, 200, o);
}

static void list_jobs(const gw_routes *g, const cv_http_request *req, const char *param, cv_http_response *resp) {
    (void)req;
    (void)param;
    gw_reply_json(resp, 200, gw_jobs_list(g->jobs));
}

static void post_job(const gw_routes *g, const cv_http_request *req, const char *param, cv_http_response *resp) {
    (void)param;
    gw_job_request job;
    const gw_scene *scene = NULL;
    uint64_t id = 0;
    cv_result r = gw_job_request_parse(req->body, req->body_size, g->max_pixels, &job);
    if (r == CV_OK && strcmp(job.scene, GW_DEFAULT_SCENE) != 0)
        r = gw_store_acquire(g->store, job.scene, &scene);
    if (r == CV_OK && (r = gw_jobs_submit(g->jobs, &job, scene, &id)) != CV_OK) {
        gw_reply_error(resp, r == CV_ERROR_LIMIT_EXCEEDED ? 429 : 503, "%s", cv_last_error());
        return;
    }
    if (r != CV_OK) {
        gw_reply_error(resp, gw_status_of(r), "%s", cv_last_error());
        return;
    }
    cJSON *o = NULL;
    gw_jobs_describe(g->jobs, id, &o);
    gw_reply_json(resp, 201, o);
}

/* The path's job id, or a 404 said. */
static bool job_id(const char *param, uint64_t *id, cv_http_response *resp) {
    if (!cv_parse_uint(param, 1, UINT64_MAX, id)) {
        gw_reply_error(resp, 404, "path: no job '%s' (job ids are whole numbers from 1)", param);
        return false;
    }
    return true;
}

static void get_job(const gw_routes *g, const cv_http_request *req, const char *param, cv_http_response *resp) {
    (void)req;
    uint64_t id;
    cJSON *o = NULL;
    if (job_id(param, &id, resp)) {
        cv_result r = gw_jobs_describe(g->jobs, id, &o);
        reply_result(resp, r, o);
    }
}

static void delete_job(const gw_routes *g, const cv_http_request *req, const char *param, cv_http_response *resp) {
    (void)req;
    uint64_t id;
    cJSON *o = NULL;
    if (job_id(param, &id, resp)) {
        cv_result r = gw_jobs_cancel(g->jobs, id, &o);
        reply_result(resp, r, o);
    }
}

static void job_image(const gw_routes *g, const char *param, bool exr, cv_http_response *resp) {
    uint64_t id;
    uint8_t *data = NULL;
    size_t size = 0;
    if (!job_id(param, &id, resp))
        return;
    cv_result r = gw_jobs_image(g->jobs, id, exr, &data, &size);
    if (r != CV_OK) {
        gw_reply_error(resp, gw_status_of(r), "%s", cv_last_error());
        return;
    }
    char disposition[96];
    snprintf(disposition, sizeof(disposition), "attachment; filename=\"job%llu.%s\"", (unsigned long long)id,
             exr ? "exr" : "png");
    gw_reply_bytes(resp, 200, exr ? "image/x-exr" : "image/png", disposition, data, size);
    free(data);
}

static void get_png(const gw_routes *g, const cv_http_request *req, const char *param, cv_http_response *resp) {
    (void)req;
    job_image(g, param, false, resp);
}

static void get_exr(const gw_routes *g, const cv_http_request *req, const char *param, cv_http_response *resp) {
    (void)req;
    job_image(g, param, true, resp);
}

/* Every route of the API, under /api/v1 (docs/openapi.yaml). */
static const struct route {
    const char *method;
    const char *pattern;
    route_fn fn;
} routes[] = {
    { "GET", "/", get_root },
    { "GET", "/nodes", get_nodes },
    { "POST", "/scenes", post_scene },
    { "PUT", "/scenes/{sha256}", put_scene },
    { "HEAD", "/scenes/{sha256}", head_scene },
    { "GET", "/scenes/{sha256}", get_scene },
    { "GET", "/jobs", list_jobs },
    { "POST", "/jobs", post_job },
    { "GET", "/jobs/{id}", get_job },
    { "DELETE", "/jobs/{id}", delete_job },
    { "GET", "/jobs/{id}/image.png", get_png },
    { "GET", "/jobs/{id}/image.exr", get_exr },
};

/* Whether `path` (after /api/v1, "" or "/" for the root) matches `pattern`; its {segment} into param. */
static bool match(const char *pattern, const char *path, char *param, size_t size) {
    param[0] = '\0';
    if (path[0] == '\0')
        path = "/";
    while (*pattern && *path) {
        if (*pattern == '{') {
            size_t n = strcspn(path, "/");
            if (n == 0)
                return false;
            snprintf(param, size, "%.*s", (int)n, path);
            path += n;
            pattern = strchr(pattern, '}') + 1;
        } else if (*pattern++ != *path++) {
            return false;
        }
    }
    return *pattern == '\0' && *path == '\0';
}

void gw_route(const gw_routes *g, const cv_http_request *req, cv_http_response *resp) {
    const char *p = req->path;
    if (strncmp(p, "/api/", 5) != 0)
        return;
    size_t api = strlen(API);
    if (strncmp(p, API, api) != 0 || (p[api] != '/' && p[api] != '\0')) {
        gw_reply_error(resp, 404, "path: %s: no such endpoint (this gateway serves " API ")", p);
        return;
    }
    char param[256], allowed[64] = "";
    for (size_t i = 0; i < sizeof(routes) / sizeof(routes[0]); i++) {
        if (!match(routes[i].pattern, p + api, param, sizeof(param)))
            continue;
        if (strcmp(req->method, routes[i].method) == 0) {
            routes[i].fn(g, req, param, resp);
            return;
        }
        size_t at = strlen(allowed);
        snprintf(allowed + at, sizeof(allowed) - at, "%s%s", at ? ", " : "", routes[i].method);
    }
    if (allowed[0])
        gw_reply_error(resp, 405, "%s %s: method not allowed (%s)", req->method, req->path, allowed);
    else
        gw_reply_error(resp, 404, "path: %s: no such endpoint", req->path);
}
