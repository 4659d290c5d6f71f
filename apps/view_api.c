/* corvid-view's API (view_api.h): snapshots, stats and the view's job defaults; the
 * rest of /api/ is the REST gateway's. */
#include "view_api.h"

#include <cjson/cJSON.h>
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "corvid/frame_codec.h"
#include "corvid/image_exr.h"
#include "view_messages.h"
#include "view_session.h"

/* The ZSTD radiance snapshot as an EXR file's bytes: decompressed, written to a
 * private temporary directory by image/'s writer, read back, removed. */
static cv_result exr_bytes(const cv_encoded *z, uint8_t **out, size_t *out_size) {
    cv_decoder *d = NULL;
    uint8_t *rgba = NULL;
    size_t size = 0;
    uint32_t w, h;
    cv_result r = cv_decoder_create(CV_CODEC_ZSTD, &d);
    if (r == CV_OK)
        r = cv_decoder_decode(d, z->data, z->size, &rgba, &size, &w, &h);
    cv_decoder_destroy(d);
    if (r == CV_OK && size != (size_t)z->width * z->height * 16)
        r = cv_error(CV_ERROR_MALFORMED, "snapshot.exr: %zu bytes of radiance for %ux%u RGBA32F", size, z->width,
                     z->height);
    char dir[] = "/tmp/corvid-view-XXXXXX", path[64];
    bool made = r == CV_OK && mkdtemp(dir);
    if (r == CV_OK && !made)
        r = cv_error(CV_ERROR_IO, "snapshot.exr: temporary directory: %s", strerror(errno));
    snprintf(path, sizeof path, "%s/snapshot.exr", dir);
    cv_exr_layer layer = { .channel_count = 4,
                           .channels = { "R", "G", "B", "A" },
                           .type = CV_EXR_HALF,
                           .interleaved = (const float *)rgba };
    if (r == CV_OK)
        r = cv_exr_write(path, &(cv_exr_desc){ .width = z->width,
                                               .height = z->height,
                                               .compression = CV_EXR_PIZ,
                                               .layer_count = 1,
                                               .layers = &layer });
    free(rgba);
    FILE *f = r == CV_OK ? fopen(path, "rb") : NULL;
    if (r == CV_OK && !f)
        r = cv_error(CV_ERROR_IO, "snapshot.exr: %s: %s", path, strerror(errno));
    if (f) {
        fseek(f, 0, SEEK_END);
        long n = ftell(f);
        fseek(f, 0, SEEK_SET);
        *out = n > 0 ? malloc((size_t)n) : NULL;
        if (!*out || fread(*out, 1, (size_t)n, f) != (size_t)n) {
            free(*out);
            *out = NULL;
            r = cv_error(CV_ERROR_IO, "snapshot.exr: reading back %s", path);
        }
        *out_size = *out ? (size_t)n : 0;
        fclose(f);
    }
    if (made) {
        unlink(path);
        rmdir(dir);
    }
    return r;
}

static void snapshot(view_session *s, cv_codec codec, cv_http_response *resp) {
    cv_encoded e = { 0 };
    pthread_mutex_lock(&s->lock);
    cv_live *live = s->live;
    pthread_mutex_unlock(&s->lock);
    cv_result r = live ? cv_live_snapshot(live, codec, &e) : cv_error(CV_ERROR_BAD_STATE, "no live view yet");
    if (r == CV_OK && codec == CV_CODEC_PNG) {
        resp->body = e.data; /* the response owns it now */
        resp->body_size = e.size;
        e.data = NULL;
    } else if (r == CV_OK) {
        r = exr_bytes(&e, &resp->body, &resp->body_size);
    }
    cv_encoded_free(&e);
    if (r != CV_OK) {
        cv_http_respond_error(resp, 503, "snapshot: %s", cv_last_error());
        return;
    }
    resp->status = 200;
    const char *ext = codec == CV_CODEC_PNG ? "png" : "exr";
    snprintf(resp->content_type, sizeof resp->content_type, "%s",
             codec == CV_CODEC_PNG ? "image/png" : "image/x-exr");
    snprintf(resp->content_disposition, sizeof resp->content_disposition, "attachment; filename=\"corvid-view.%s\"",
             ext);
}

void view_api_init(view_api *a, view_session *session, cv_gateway *gateway, uint32_t width, uint32_t height) {
    *a = (view_api){ .session = session, .gateway = gateway, .width = width, .height = height };
    pthread_mutex_init(&a->lock, NULL);
    snprintf(a->note, sizeof a->note, "the scene is loading");
}

void view_api_finish(view_api *a) { pthread_mutex_destroy(&a->lock); }

void view_api_no_scene(view_api *a, const char *why) {
    pthread_mutex_lock(&a->lock);
    a->scene[0] = 0;
    snprintf(a->note, sizeof a->note, "%s", why);
    pthread_mutex_unlock(&a->lock);
}

