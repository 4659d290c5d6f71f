/* GET /api/v1/nodes: where jobs render and whether it is up. For a node
 * list every node is asked (cv_proxy_query_node: its name, sessions and
 * devices) at create and then every interval by a thread of its own, so a
 * request only reads the last answers; local devices are opened once at
 * create through the program's open_devices, their names noted, and closed.
 * Thread-safe. */
#ifndef CORVID_GATEWAY_NODE_HEALTH_H
#define CORVID_GATEWAY_NODE_HEALTH_H

#include <cjson/cJSON.h>

#include "corvid/gateway_types.h"

typedef struct gw_health gw_health;

/* nodes: the list, or NULL/"" for local devices (checked: a bad list is CV_ERROR_INVALID_ARGUMENT). */
cv_result gw_health_create(const char *nodes, uint32_t interval_ms, cv_gateway_open_devices_fn open_devices,
                           void *user, gw_health **out);
void gw_health_destroy(gw_health *h);

/* {"source": "nodes"|"local", "nodes": [{"endpoint", "health": "unknown"|"up"|"down", "error", "name",
 *  "sessions", "checked_ms_ago", "devices": [{"index", "label", "name", "backend"}]}]} */
cJSON *gw_health_describe(gw_health *h);

#endif
