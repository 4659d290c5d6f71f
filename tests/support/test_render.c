/* See test_render.h. */
#include "test_render.h"

#include "corvid/vulkan.h"
#include "env_vulkan.h"
#include "test_adapter.h"

cv_result cv_test_gpus_open(uint32_t count, cv_test_gpus *out) {
    *out = (cv_test_gpus){ 0 };
    if (count == 0 || count > 4)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_test_gpus_open: %u devices (1..4)", count);
    cv_vulkan_gpu_table table;
    cv_result res = cv_context_create(NULL, &out->ctx);
    if (res != CV_OK)
        return res;
    /* The device options from the environment, as a program's (renderer_transfer_paths_shared: CORVID_VGPU_DEVICE). */
    cv_vulkan_gpu_config config = { .total = count, .adapters = cv_test_adapter() };
    res = cv_env_vulkan_options(&config.device);
    if (res == CV_OK)
        res = cv_vulkan_gpu_table_build(&config, &table);
    if (res == CV_OK)
        res = cv_vulkan_create_devices(out->ctx, &table, true, out->devices);
    if (res != CV_OK) {
        cv_test_gpus_close(out);
        return res;
    }
    out->count = count;
    return CV_OK;
}

cv_result cv_test_gpus_render(const cv_test_gpus *g, uint32_t gpus, const cv_scene *scene, const cv_bvh *bvh,
                              const cv_render_settings *settings, cv_render_output *out, cv_render_stats *stats) {
    if (!g || gpus == 0 || gpus > g->count)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_test_gpus_render: %u devices of %u", gpus, g ? g->count : 0);
    cv_renderer *r = NULL;
    cv_result res = cv_renderer_create(g->devices, gpus, scene, bvh, &r);
    if (res == CV_OK)
        res = cv_renderer_render(r, settings, out, stats, NULL, NULL);
    cv_renderer_destroy(r);
    return res;
}

void cv_test_gpus_close(cv_test_gpus *g) {
    cv_context_destroy(g->ctx); /* its devices with it */
    *g = (cv_test_gpus){ 0 };
}

cv_result cv_test_render(uint32_t gpus, const cv_scene *scene, const cv_bvh *bvh, const cv_render_settings *settings,
                         cv_render_output *out, cv_render_stats *stats) {
    if (gpus == 0 || gpus > 4)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_test_render: %u devices (1..4)", gpus);
    cv_test_gpus g;
    cv_result res = cv_test_gpus_open(gpus, &g);
    if (res == CV_OK)
        res = cv_test_gpus_render(&g, gpus, scene, bvh, settings, out, stats);
    cv_test_gpus_close(&g);
    return res;
}
