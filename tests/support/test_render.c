/* See test_render.h. */
#include "test_render.h"

#include "corvid/vulkan.h"
#include "test_adapter.h"

cv_result cv_test_render(uint32_t gpus, const cv_scene *scene, const cv_bvh *bvh, const cv_render_settings *settings,
                         cv_render_output *out, cv_render_stats *stats) {
    if (gpus == 0 || gpus > 4)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_test_render: %u devices (1..4)", gpus);
    cv_context *ctx;
    cv_device *devices[4] = { 0 };
    cv_vulkan_gpu_table table;
    cv_renderer *r = NULL;
    cv_result res = cv_context_create(NULL, &ctx);
    if (res != CV_OK)
        return res;
    res = cv_vulkan_gpu_table_build(&(cv_vulkan_gpu_config){ .total = gpus, .adapters = cv_test_adapter() }, &table);
    if (res == CV_OK)
        res = cv_vulkan_create_devices(ctx, &table, true, devices);
    if (res == CV_OK)
        res = cv_renderer_create(devices, gpus, scene, bvh, &r);
    if (res == CV_OK)
        res = cv_renderer_render(r, settings, out, stats, NULL, NULL);
    cv_renderer_destroy(r);
    cv_context_destroy(ctx);
    return res;
}
