/* Adapter enumeration and selection: by purpose, by index, by case-insensitive
 * name substring ("llvmpipe"), and a clear NOT_FOUND (naming the adapters
 * there are) for a name or index that matches nothing, with no device left
 * behind. Also the GPU table: flag parsing and the index -> adapter mapping. */
#include <ctype.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "env_vulkan.h"
#include "vk_test.h"

static void test_adapters(void) {
    cv_vulkan_adapter_info adapters[8];
    uint32_t count = 0;
    CHECK_OK(cv_vulkan_adapters(adapters, 8, &count));
    CHECK(count >= 1);
    /* The test adapter: found by a name substring, in any letter case. */
    uint32_t tested = UINT32_MAX;
    for (uint32_t i = 0; i < count && i < 8; i++) {
        CHECK_EQ_INT(adapters[i].index, i);
        if (tested == UINT32_MAX && strcasestr(adapters[i].name, vkt_adapter())) {
            tested = i;
            CHECK(adapters[i].usable);
            if (vkt_is_lavapipe()) {
                CHECK_EQ_INT(adapters[i].type, CV_VULKAN_ADAPTER_CPU);
                CHECK(!adapters[i].separate_compute_queue && !adapters[i].separate_copy_queue);
            }
        }
    }
    CHECK(tested != UINT32_MAX);

    char upper[64];
    snprintf(upper, sizeof(upper), "%s", vkt_adapter());
    for (char *c = upper; *c; c++)
        *c = (char)toupper((unsigned char)*c);
    uint32_t index = UINT32_MAX;
    CHECK_OK(cv_vulkan_find_adapter(vkt_adapter(), &index));
    CHECK_EQ_INT(index, tested);
    index = UINT32_MAX;
    CHECK_OK(cv_vulkan_find_adapter(upper, &index));
    CHECK_EQ_INT(index, tested);
    CHECK_OK(cv_vulkan_find_adapter("0", &index));
    CHECK_EQ_INT(index, 0);
    if (vkt_is_lavapipe()) {
        CHECK_OK(cv_vulkan_choose_adapter(CV_VULKAN_PURPOSE_SOFTWARE, &index));
        CHECK_EQ_INT(index, tested);
    }
    CHECK_OK(cv_vulkan_choose_adapter(CV_VULKAN_PURPOSE_RENDER, &index));
    CHECK(index < count && adapters[index].usable);
    CHECK_OK(cv_vulkan_find_adapter("", &index));

    index = 77;
    CHECK_RESULT(cv_vulkan_find_adapter("no-such-gpu", &index), CV_ERROR_NOT_FOUND);
    CHECK(strstr(cv_last_error(), "no-such-gpu") != NULL);
    CHECK(strstr(cv_last_error(), adapters[0].name) != NULL); /* lists what there is */
    CHECK_EQ_INT(index, 77);
    CHECK_RESULT(cv_vulkan_find_adapter("9", &index), CV_ERROR_NOT_FOUND);
    CHECK(strstr(cv_last_error(), "index 9") != NULL);
}

static void test_devices(void) {
    cv_context *ctx;
    CHECK_OK(cv_context_create(NULL, &ctx));
    cv_device *by_name = NULL, *by_index = NULL, *missing = NULL;
    CHECK_OK(vkt_device(ctx, vkt_adapter(), "by-name", &by_name));
    CHECK_OK(vkt_device(ctx, "0", "by-index", &by_index));
    if (by_name && by_index) {
        const cv_device_info *a = cv_device_get_info(by_name), *b = cv_device_get_info(by_index);
        CHECK(strcasestr(a->name, vkt_adapter()) != NULL);
        CHECK(strcmp(a->backend, "vulkan") == 0);
        CHECK_EQ_INT(b->adapter_index, 0);
        if (vkt_is_lavapipe()) {
            CHECK(strstr(a->driver, "llvmpipe") != NULL);
            CHECK(!a->separate_compute_queue && !a->separate_copy_queue);
        }
        CHECK(a->max_storage_buffer_range >= (1u << 27));
        CHECK(a->max_dispatch[0] >= 65535 && a->max_dispatch[1] >= 65535 && a->max_dispatch[2] >= 65535);
        CHECK(strcmp(cv_device_label(by_name), "by-name") == 0);
    }
    CHECK_RESULT(vkt_device(ctx, "no-such-gpu", "missing", &missing), CV_ERROR_NOT_FOUND);
    CHECK(strstr(cv_last_error(), "no-such-gpu") != NULL);
    CHECK(missing == NULL);
    CHECK_RESULT(vkt_device(ctx, "12", "missing", &missing), CV_ERROR_NOT_FOUND);
    /* Memory stats belong to Vulkan devices only. */
    cv_device *mock = NULL;
    CHECK_OK(cv_device_create(ctx, cv_mock_backend(), NULL, &mock));
    cv_vulkan_memory_stats stats;
    CHECK_RESULT(cv_vulkan_get_memory_stats(mock, &stats), CV_ERROR_INVALID_ARGUMENT);
    if (by_name)
        CHECK_OK(cv_vulkan_get_memory_stats(by_name, &stats));
    cv_context_destroy(ctx);
}

