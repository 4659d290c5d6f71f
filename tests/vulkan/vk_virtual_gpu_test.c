/* Virtual multi-GPU: with CORVID_VIRTUAL_GPUS=3 (set by ctest) the GPU table
 * maps three virtual GPUs onto the one lavapipe adapter; three VkDevices are
 * created from it and driven from three threads at once, each loading its own
 * resources, recording, submitting and reading back compute work with its own
 * values, which must all come out exactly right. */
#include <pthread.h>
#include <stdlib.h>
#include <string.h>

#include "corvid/backend.h"
#include "env_vulkan.h"
#include "vk_test.h"

enum { N = 2048, ROUNDS = 20, W = 40, H = 24 };

typedef struct worker {
    cv_context *ctx;
    cv_device *dev;
    uint32_t index;
    int failures;
} worker;

static void *work(void *arg) {
    worker *w = arg;
    cv_context *ctx = w->ctx;
    cv_buffer x = { 0 }, y = { 0 };
    cv_texture tex = { 0 };
    cv_pipeline fill = { 0 }, saxpy = { 0 }, gradient = { 0 };
    cv_cmdlist list = { 0 };
    cv_command_list *l;
    bool ok = cv_buffer_create(ctx, &(cv_buffer_desc){ .size = 4 * N }, &x) == CV_OK &&
              cv_buffer_create(ctx, &(cv_buffer_desc){ .size = 4 * N }, &y) == CV_OK &&
              cv_texture_create(ctx,
                                &(cv_texture_desc){ .width = W,
                                                    .height = H,
                                                    .format = CV_FORMAT_RGBA32F,
                                                    .usage = CV_TEXTURE_USAGE_STORAGE },
                                &tex) == CV_OK &&
              cv_pipeline_create(ctx, "test.fill_u32", &fill) == CV_OK &&
              cv_pipeline_create(ctx, "test.saxpy", &saxpy) == CV_OK &&
              cv_pipeline_create(ctx, "test.gradient", &gradient) == CV_OK && cv_cmdlist_create(ctx, &list) == CV_OK;
    cv_handle handles[] = { cv_any(x), cv_any(y), cv_any(tex), cv_any(fill), cv_any(saxpy), cv_any(gradient) };
    for (size_t i = 0; ok && i < sizeof(handles) / sizeof(handles[0]); i++)
        ok = cv_device_load(w->dev, handles[i]) == CV_OK;
    float *hy = malloc(4 * N), *out = malloc(4 * N);
    float(*texels)[W][4] = malloc(W * H * 16);
    for (uint32_t round = 0; ok && round < ROUNDS; round++) {
        /* x[i] = bits(1.0) + seed + i reinterpreted; y = a x + y; gradient at a per-device origin. */
        uint32_t seed = w->index * 1000 + round;
        for (int i = 0; i < N; i++)
            hy[i] = (float)(i % 37) - 18.0f;
        ok = cv_device_write_buffer(w->dev, y, 0, 4 * N, hy) == CV_OK && cv_cmdlist_begin(ctx, list, &l) == CV_OK;
        if (!ok)
            break;
        uint32_t fill_push[2] = { 0x3f800000u + seed, N };
        struct {
            float a;
            uint32_t count;
        } saxpy_push = { (float)(w->index + 1), N };
        int32_t origin[2] = { (int32_t)(w->index * 100 + round), -(int32_t)round };
        cv_binding bx = { .resource = cv_any(x) }, bt = { .resource = cv_any(tex) };
        cv_binding xy[2] = { { .resource = cv_any(x) }, { .resource = cv_any(y) } };
        cv_cmd_dispatch(l, CV_QUEUE_COMPUTE,
                        &(cv_dispatch_args){ .pipeline = fill,
                                             .bindings = &bx,
                                             .bindings_count = 1,
                                             .push = fill_push,
                                             .push_size = 8,
                                             .groups_x = N / 64,
                                             .groups_y = 1,
                                             .groups_z = 1 });
        cv_cmd_dispatch(l, CV_QUEUE_COMPUTE,
                        &(cv_dispatch_args){ .pipeline = saxpy,
                                             .bindings = xy,
                                             .bindings_count = 2,
                                             .push = &saxpy_push,
                                             .push_size = 8,
                                             .groups_x = N / 64,
                                             .groups_y = 1,
                                             .groups_z = 1 });
        cv_cmd_dispatch(l, CV_QUEUE_COMPUTE,
                        &(cv_dispatch_args){ .pipeline = gradient,
                                             .bindings = &bt,
                                             .bindings_count = 1,
                                             .push = origin,
                                             .push_size = 8,
                                             .groups_x = W / 8,
                                             .groups_y = H / 8,
                                             .groups_z = 1 });
        uint64_t t;
        ok = cv_command_list_end(l) == CV_OK && cv_device_submit(w->dev, list, &t) == CV_OK &&
             cv_device_wait(w->dev, t, UINT64_MAX) == CV_OK &&
             cv_device_read_buffer(w->dev, y, 0, 4 * N, out) == CV_OK &&
             cv_device_read_texture(w->dev, tex, (cv_rect){ 0, 0, W, H }, texels) == CV_OK;
        for (uint32_t i = 0; ok && i < N; i++) {
            uint32_t bits = fill_push[0] + i;
            float xv;
            memcpy(&xv, &bits, 4);
            volatile float product = saxpy_push.a * xv;
            w->failures += out[i] != product + hy[i];
        }
        for (int py = 0; ok && py < H; py++)
            for (int px = 0; px < W; px++) {
                uint32_t gx = (uint32_t)(px + origin[0]), gy = (uint32_t)(py + origin[1]);
                w->failures += texels[py][px][0] != (float)(gx & 255u) / 256.0f ||
                               texels[py][px][1] != (float)(gy & 255u) / 256.0f ||
                               texels[py][px][2] != (float)((gx + gy) & 255u) / 256.0f;
            }
    }
    if (!ok)
        w->failures++;
    free(hy);
    free(out);
    free(texels);
    for (size_t i = 0; i < sizeof(handles) / sizeof(handles[0]); i++)
        if (handles[i].id)
            cv_destroy(ctx, handles[i]);
    if (list.id)
        cv_cmdlist_destroy(ctx, list);
    return NULL;
}

