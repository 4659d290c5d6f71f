/* Device objects on Vulkan: every pipeline of the registry builds (so its
 * shaders exist, declare the registry's binding kinds and local size), every
 * Corvid format makes a texture with each usage its format allows, a format
 * lacking a feature a usage needs is refused with CV_ERROR_UNSUPPORTED by the
 * backend, and the embedded shader table answers lookups. */
#include <string.h>

#include "corvid/backend.h"
#include "corvid/shaders.h"
#include "vk_test.h"

static void test_registry(cv_context *ctx, cv_device *dev) {
    uint32_t count = cv_pipeline_registry_count();
    CHECK(count >= 5);
    for (uint32_t i = 0; i < count; i++) {
        const cv_pipeline_info *info = cv_pipeline_registry_at(i);
        const char *files[3] = { info->compute_shader, info->vertex_shader, info->fragment_shader };
        for (int s = 0; s < 3; s++)
            if (files[s]) {
                size_t size = 0;
                CHECK(cv_shader_spirv(files[s], &size) != NULL);
                CHECK(size > 20 && size % 4 == 0);
            }
        cv_pipeline p;
        CHECK_OK(cv_pipeline_create(ctx, info->name, &p));
        cv_result r = cv_device_load(dev, cv_any(p));
        if (r != CV_OK)
            fprintf(stderr, "pipeline '%s': %s\n", info->name, cv_last_error());
        CHECK_OK(r);
        CHECK_OK(cv_pipeline_destroy(ctx, p));
    }
    size_t size = 1;
    CHECK(cv_shader_spirv("no_such_shader.comp", &size) == NULL);
    CHECK_EQ_INT(size, 0);
    CHECK(cv_shader_count() >= 6);
}

static void test_formats(cv_context *ctx, cv_device *dev) {
    for (int f = CV_FORMAT_RGBA8_UNORM; f < CV_FORMAT_COUNT; f++) {
        bool depth = cv_format_is_depth((cv_format)f);
        uint32_t usage = depth ? CV_TEXTURE_USAGE_DEPTH_TARGET | CV_TEXTURE_USAGE_SAMPLED
                               : CV_TEXTURE_USAGE_SAMPLED | CV_TEXTURE_USAGE_STORAGE | CV_TEXTURE_USAGE_COLOR_TARGET;
        cv_texture t;
        CHECK_OK(cv_texture_create(
            ctx,
            &(cv_texture_desc){ .width = 17, .height = 9, .format = (cv_format)f, .usage = usage, .label = "format" },
            &t));
        cv_result r = cv_device_load(dev, cv_any(t));
        if (r != CV_OK)
            fprintf(stderr, "%s: %s\n", cv_format_name((cv_format)f), cv_last_error());
        CHECK_OK(r);
        /* A texel written and read back unchanged. */
        uint8_t texel[16], back[16];
        for (int i = 0; i < 16; i++)
            texel[i] = (uint8_t)(0x30 + i);
        if (depth)
            memcpy(texel, &(float){ 0.375f }, 4);
        CHECK_OK(cv_device_write_texture(dev, t, (cv_rect){ 16, 8, 1, 1 }, texel));
        CHECK_OK(cv_device_read_texture(dev, t, (cv_rect){ 16, 8, 1, 1 }, back));
        CHECK(memcmp(texel, back, cv_format_bytes((cv_format)f)) == 0);
        CHECK_OK(cv_texture_destroy(ctx, t));
    }
    /* The context refuses depth+storage before a backend sees it; the backend
     * checks the adapter's format features itself and names what is missing. */
    const cv_backend *backend = cv_vulkan_backend();
    cv_resource_desc desc = { .type = CV_HANDLE_TEXTURE,
                              .texture = { .width = 8,
                                           .height = 8,
                                           .format = CV_FORMAT_D32F,
                                           .usage = CV_TEXTURE_USAGE_STORAGE,
                                           .label = "depth-storage" } };
    void *obj = NULL;
    cv_result r = backend->resource_create(cv_device_backend_data(dev), 1, &desc, NULL, &obj);
    if (vkt_is_lavapipe() || r != CV_OK) { /* lavapipe lacks depth storage; NVIDIA has it */
        CHECK_EQ_INT(r, CV_ERROR_UNSUPPORTED);
        CHECK(strstr(cv_last_error(), "depth-storage") != NULL && strstr(cv_last_error(), "storage") != NULL);
        CHECK(obj == NULL);
    } else {
        backend->resource_destroy(cv_device_backend_data(dev), CV_HANDLE_TEXTURE, obj);
    }
}

int main(void) {
    cv_context *ctx;
    cv_device *dev = NULL;
    CHECK_OK(cv_context_create(NULL, &ctx));
    CHECK_OK(vkt_device(ctx, vkt_adapter(), "resources", &dev));
    if (!dev) {
        cv_context_destroy(ctx); /* with any device it made */
        return check_report("vk_resources");
    }
    test_registry(ctx, dev);
    test_formats(ctx, dev);
    cv_vulkan_memory_stats stats;
    CHECK_OK(cv_vulkan_get_memory_stats(dev, &stats));
    CHECK_EQ_INT(stats.images + stats.pipelines, 0);
    cv_context_destroy(ctx);
    return vkt_report("vk_resources");
}