static void test_gpu_args(void) {
    char a0[] = "app", a1[] = "--virtual-gpus", a2[] = "3", a3[] = "--keep", a4[] = "--gpus=5", a5[] = "scene.gltf",
         a6[] = "--adapters", a7[] = "llvmpipe";
    char *argv[] = { a0, a1, a2, a3, a4, a5, a6, a7, NULL };
    int argc = 8;
    cv_vulkan_gpu_config config = { 0 };
    CHECK_OK(cv_env_vulkan_gpu_args(&argc, argv, &config));
    CHECK_EQ_INT(argc, 3);
    CHECK(strcmp(argv[0], "app") == 0 && strcmp(argv[1], "--keep") == 0 && strcmp(argv[2], "scene.gltf") == 0);
    CHECK(argv[3] == NULL);
    CHECK_EQ_INT(config.virtual_per_adapter, 3);
    CHECK_EQ_INT(config.total, 5);
    CHECK(config.adapters && strcmp(config.adapters, "llvmpipe") == 0);

    char b1[] = "--gpus", b2[] = "0";
    char *bad[] = { a0, b1, b2, NULL };
    int bad_argc = 3;
    cv_vulkan_gpu_config unchanged = { .virtual_per_adapter = 2 };
    CHECK_RESULT(cv_env_vulkan_gpu_args(&bad_argc, bad, &unchanged), CV_ERROR_INVALID_ARGUMENT);
    CHECK_EQ_INT(bad_argc, 3);
    CHECK_EQ_INT(unchanged.virtual_per_adapter, 2);
    char *missing[] = { a0, a1, NULL };
    int missing_argc = 2;
    CHECK_RESULT(cv_env_vulkan_gpu_args(&missing_argc, missing, &unchanged), CV_ERROR_INVALID_ARGUMENT);
}

static void test_gpu_table(void) {
    cv_vulkan_gpu_table t;
    CHECK_OK(cv_vulkan_gpu_table_build(&(cv_vulkan_gpu_config){ .virtual_per_adapter = 4 }, &t));
    CHECK_EQ_INT(t.count, 4);
    for (uint32_t i = 0; i < t.count; i++) {
        CHECK_EQ_INT(t.gpus[i].adapter, 0);
        CHECK_EQ_INT(t.gpus[i].instance, i);
    }
    /* An adapter listed twice counts twice; total overrides per-adapter counts. */
    char two[80];
    snprintf(two, sizeof(two), "%s,0", vkt_adapter());
    CHECK_OK(cv_vulkan_gpu_table_build(&(cv_vulkan_gpu_config){ .total = 3, .adapters = two }, &t));
    CHECK_EQ_INT(t.count, 3);
    for (uint32_t i = 0; i < 3; i++)
        CHECK(t.gpus[i].adapter == 0 && t.gpus[i].instance == i);
    snprintf(two, sizeof(two), "%s,nope", vkt_adapter());
    CHECK_RESULT(cv_vulkan_gpu_table_build(&(cv_vulkan_gpu_config){ .adapters = two }, &t), CV_ERROR_NOT_FOUND);
    CHECK_RESULT(cv_vulkan_gpu_table_build(&(cv_vulkan_gpu_config){ .virtual_per_adapter = 65 }, &t),
                 CV_ERROR_LIMIT_EXCEEDED);
    /* The table carries the config's device options to every device it makes. */
    CHECK_OK(
        cv_vulkan_gpu_table_build(&(cv_vulkan_gpu_config){ .device = { .link_queue = CV_VULKAN_LINK_QUEUE_COPY } },
                                  &t));
    CHECK_EQ_INT(t.options.link_queue, CV_VULKAN_LINK_QUEUE_COPY);
    /* The library never reads the environment; a program maps it onto the config (env_vulkan.h). */
    setenv("CORVID_VIRTUAL_GPUS", "2", 1);
    cv_vulkan_gpu_config c = { 0 };
    CHECK_OK(cv_vulkan_gpu_table_build(&c, &t));
    CHECK_EQ_INT(t.count, 1);
    CHECK_OK(cv_env_vulkan_gpu_config(&c));
    CHECK_OK(cv_vulkan_gpu_table_build(&c, &t));
    CHECK_EQ_INT(t.count, 2);
    setenv("CORVID_VIRTUAL_GPUS", "two", 1);
    cv_vulkan_gpu_config fresh = { 0 };
    CHECK_RESULT(cv_env_vulkan_gpu_config(&fresh), CV_ERROR_INVALID_ARGUMENT);
    CHECK(strstr(cv_last_error(), "CORVID_VIRTUAL_GPUS: 'two'") != NULL);
    CHECK_EQ_INT(fresh.virtual_per_adapter, 0);
    fresh.total = 3; /* an explicit count wins: the variable is not even read */
    CHECK_OK(cv_env_vulkan_gpu_config(&fresh));
    CHECK_EQ_INT(fresh.virtual_per_adapter, 0);
    unsetenv("CORVID_VIRTUAL_GPUS");
}

