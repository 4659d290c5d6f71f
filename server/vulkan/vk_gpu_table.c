/* Virtual multi-GPU: the device indirection table.
 *
 * Virtual device indices are redirected to adapter indices. With N instances
 * per adapter, each adapter appears N times, and each appearance becomes its
 * own VkDevice, so code written for several GPUs runs, and is tested, on one
 * (or on lavapipe). The instances of one adapter run concurrently from several
 * threads; on a CPU adapter they share its cores, so they test correctness,
 * not speed-up. Several real adapters use the same table. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "vk_adapters.h"

/* The adapters the table spreads over: the listed ones, or every usable
 * adapter of the best type present. */
static cv_result table_adapters(const vk_adapter *adapters, uint32_t count, const char *list, uint32_t *out,
                                uint32_t *out_count) {
    uint32_t n = 0;
    if (list && *list) {
        char spec[256];
        for (const char *p = list; n < CV_MAX_DEVICES;) {
            size_t len = strcspn(p, ",");
            /* An empty entry would match every adapter name: ",,," made three devices. */
            if (len == 0 || len >= sizeof(spec))
                return cv_error(CV_ERROR_INVALID_ARGUMENT, "--adapters: '%s': entry %u is %s", list, n + 1,
                                len ? "longer than 255 characters" : "empty");
            snprintf(spec, sizeof(spec), "%.*s", (int)len, p);
            cv_result r = vk_adapters_resolve(adapters, count, spec, &out[n]);
            if (r != CV_OK)
                return r;
            n++;
            if (p[len] != ',')
                break;
            p += len + 1;
        }
    } else {
        uint32_t best;
        cv_result r = vk_adapters_choose(adapters, count, CV_VULKAN_PURPOSE_RENDER, &best);
        if (r != CV_OK)
            return r;
        for (uint32_t i = 0; i < count && n < CV_MAX_DEVICES; i++)
            if (adapters[i].info.usable && adapters[i].info.type == adapters[best].info.type)
                out[n++] = i;
    }
    if (n == 0)
        return cv_error(CV_ERROR_NOT_FOUND, "vulkan: adapter list '%s' names no adapter", list ? list : "");
    *out_count = n;
    return CV_OK;
}

cv_result cv_vulkan_gpu_table_build(const cv_vulkan_gpu_config *config, cv_vulkan_gpu_table *out) {
    if (!out)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_vulkan_gpu_table_build: NULL table");
    cv_vulkan_gpu_config c = config ? *config : (cv_vulkan_gpu_config){ 0 };
    if (c.virtual_per_adapter == 0)
        c.virtual_per_adapter = 1;
    vk_instance *inst;
    cv_result r = vk_instance_acquire(false, CV_VULKAN_SYNC_VALIDATION_DEFAULT, &inst);
    if (r != CV_OK)
        return r;
    vk_adapter *adapters = NULL;
    uint32_t count = 0, chosen[CV_MAX_DEVICES], chosen_count = 0;
    r = vk_adapters_enumerate(inst, &adapters, &count);
    if (r == CV_OK)
        r = table_adapters(adapters, count, c.adapters, chosen, &chosen_count);
    free(adapters);
    vk_instance_release(inst);
    if (r != CV_OK)
        return r;

    uint32_t total = c.total ? c.total : chosen_count * c.virtual_per_adapter;
    if (total > CV_MAX_DEVICES)
        return cv_error(CV_ERROR_LIMIT_EXCEEDED, "vulkan: %u adapters x %u virtual GPUs exceeds %u devices",
                        chosen_count, c.virtual_per_adapter, CV_MAX_DEVICES);
    cv_vulkan_gpu_table table = { .count = total, .options = c.device };
    for (uint32_t i = 0; i < total; i++) {
        /* Explicit totals go round-robin over adapters; otherwise each
         * adapter's instances are adjacent (gpu0..N-1 on the first adapter). */
        uint32_t adapter = chosen[c.total ? i % chosen_count : i / c.virtual_per_adapter];
        uint32_t instance = 0;
        for (uint32_t j = 0; j < i; j++)
            instance += table.gpus[j].adapter == adapter;
        table.gpus[i] = (cv_vulkan_gpu){ .adapter = adapter, .instance = instance };
    }
    *out = table;
    return CV_OK;
}

cv_result cv_vulkan_create_devices(cv_context *ctx, const cv_vulkan_gpu_table *table, bool validation,
                                   cv_device **out) {
    if (!ctx || !table || !out)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_vulkan_create_devices: NULL argument");
    for (uint32_t i = 0; i < table->count; i++) {
        char adapter[16];
        snprintf(adapter, sizeof(adapter), "%u", table->gpus[i].adapter);
        cv_device_desc desc = { .adapter = adapter, .validation = validation, .backend_options = &table->options };
        snprintf(desc.label, sizeof(desc.label), "gpu%u", i);
        cv_result r = cv_device_create(ctx, cv_vulkan_backend(), &desc, &out[i]);
        if (r != CV_OK) {
            while (i-- > 0) {
                cv_device_destroy(out[i]);
                out[i] = NULL;
            }
            return r;
        }
    }
    return CV_OK;
}
