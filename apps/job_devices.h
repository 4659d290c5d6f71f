/* The devices a REST gateway job renders on (corvid/gateway.h's open_devices),
 * shared by corvid-gateway and corvid-view (which serves the gateway on its
 * page's port): local devices of a Vulkan GPU table, made anew for each job in
 * a context of its own, or the devices of corvid-nodes (--nodes).
 *
 *     job_devices d = { .gpu_config = config };          // from cv_env_vulkan_gpu_args
 *     if (job_devices_configure(&d, nodes, validation) != CV_OK) ...
 *     cv_gateway_desc desc = { .open_devices = job_devices_open, .user = &d, .nodes = nodes };
 */
#ifndef CORVID_APPS_JOB_DEVICES_H
#define CORVID_APPS_JOB_DEVICES_H

#include <stdbool.h>

#include "corvid/gateway_types.h"
#include "corvid/vulkan.h"

typedef struct job_devices {
    cv_vulkan_gpu_config gpu_config; /* the local choice (--gpus, ...); ignored with nodes */
    cv_vulkan_gpu_table table;       /* built by job_devices_configure */
    const char *nodes;               /* "host:port,..."; NULL = local devices */
    bool validation;
} job_devices;

/* Checks the choice now, so that a bad one fails at start: nodes (NULL = local), else the local table from
 * gpu_config and the environment (no choice at all: one device). */
cv_result job_devices_configure(job_devices *d, const char *nodes, bool validation);

/* cv_gateway_open_devices_fn (user: the job_devices): a context of its own and its devices. */
cv_result job_devices_open(void *user, cv_gateway_devices *out);

#endif