/* The device options' variables (env_vulkan.h): words into enums, a bad one named and nothing changed. */
static void test_env_options(void) {
    setenv("CORVID_VGPU_DEVICE", "shared", 1);
    setenv("CORVID_CROSS_WAIT", "bridge", 1);
    setenv("CORVID_LINK_QUEUE", "graphics", 1);
    setenv("CORVID_TRACE_PATH", "compute", 1);
    setenv("CORVID_VK_SYNC_VALIDATION", "0", 1);
    cv_vulkan_device_options o = { 0 };
    CHECK_OK(cv_env_vulkan_options(&o));
    CHECK_EQ_INT(o.vgpu_device, CV_VULKAN_VGPU_SHARED);
    CHECK_EQ_INT(o.cross_wait, CV_VULKAN_CROSS_WAIT_BRIDGE);
    CHECK_EQ_INT(o.link_queue, CV_VULKAN_LINK_QUEUE_GRAPHICS);
    CHECK_EQ_INT(o.trace_path, CV_VULKAN_TRACE_COMPUTE);
    CHECK_EQ_INT(o.sync_validation, CV_VULKAN_SYNC_VALIDATION_OFF);
    setenv("CORVID_LINK_QUEUE", "gpu", 1);
    cv_vulkan_device_options unchanged = { 0 };
    CHECK_RESULT(cv_env_vulkan_options(&unchanged), CV_ERROR_INVALID_ARGUMENT);
    CHECK(strstr(cv_last_error(), "CORVID_LINK_QUEUE='gpu': expected compute, graphics or copy") != NULL);
    CHECK_EQ_INT(unchanged.vgpu_device, CV_VULKAN_VGPU_AUTO);
    const char *names[] = { "CORVID_VGPU_DEVICE", "CORVID_CROSS_WAIT", "CORVID_LINK_QUEUE", "CORVID_TRACE_PATH",
                            "CORVID_VK_SYNC_VALIDATION" };
    for (int i = 0; i < 5; i++)
        unsetenv(names[i]);
    /* Unset: the fields stay as the program set them. */
    o = (cv_vulkan_device_options){ .cross_wait = CV_VULKAN_CROSS_WAIT_IMPORT };
    CHECK_OK(cv_env_vulkan_options(&o));
    CHECK_EQ_INT(o.cross_wait, CV_VULKAN_CROSS_WAIT_IMPORT);
    /* A value outside its enum fails device creation, naming the field. */
    cv_context *ctx;
    CHECK_OK(cv_context_create(NULL, &ctx));
    cv_vulkan_device_options bad = { .vgpu_device = (cv_vulkan_vgpu_device)7 };
    cv_device *dev = NULL;
    CHECK_RESULT(cv_device_create(ctx, cv_vulkan_backend(),
                                  &(cv_device_desc){
                                      .adapter = vkt_adapter(), .label = "bad", .backend_options = &bad },
                                  &dev),
                 CV_ERROR_INVALID_ARGUMENT);
    CHECK(strstr(cv_last_error(), "vgpu_device") != NULL && dev == NULL);
    cv_context_destroy(ctx);
}

int main(void) {
    test_adapters();
    test_devices();
    test_gpu_args();
    test_gpu_table();
    test_env_options();
    return vkt_report("vk_adapter");
}
