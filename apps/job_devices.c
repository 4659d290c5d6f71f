/* The devices of a REST gateway job (job_devices.h): local ones from a GPU table,
 * or the nodes' (render_devices.c). */
#include "job_devices.h"

#include "env_vulkan.h"
#include "render_devices.h"

cv_result job_devices_open(void *user, cv_gateway_devices *out) {
    const job_devices *d = user;
    cv_result r = cv_context_create(NULL, &out->ctx);
    if (r == CV_OK && d->nodes) {
        r = render_node_devices(out->ctx, d->nodes, out->devices, &out->count, true);
    } else if (r == CV_OK) {
        r = cv_vulkan_create_devices(out->ctx, &d->table, d->validation, out->devices);
        out->count = r == CV_OK ? d->table.count : 0;
    }
    if (r != CV_OK) {
        for (uint32_t i = out->count; i-- > 0;)
            cv_device_destroy(out->devices[i]);
        if (out->ctx)
            cv_context_destroy(out->ctx);
        *out = (cv_gateway_devices){ 0 };
    }
    return r;
}

cv_result job_devices_configure(job_devices *d, const char *nodes, bool validation) {
    d->nodes = nodes;
    d->validation = validation;
    if (nodes)
        return CV_OK;
    if (!d->gpu_config.total && !d->gpu_config.virtual_per_adapter && !d->gpu_config.adapters)
        d->gpu_config.total = 1;
    if (d->gpu_config.total && !d->gpu_config.virtual_per_adapter)
        d->gpu_config.virtual_per_adapter = 1;
    cv_result r = cv_env_vulkan_gpu_config(&d->gpu_config);
    if (r == CV_OK)
        r = cv_vulkan_gpu_table_build(&d->gpu_config, &d->table);
    if (r == CV_OK && d->table.count > CV_MAX_DEVICES)
        r = cv_error(CV_ERROR_LIMIT_EXCEEDED, "%u devices requested; a job takes at most %u", d->table.count,
                     CV_MAX_DEVICES);
    return r;
}
