/* Responses a cv_http_handler fills in: a JSON body, or an error message as JSON. */
#include <corvid/web_server.h>

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static void set_body(cv_http_response *resp, int status, char *body, size_t size) {
    free(resp->body);
    resp->status = status;
    snprintf(resp->content_type, sizeof resp->content_type, "application/json");
    resp->body = (uint8_t *)body;
    resp->body_size = body ? size : 0;
    if (!body) /* out of memory: the status still says what happened, without a body */
        resp->status = status >= 400 ? status : 500;
}

void cv_http_respond_json(cv_http_response *resp, int status, const char *json) {
    size_t n = strlen(json);
    char *copy = malloc(n + 1);
    if (copy)
        memcpy(copy, json, n + 1);
    set_body(resp, status, copy, n);
}

/* Appends `s` JSON-escaped (quotes, backslashes and control characters). */
static size_t escape_json(char *out, const char *s) {
    size_t n = 0;
    for (; *s; s++) {
        unsigned char c = (unsigned char)*s;
        if (c == '"' || c == '\\') {
            out[n++] = '\\';
            out[n++] = (char)c;
        } else if (c < 0x20) {
            n += (size_t)sprintf(out + n, "\\u%04x", c);
        } else {
            out[n++] = (char)c;
        }
    }
    return n;
}

void cv_http_respond_error(cv_http_response *resp, int status, const char *fmt, ...) {
    char message[1024];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(message, sizeof message, fmt, ap);
    va_end(ap);
    /* Escaping at most sextuples a byte (\u00xx). */
    char *body = malloc(strlen(message) * 6 + 16);
    size_t n = 0;
    if (body) {
        n = (size_t)sprintf(body, "{\"error\":\"");
        n += escape_json(body + n, message);
        n += (size_t)sprintf(body + n, "\"}");
    }
    set_body(resp, status, body, n);
}
