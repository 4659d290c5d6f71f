/* The routes of /api/v1 (routes.h). */
#include "routes.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "corvid/gateway_types.h"
#include "corvid/render_options.h"
#include "reply.h"

#define API "/api/v1"

static bool is(const cv_http_request *req, const char *method) { return strcmp(req->method, method) == 0; }

static void not_allowed(const cv_http_request *req, cv_http_response *resp, const char *allowed) {
    gw_reply_error(resp, 405, "%s %s: method not allowed (%s)", req->method, req->path, allowed);
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

static void get_root(const gw_routes *g, cv_http_response *resp) {
    cJSON *o = cJSON_CreateObject();
    cJSON *settings = settings_json();
    if (!o || !settings || !cJSON_AddItemToObject(o, "settings", settings)) {
        cJSON_Delete(settings);
        cJSON_Delete(o);
        gw_reply_json(resp, 200, NULL);
        return;
    }
    cJSON *limits = cJSON_AddObjectToObject(o, "limits");
    bool ok = limits && cJSON_AddNumberToObject(o, "version", CV_GATEWAY_API_VERSION) &&
              cJSON_AddStringToObject(o, "api", API) &&
              cJSON_AddNumberToObject(limits, "max_scene_bytes", (double)g->max_scene_bytes) &&
              cJSON_AddNumberToObject(limits, "max_pixels", (double)g->max_pixels) &&
              cJSON_AddNumberToObject(limits, "workers", g->workers) &&
              cJSON_AddNumberToObject(limits, "max_queued", g->max_queued);
    if (!ok) {
        cJSON_Delete(o);
        o = NULL;
    }
    gw_reply_json(resp, 200, o);
}

/* PUT /scenes/{sha} (expected set) and POST /scenes. */
static void put_scene(const gw_routes *g, const cv_http_request *req, const char *expected, cv_http_response *resp) {
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

static void scene_item(const gw_routes *g, const cv_http_request *req, const char *id, cv_http_response *resp) {
    uint8_t digest[CV_SHA256_SIZE];
    char sha[CV_SHA256_HEX_SIZE];
    if (!cv_sha256_parse_hex(id, digest)) {
        gw_reply_error(resp, 400, "path: '%s' is not a SHA-256 (64 hex digits)", id);
        return;
    }
    cv_sha256_hex(digest, sha);
    if (is(req, "PUT")) {
        put_scene(g, req, sha, resp);
        return;
    }
    if (!is(req, "GET") && !is(req, "HEAD")) {
        not_allowed(req, resp, "GET, HEAD, PUT");
        return;
    }
    uint64_t bytes = 0, triangles = 0;
    bool known = gw_store_describe(g->store, sha, &bytes, &triangles);
    if (is(req, "HEAD")) {
        resp->status = known ? 200 : 404;
        snprintf(resp->content_type, sizeof(resp->content_type), "application/json");
    } else if (!known) {
        gw_reply_error(resp, 404, "scene: no stored model has the SHA-256 %s (upload it first)", sha);
    } else {
        cJSON *o = cJSON_CreateObject();
        if (o && (!cJSON_AddStringToObject(o, "scene", sha) || !cJSON_AddNumberToObject(o, "bytes", (double)bytes) ||
                  !cJSON_AddNumberToObject(o, "triangles", (double)triangles))) {
            cJSON_Delete(o);
            o = NULL;
        }
        gw_reply_json(resp, 200, o);
    }
}

static void post_job(const gw_routes *g, const cv_http_request *req, cv_http_response *resp) {
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

/* /jobs/{id}[/image.png|/image.exr]. */
static void job_item(const gw_routes *g, const cv_http_request *req, const char *rest, cv_http_response *resp) {
    char *end = NULL;
    errno = 0;
    unsigned long long id = strtoull(rest, &end, 10);
    if (rest[0] < '0' || rest[0] > '9' || errno || (*end && *end != '/')) {
        gw_reply_error(resp, 404, "path: no job '%s' (job ids are numbers)", rest);
        return;
    }
    cJSON *o = NULL;
    cv_result r;
    if (*end == '/') {
        bool png = strcmp(end, "/image.png") == 0, exr = strcmp(end, "/image.exr") == 0;
        if (!png && !exr) {
            gw_reply_error(resp, 404, "path: %s: no such endpoint (image.png, image.exr)", req->path);
            return;
        }
        if (!is(req, "GET")) {
            not_allowed(req, resp, "GET");
            return;
        }
        uint8_t *data = NULL;
        size_t size = 0;
        if ((r = gw_jobs_image(g->jobs, id, exr, &data, &size)) != CV_OK) {
            gw_reply_error(resp, gw_status_of(r), "%s", cv_last_error());
            return;
        }
        char disposition[96];
        snprintf(disposition, sizeof(disposition), "attachment; filename=\"job%llu.%s\"", id, exr ? "exr" : "png");
        gw_reply_bytes(resp, 200, exr ? "image/x-exr" : "image/png", disposition, data, size);
        free(data);
        return;
    }
    if (is(req, "GET"))
        r = gw_jobs_describe(g->jobs, id, &o);
    else if (is(req, "DELETE"))
        r = gw_jobs_cancel(g->jobs, id, &o);
    else {
        not_allowed(req, resp, "GET, DELETE");
        return;
    }
    if (r != CV_OK)
        gw_reply_error(resp, gw_status_of(r), "%s", cv_last_error());
    else
        gw_reply_json(resp, 200, o);
}

void gw_route(const gw_routes *g, const cv_http_request *req, cv_http_response *resp) {
    const char *p = req->path;
    if (strncmp(p, "/api/", 5) != 0)
        return;
    if (strncmp(p, API, strlen(API)) != 0 || (p[strlen(API)] != '/' && p[strlen(API)] != '\0')) {
        gw_reply_error(resp, 404, "path: %s: no such endpoint (this gateway serves " API ")", p);
        return;
    }
    p += strlen(API);
    if (strcmp(p, "") == 0 || strcmp(p, "/") == 0) {
        if (is(req, "GET"))
            get_root(g, resp);
        else
            not_allowed(req, resp, "GET");
    } else if (strcmp(p, "/nodes") == 0) {
        if (is(req, "GET"))
            gw_reply_json(resp, 200, gw_health_describe(g->health));
        else
            not_allowed(req, resp, "GET");
    } else if (strcmp(p, "/scenes") == 0) {
        if (is(req, "POST"))
            put_scene(g, req, NULL, resp);
        else
            not_allowed(req, resp, "POST");
    } else if (strncmp(p, "/scenes/", 8) == 0) {
        scene_item(g, req, p + 8, resp);
    } else if (strcmp(p, "/jobs") == 0) {
        if (is(req, "GET"))
            gw_reply_json(resp, 200, gw_jobs_list(g->jobs));
        else if (is(req, "POST"))
            post_job(g, req, resp);
        else
            not_allowed(req, resp, "GET, POST");
    } else if (strncmp(p, "/jobs/", 6) == 0) {
        job_item(g, req, p + 6, resp);
    } else {
        gw_reply_error(resp, 404, "path: %s: no such endpoint", req->path);
    }
}
