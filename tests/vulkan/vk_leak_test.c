/* 10,000 resources created, loaded, partly used by submitted work and
 * destroyed, in waves (so the block allocator splits, merges and frees blocks):
 * afterwards the device's memory statistics and Vulkan object counts are back
 * at their baseline, the context holds no handles and the device has nothing
 * loaded; after the device is gone no VkDeviceMemory is left in the process. */
#include <stdlib.h>
#include <string.h>

#include "vk_test.h"

enum { TOTAL = 10000, WAVE = 500 };

static const cv_format formats[] = {
    CV_FORMAT_RGBA8_UNORM, CV_FORMAT_RGBA16F,    CV_FORMAT_RGBA32F,  CV_FORMAT_R32F,
    CV_FORMAT_RG16F,       CV_FORMAT_R11G11B10F, CV_FORMAT_R32_UINT, CV_FORMAT_D32F
};

int main(void) {
    cv_context *ctx;
    cv_device *dev = NULL;
    CHECK_OK(cv_context_create(NULL, &ctx));
    CHECK_OK(vkt_device(ctx, NULL, "leaks", &dev));
    if (!dev) {
        cv_context_destroy(ctx); /* with any device it made */
        return check_report("vk_leak");
    }
    cv_vulkan_memory_stats base;
    CHECK_OK(cv_vulkan_get_memory_stats(dev, &base));
    CHECK_EQ_INT(base.allocation_count, 0);

    cv_pipeline fill = vkt_pipeline(ctx, dev, "test.fill_u32");
    cv_cmdlist list;
    CHECK_OK(cv_cmdlist_create(ctx, &list));
    cv_handle *wave = calloc(WAVE, sizeof(*wave));
    uint32_t created = 0, peak_blocks = 0;
    uint32_t seed = 1;
    while (created < TOTAL) {
        for (uint32_t i = 0; i < WAVE; i++, created++) {
            seed = seed * 1103515245u + 12345u;
            uint32_t r = seed >> 8;
            if (i % 10 < 6) {
                cv_buffer b;
                uint64_t size = 256ull << (r % 9); /* 256 B .. 64 KiB */
                if (i % 97 == 0)
                    size = 40ull << 20; /* larger than half a block: its own */
                CHECK_OK(cv_buffer_create(ctx, &(cv_buffer_desc){ .size = size }, &b));
                wave[i] = cv_any(b);
            } else if (i % 10 < 9) {
                cv_texture t;
                cv_format f = formats[r % 8];
                uint32_t usage = f == CV_FORMAT_D32F ? 0 : CV_TEXTURE_USAGE_SAMPLED | CV_TEXTURE_USAGE_STORAGE;
                CHECK_OK(cv_texture_create(ctx,
                                           &(cv_texture_desc){ .width = 8 + r % 57,
                                                               .height = 8 + (r >> 6) % 41,
                                                               .format = f,
                                                               .usage = usage },
                                           &t));
                wave[i] = cv_any(t);
            } else {
                cv_sampler s;
                CHECK_OK(cv_sampler_create(ctx, &(cv_sampler_desc){ .filter = r % 2 }, &s));
                wave[i] = cv_any(s);
            }
            CHECK_OK(cv_device_load(dev, wave[i]));
        }
        /* Some of the wave's buffers are in flight when they are destroyed. */
        cv_command_list *l;
        CHECK_OK(cv_cmdlist_begin(ctx, list, &l));
        for (uint32_t i = 0; i < WAVE; i += 50) {
            uint32_t push[2] = { i, 64 };
            cv_binding b = { .resource = wave[i] };
            cv_cmd_dispatch(l, CV_QUEUE_COMPUTE,
                            &(cv_dispatch_args){ .pipeline = fill,
                                                 .bindings = &b,
                                                 .bindings_count = 1,
                                                 .push = push,
                                                 .push_size = 8,
                                                 .groups_x = 1,
                                                 .groups_y = 1,
                                                 .groups_z = 1 });
        }
        CHECK_OK(cv_command_list_end(l));
        uint64_t ticket;
        CHECK_OK(cv_device_submit(dev, list, &ticket));
        cv_vulkan_memory_stats now;
        CHECK_OK(cv_vulkan_get_memory_stats(dev, &now));
        if (now.block_count > peak_blocks)
            peak_blocks = now.block_count;
        for (uint32_t i = 0; i < WAVE; i++)
            CHECK_OK(cv_destroy(ctx, wave[i]));
        CHECK_OK(cv_device_wait(dev, ticket, UINT64_MAX));
    }
    CHECK_EQ_INT(created, TOTAL);
    CHECK_OK(cv_pipeline_destroy(ctx, fill));
    CHECK_OK(cv_cmdlist_destroy(ctx, list));
    CHECK_OK(cv_device_wait_idle(dev));

    cv_vulkan_memory_stats end;
    CHECK_OK(cv_vulkan_get_memory_stats(dev, &end));
    printf("peak %u blocks; after: %u blocks (%llu bytes), %u allocations\n", peak_blocks, end.block_count,
           (unsigned long long)end.block_bytes, end.allocation_count);
    CHECK_EQ_INT(end.allocation_count, base.allocation_count);
    CHECK_EQ_INT(end.allocated_bytes, base.allocated_bytes);
    CHECK_EQ_INT(end.buffers, base.buffers);
    CHECK_EQ_INT(end.images, base.images);
    CHECK_EQ_INT(end.samplers, base.samplers);
    CHECK_EQ_INT(end.pipelines, base.pipelines);
    /* At most one empty block is kept per memory type and tiling. */
    CHECK(end.block_count <= 2);
    for (int t = CV_HANDLE_BUFFER; t < CV_HANDLE_TYPE_COUNT; t++)
        CHECK_EQ_INT(cv_context_live_count(ctx, (cv_handle_type)t), 0);
    CHECK_EQ_INT(cv_device_loaded_count(dev), 0);
    cv_device_destroy(dev);
    CHECK_EQ_INT(cv_vulkan_live_memory_blocks(), 0);
    free(wave);
    cv_context_destroy(ctx);
    return vkt_report("vk_leak");
}