int main(void) {
    const char *env = getenv("CORVID_VIRTUAL_GPUS");
    CHECK(env && strcmp(env, "3") == 0);
    cv_vulkan_gpu_config config = { 0 };
    CHECK_OK(cv_env_vulkan_gpu_config(&config)); /* as a program: CORVID_VIRTUAL_GPUS, CORVID_VGPU_DEVICE */
    cv_vulkan_gpu_table table;
    CHECK_OK(cv_vulkan_gpu_table_build(&config, &table));
    CHECK_EQ_INT(table.count, 3);
    uint32_t lavapipe = UINT32_MAX;
    CHECK_OK(cv_vulkan_find_adapter(vkt_adapter(), &lavapipe));
    for (uint32_t i = 0; i < table.count; i++) {
        CHECK_EQ_INT(table.gpus[i].adapter, lavapipe);
        CHECK_EQ_INT(table.gpus[i].instance, i);
    }
    cv_context *ctx;
    CHECK_OK(cv_context_create(NULL, &ctx));
    cv_device *devices[3] = { NULL, NULL, NULL };
    CHECK_OK(cv_vulkan_create_devices(ctx, &table, true, devices));
    if (!devices[0]) {
        cv_context_destroy(ctx); /* with any device it made */
        return check_report("vk_virtual_gpu");
    }
    CHECK(cv_device_backend_data(devices[0]) != cv_device_backend_data(devices[1]));
    worker workers[3];
    pthread_t threads[3];
    for (uint32_t i = 0; i < 3; i++) {
        workers[i] = (worker){ .ctx = ctx, .dev = devices[i], .index = i };
        CHECK_EQ_INT(cv_device_get_info(devices[i])->adapter_index, lavapipe);
        pthread_create(&threads[i], NULL, work, &workers[i]);
    }
    for (uint32_t i = 0; i < 3; i++) {
        pthread_join(threads[i], NULL);
        CHECK_EQ_INT(workers[i].failures, 0);
        CHECK_EQ_INT(cv_device_loaded_count(devices[i]), 0);
    }
    cv_context_destroy(ctx);
    CHECK_EQ_INT(cv_vulkan_live_memory_blocks(), 0);
    return vkt_report("vk_virtual_gpu");
}