static cv_result read_file(const char *path, uint8_t **out, size_t *size) {
    FILE *f = fopen(path, "rb");
    if (!f)
        return cv_error(CV_ERROR_IO, "%s: %s", path, strerror(errno));
    long n = fseek(f, 0, SEEK_END) == 0 ? ftell(f) : -1;
    *out = n > 0 && fseek(f, 0, SEEK_SET) == 0 ? malloc((size_t)n) : NULL;
    cv_result r = CV_OK;
    if (!*out || fread(*out, 1, (size_t)n, f) != (size_t)n) {
        free(*out);
        *out = NULL;
        r = cv_error(CV_ERROR_IO, "%s: cannot read it", path);
    }
    *size = *out ? (size_t)n : 0;
    fclose(f);
    return r;
}

/* The model's bytes to the gateway as a page would send them (POST /api/v1/scenes): its store parses
 * them as for any upload, so a job renders what an uploaded copy of the file would render. */
cv_result view_api_register_scene(view_api *a, const char *model) {
    if (!model) {
        pthread_mutex_lock(&a->lock);
        snprintf(a->scene, sizeof a->scene, "default");
        a->note[0] = 0;
        pthread_mutex_unlock(&a->lock);
        return CV_OK;
    }
    uint8_t *bytes = NULL;
    size_t size = 0;
    cv_result r = read_file(model, &bytes, &size);
    cv_http_response resp = { 0 };
    if (r == CV_OK)
        cv_gateway_handle(a->gateway,
                          &(cv_http_request){ .method = "POST",
                                              .path = "/api/v1/scenes",
                                              .query = "",
                                              .content_type = "application/octet-stream",
                                              .body = bytes,
                                              .body_size = size },
                          &resp);
    free(bytes);
    cJSON *json = resp.body ? cJSON_ParseWithLength((const char *)resp.body, resp.body_size) : NULL;
    const cJSON *scene = cJSON_GetObjectItemCaseSensitive(json, "scene");
    const cJSON *error = cJSON_GetObjectItemCaseSensitive(json, "error");
    if (r == CV_OK && (resp.status / 100 != 2 || !cJSON_IsString(scene)))
        r = cv_error(CV_ERROR_INVALID_ARGUMENT, "jobs: the gateway refused %s (%d): %s", model, resp.status,
                     cJSON_IsString(error) ? error->valuestring : "no answer");
    pthread_mutex_lock(&a->lock);
    if (r == CV_OK) {
        snprintf(a->scene, sizeof a->scene, "%s", scene->valuestring);
        a->note[0] = 0;
    } else {
        snprintf(a->note, sizeof a->note, "%s", cv_last_error());
    }
    pthread_mutex_unlock(&a->lock);
    cJSON_Delete(json);
    free(resp.body);
    return r;
}

/* GET /api/v1/view: what a job from the page starts from. */
static void view_defaults(view_api *a, cv_http_response *resp) {
    cJSON *o = cJSON_CreateObject();
    pthread_mutex_lock(&a->lock);
    bool ok = o &&
              (a->scene[0] ? cJSON_AddStringToObject(o, "scene", a->scene) : cJSON_AddNullToObject(o, "scene")) &&
              cJSON_AddNumberToObject(o, "width", a->width) && cJSON_AddNumberToObject(o, "height", a->height) &&
              cJSON_AddStringToObject(o, "note", a->note);
    pthread_mutex_unlock(&a->lock);
    char *json = ok ? cJSON_PrintUnformatted(o) : NULL;
    cJSON_Delete(o);
    if (json)
        cv_http_respond_json(resp, 200, json);
    else
        cv_http_respond_error(resp, 500, "/api/v1/view: out of memory");
    free(json);
}

void view_api_handle(void *user, const cv_http_request *req, cv_http_response *resp) {
    view_api *a = user;
    view_session *s = a->session;
    bool png = !strcmp(req->path, "/api/v1/view/snapshot.png"), exr = !strcmp(req->path, "/api/v1/view/snapshot.exr");
    bool stats = !strcmp(req->path, "/api/v1/view/stats"), defaults = !strcmp(req->path, "/api/v1/view");
    if (!png && !exr && !stats && !defaults) {
        cv_gateway_handle(a->gateway, req, resp);
        return;
    }
    if (strcmp(req->method, "GET") && strcmp(req->method, "HEAD")) {
        cv_http_respond_error(resp, 405, "%s: %s not allowed (GET)", req->path, req->method);
        return;
    }
    if (defaults) {
        view_defaults(a, resp);
        return;
    }
    if (!stats) {
        snapshot(s, png ? CV_CODEC_PNG : CV_CODEC_ZSTD, resp);
        return;
    }
    cv_live_stats ls = { 0 };
    cv_web_stats ws = { 0 };
    pthread_mutex_lock(&s->lock);
    if (s->live)
        cv_live_get_stats(s->live, &ls);
    double sent = s->sent_bytes_per_s, received = s->page_bytes_per_s;
    pthread_mutex_unlock(&s->lock);
    char *json = view_stats_json(&ls, &ws, sent, received);
    if (json)
        cv_http_respond_json(resp, 200, json);
    free(json);
}
