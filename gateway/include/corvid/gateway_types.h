/* What the REST gateway (corvid/gateway.h) and its parts share: the API's
 * version and a job's devices as the program's open_devices callback gives
 * them.
 *
 *     static cv_result open_gpus(void *user, cv_gateway_devices *out) {
 *         cv_result r = cv_context_create(NULL, &out->ctx);
 *         if (r == CV_OK && (r = cv_device_create(out->ctx, backend, &desc, &out->devices[0])) == CV_OK)
 *             out->count = 1;
 *         return r;   // on failure the callback leaves nothing open
 *     }
 */
#ifndef CORVID_GATEWAY_TYPES_H
#define CORVID_GATEWAY_TYPES_H

#include <stdint.h>

#include "corvid/device.h"
#include "corvid/result.h"

/* The version in the API's paths (/api/v1) and in GET /api/v1's "version". */
#define CV_GATEWAY_API_VERSION 1

/* One job's devices: a context of its own and its devices (device 0 the primary). */
typedef struct cv_gateway_devices {
    cv_context *ctx;
    cv_device *devices[CV_MAX_DEVICES];
    uint32_t count;
} cv_gateway_devices;

/* Opens the devices of one job into *out; on failure it leaves nothing open. */
typedef cv_result (*cv_gateway_open_devices_fn)(void *user, cv_gateway_devices *out);

#endif
