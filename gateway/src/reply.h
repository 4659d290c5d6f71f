/* The gateway's HTTP replies: JSON documents, {"error": "..."} refusals and
 * files, written into a cv_http_response (its body malloc'd; the server frees
 * it), and the HTTP status that answers a cv_result. */
#ifndef CORVID_GATEWAY_REPLY_H
#define CORVID_GATEWAY_REPLY_H

#include <cjson/cJSON.h>

#include "corvid/result.h"
#include "corvid/web_server.h"

/* Prints `json` (NULL: out of memory, 503) as the body and deletes it. */
void gw_reply_json(cv_http_response *resp, int status, cJSON *json);

/* The body {"error": "<message>"}. */
void gw_reply_error(cv_http_response *resp, int status, const char *fmt, ...) __attribute__((format(printf, 3, 4)));

/* A copy of `size` bytes; disposition "" = none. */
void gw_reply_bytes(cv_http_response *resp, int status, const char *content_type, const char *disposition,
                    const void *data, size_t size);

/* 400 for bad input, 404 not found, 409 a wrong state, 413 over a limit, 503 out of memory or a node
 * unreachable, 500 for anything else (callers decide the statuses particular to them, e.g. 429). */
int gw_status_of(cv_result r);

#endif
