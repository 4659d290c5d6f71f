/* Node endpoints: "host:port" lists as users write them (--nodes, CORVID_NODES).
 *
 * A list is comma-separated; each entry is HOST:PORT with HOST a name, an IPv4
 * address or a bracketed IPv6 address ("[::1]:7700") and PORT 1..65535. Empty
 * entries, missing or bad ports, over-long names and repeated endpoints are
 * refused with a message naming the entry, so "a:1,,b:2" or "a:1,a:1" never
 * turns silently into a different set of devices.
 *
 *     cv_endpoint nodes[CV_MAX_NODES];
 *     uint32_t n;
 *     // list: --nodes' value, or CORVID_NODES as the program read it
 *     if (cv_endpoints_parse(list, "--nodes", nodes, CV_MAX_NODES, &n) != CV_OK)
 *         fprintf(stderr, "%s\n", cv_last_error());
 *     ... cv_device_desc desc = { .endpoint = nodes[0].text }; */
#ifndef CORVID_ENDPOINT_H
#define CORVID_ENDPOINT_H

#include <stdint.h>

#include "corvid/result.h"

#define CV_MAX_NODES 16u
#define CV_ENDPOINT_HOST_MAX 253u /* the longest DNS name */

typedef struct cv_endpoint {
    char host[CV_ENDPOINT_HOST_MAX + 3]; /* as written, brackets of IPv6 included */
    uint16_t port;
    char text[CV_ENDPOINT_HOST_MAX + 10]; /* "host:port", what gRPC is given */
} cv_endpoint;

/* Parses one "host:port". `what` names the option in messages. */
cv_result cv_endpoint_parse(const char *text, const char *what, cv_endpoint *out);
/* Parses a comma-separated list of at most `capacity` endpoints; on failure
 * *out and *count are unchanged. */
cv_result cv_endpoints_parse(const char *list, const char *what, cv_endpoint *out, uint32_t capacity,
                             uint32_t *count);

#endif
