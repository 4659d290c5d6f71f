/* The gateway's HTTP replies (reply.h). */
#include "reply.h"

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static void set_body(cv_http_response *resp, int status, const char *content_type, uint8_t *body, size_t size) {
    free(resp->body);
    resp->status = status;
    snprintf(resp->content_type, sizeof(resp->content_type), "%s", content_type);
    resp->body = body;
    resp->body_size = size;
}

/* The one reply left when memory runs out: a static text copied into a small allocation, or no body. */
static void reply_out_of_memory(cv_http_response *resp) {
    static const char text[] = "{\"error\":\"gateway: out of memory\"}";
    uint8_t *body = malloc(sizeof(text) - 1);
    if (body)
        memcpy(body, text, sizeof(text) - 1);
    set_body(resp, 503, "application/json", body, body ? sizeof(text) - 1 : 0);
}

void gw_reply_json(cv_http_response *resp, int status, cJSON *json) {
    char *text = json ? cJSON_PrintUnformatted(json) : NULL;
    cJSON_Delete(json);
    if (!text) {
        reply_out_of_memory(resp);
        return;
    }
    set_body(resp, status, "application/json", (uint8_t *)text, strlen(text));
}

void gw_reply_error(cv_http_response *resp, int status, const char *fmt, ...) {
    char message[1024];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(message, sizeof(message), fmt, ap);
    va_end(ap);
    cJSON *json = cJSON_CreateObject();
    if (json && !cJSON_AddStringToObject(json, "error", message)) {
        cJSON_Delete(json);
        json = NULL;
    }
    gw_reply_json(resp, status, json);
}

void gw_reply_bytes(cv_http_response *resp, int status, const char *content_type, const char *disposition,
                    const void *data, size_t size) {
    uint8_t *body = malloc(size ? size : 1);
    if (!body) {
        reply_out_of_memory(resp);
        return;
    }
    memcpy(body, data, size);
    set_body(resp, status, content_type, body, size);
    snprintf(resp->content_disposition, sizeof(resp->content_disposition), "%s", disposition);
}

int gw_status_of(cv_result r) {
    switch (r) {
    case CV_ERROR_INVALID_ARGUMENT:
    case CV_ERROR_MALFORMED:
    case CV_ERROR_HASH_MISMATCH:
    case CV_ERROR_OUT_OF_RANGE: return 400;
    case CV_ERROR_NOT_FOUND: return 404;
    case CV_ERROR_BAD_STATE: return 409;
    case CV_ERROR_LIMIT_EXCEEDED: return 413;
    case CV_ERROR_OUT_OF_MEMORY:
    case CV_ERROR_CONNECTION: return 503;
    default: return 500;
    }
}
