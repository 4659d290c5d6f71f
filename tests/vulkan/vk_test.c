/* Helpers for the Vulkan backend tests (see vk_test.h). */
#include <stdlib.h>
#include <string.h>

#include "env_vulkan.h"
#include "vk_test.h"

#include <stdio.h>

const char *vkt_adapter(void) {
    const char *env = getenv("CORVID_TEST_ADAPTER");
    return env && env[0] ? env : "llvmpipe";
}

bool vkt_is_lavapipe(void) { return strcmp(vkt_adapter(), "llvmpipe") == 0; }

cv_result vkt_device(cv_context *ctx, const char *adapter, const char *label, cv_device **out) {
    /* The device options from the environment, as a program's (env_vulkan.h): the *_shared variants of the tests run
     * with CORVID_VGPU_DEVICE=shared. */
    cv_vulkan_device_options options = { 0 };
    cv_result r = cv_env_vulkan_options(&options);
    cv_device_desc desc = { .adapter = adapter ? adapter : vkt_adapter(),
                            .validation = true,
                            .backend_options = &options };
    snprintf(desc.label, sizeof(desc.label), "%s", label);
    return r == CV_OK ? cv_device_create(ctx, cv_vulkan_backend(), &desc, out) : r;
}

cv_buffer vkt_buffer(cv_context *ctx, cv_device *dev, uint64_t size, uint32_t usage, const char *label) {
    cv_buffer_desc desc = { .size = size, .usage = usage };
    snprintf(desc.label, sizeof(desc.label), "%s", label);
    cv_buffer b = { 0 };
    CHECK_OK(cv_buffer_create(ctx, &desc, &b));
    CHECK_OK(cv_device_load(dev, cv_any(b)));
    return b;
}

cv_texture vkt_texture(cv_context *ctx, cv_device *dev, uint32_t w, uint32_t h, cv_format f, uint32_t usage,
                       const char *label) {
    cv_texture_desc desc = { .width = w, .height = h, .format = f, .usage = usage };
    snprintf(desc.label, sizeof(desc.label), "%s", label);
    cv_texture t = { 0 };
    CHECK_OK(cv_texture_create(ctx, &desc, &t));
    CHECK_OK(cv_device_load(dev, cv_any(t)));
    return t;
}

cv_sampler vkt_sampler(cv_context *ctx, cv_device *dev, cv_filter filter, cv_address_mode address) {
    cv_sampler s = { 0 };
    CHECK_OK(cv_sampler_create(ctx, &(cv_sampler_desc){ .filter = filter, .address = address }, &s));
    CHECK_OK(cv_device_load(dev, cv_any(s)));
    return s;
}

cv_pipeline vkt_pipeline(cv_context *ctx, cv_device *dev, const char *name) {
    cv_pipeline p = { 0 };
    CHECK_OK(cv_pipeline_create(ctx, name, &p));
    CHECK_OK(cv_device_load(dev, cv_any(p)));
    return p;
}

cv_result vkt_two_virtual_gpus(cv_context *ctx, cv_device *out[2]) {
    out[0] = out[1] = NULL;
    cv_vulkan_gpu_table table;
    cv_vulkan_gpu_config config = { .virtual_per_adapter = 2, .adapters = vkt_adapter() };
    cv_result r = cv_env_vulkan_options(&config.device); /* as vkt_device */
    if (r == CV_OK)
        r = cv_vulkan_gpu_table_build(&config, &table);
    return r == CV_OK ? cv_vulkan_create_devices(ctx, &table, true, out) : r;
}

cv_result vkt_run(cv_device *dev, cv_cmdlist list, uint64_t *ticket) {
    uint64_t t = 0;
    cv_result r = cv_device_submit(dev, list, &t);
    if (r == CV_OK)
        r = cv_device_wait(dev, t, UINT64_MAX);
    if (ticket)
        *ticket = t;
    return r;
}

int vkt_report(const char *name) {
    cv_vulkan_message_counts m = cv_vulkan_get_message_counts();
    CHECK_EQ_INT(m.errors, 0);
    CHECK_EQ_INT(m.warnings, 0);
    return check_report(name);
}
