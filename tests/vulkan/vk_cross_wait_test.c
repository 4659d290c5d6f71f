/* How a GPU waits for another device's ticket (vk_cross_wait.h): through an
 * imported semaphore where the pair allows it, else through the bridge.
 *   - the decision as pure functions of fabricated properties: which
 *     external semaphore properties make a device capable (and what a lacking
 *     one reports), the per-device choice, the per-pair UUID check;
 *     cv_parse_word_named, with which programs read the backend's switches
 *     (the message listing the words);
 *   - on the adapter: the cross_wait option IMPORT where the device cannot import
 *     (lavapipe lacks VK_KHR_external_semaphore_fd) fails with
 *     CV_ERROR_UNSUPPORTED naming the device and what it lacks, and changes
 *     nothing (no device is left, the next creation works); a bad value is
 *     refused; device info says which way is in use;
 *   - with each mode the adapter accepts (bridge, auto, and import where it
 *     can), a ping-pong through two rings between two virtual GPUs, 12 rounds
 *     with no host wait between them, is byte-exact. On lavapipe that is the
 *     bridge; on a GPU with the extension, the import path too. */
#include <stdlib.h>
#include <string.h>

#include "corvid/transfer.h"
#include "vk_cross_wait.h"
#include "corvid/parse.h"
#include "vk_test.h"

static void pure_decisions(void) {
    /* cv_parse_word_named (corvid/parse.h), with which programs read the backend's switches. */
    static const char *const one[] = { "on" }, *const two[] = { "a", "b" };
    uint32_t k = 7;
    CHECK_OK(cv_parse_word_named("X", "b", two, 2, &k));
    CHECK_EQ_INT(k, 1);
    CHECK_RESULT(cv_parse_word_named("CORVID_ONE", "off", one, 1, &k), CV_ERROR_INVALID_ARGUMENT);
    CHECK_EQ_INT(k, 1);
    CHECK(strcmp(cv_last_error(), "CORVID_ONE='off': expected on") == 0);
    CHECK_RESULT(cv_parse_word_named("X", "c", two, 2, &k), CV_ERROR_INVALID_ARGUMENT);
    CHECK(strcmp(cv_last_error(), "X='c': expected a or b") == 0);
    CHECK_RESULT(cv_parse_word_named("X", NULL, two, 2, &k), CV_ERROR_INVALID_ARGUMENT);

    const VkExternalSemaphoreHandleTypeFlags fd = VK_EXTERNAL_SEMAPHORE_HANDLE_TYPE_OPAQUE_FD_BIT;
    const VkExternalSemaphoreFeatureFlags ex = VK_EXTERNAL_SEMAPHORE_FEATURE_EXPORTABLE_BIT,
                                          im = VK_EXTERNAL_SEMAPHORE_FEATURE_IMPORTABLE_BIT;
    VkExternalSemaphoreProperties full = { .sType = VK_STRUCTURE_TYPE_EXTERNAL_SEMAPHORE_PROPERTIES,
                                           .exportFromImportedHandleTypes = fd,
                                           .compatibleHandleTypes = fd,
                                           .externalSemaphoreFeatures = ex | im };
    char missing[96] = "junk";
    CHECK(vk_cross_wait_capable(true, &full, missing, sizeof(missing)));
    CHECK(missing[0] == '\0');
    CHECK(!vk_cross_wait_capable(false, &full, missing, sizeof(missing)));
    CHECK(strcmp(missing, "VK_KHR_external_semaphore_fd") == 0);
    CHECK(!vk_cross_wait_capable(true, NULL, missing, sizeof(missing)));
    VkExternalSemaphoreProperties p = full;
    p.compatibleHandleTypes = VK_EXTERNAL_SEMAPHORE_HANDLE_TYPE_SYNC_FD_BIT;
    CHECK(!vk_cross_wait_capable(true, &p, missing, sizeof(missing)));
    CHECK(strstr(missing, "opaque-fd timeline") != NULL);
    p = full;
    p.externalSemaphoreFeatures = im;
    CHECK(!vk_cross_wait_capable(true, &p, missing, sizeof(missing)));
    CHECK(strcmp(missing, "exportable opaque-fd timeline semaphores") == 0);
    p = full;
    p.externalSemaphoreFeatures = ex;
    CHECK(!vk_cross_wait_capable(true, &p, missing, sizeof(missing)));
    CHECK(strcmp(missing, "importable opaque-fd timeline semaphores") == 0);
    p = full;
    p.externalSemaphoreFeatures = 0; /* what a driver reports for timeline semaphores it cannot share */
    CHECK(!vk_cross_wait_capable(true, &p, missing, sizeof(missing)));

    bool import = true;
    CHECK_OK(vk_cross_wait_decide(CV_VULKAN_CROSS_WAIT_AUTO, true, "", "g0", &import));
    CHECK(import);
    CHECK_OK(vk_cross_wait_decide(CV_VULKAN_CROSS_WAIT_BRIDGE, true, "", "g0", &import));
    CHECK(!import);
    import = true;
    CHECK_OK(vk_cross_wait_decide(CV_VULKAN_CROSS_WAIT_AUTO, false, "VK_KHR_external_semaphore_fd", "g0", &import));
    CHECK(!import);
    CHECK_OK(vk_cross_wait_decide(CV_VULKAN_CROSS_WAIT_IMPORT, true, "", "g0", &import));
    CHECK(import);
    CHECK_RESULT(vk_cross_wait_decide(CV_VULKAN_CROSS_WAIT_IMPORT, false, "VK_KHR_external_semaphore_fd", "g0",
                                      &import),
                 CV_ERROR_UNSUPPORTED);
    CHECK(!import);
    CHECK(strstr(cv_last_error(), "device 'g0'") != NULL);
    CHECK(strstr(cv_last_error(), "VK_KHR_external_semaphore_fd") != NULL);

    uint8_t drv[VK_UUID_SIZE] = { 1, 2, 3 }, dev[VK_UUID_SIZE] = { 9, 8, 7 };
    uint8_t drv2[VK_UUID_SIZE], dev2[VK_UUID_SIZE];
    memcpy(drv2, drv, sizeof(drv2));
    memcpy(dev2, dev, sizeof(dev2));
    CHECK(vk_cross_wait_same_device(drv, dev, drv2, dev2));
    dev2[15] = 1;
    CHECK(!vk_cross_wait_same_device(drv, dev, drv2, dev2));
    dev2[15] = 0;
    drv2[0] = 0;
    CHECK(!vk_cross_wait_same_device(drv, dev, drv2, dev2));
}

/* Two virtual GPUs of the adapter under the mode in force (NULL: refused, as checked by the caller). */
/* Two virtual GPUs of the test adapter; `validation` as the tests use it (on),
 * except for the forced import path: the validation layer (1.3.239) never sees
 * another VkDevice signal an imported semaphore and reports the submissions
 * that waited on one as pending forever (vk_cross_wait.c), so the import
 * ping-pong runs without it and proves itself by its bytes. */
static cv_result two_gpus_validated(cv_context *ctx, cv_device *gpu[2], bool validation, cv_vulkan_cross_wait mode) {
    /* The waits between separate VkDevices (auto would share one VkDevice on
     * a GPU with several queues: vk_shared_device tests that). */
    cv_vulkan_device_options options = { .vgpu_device = CV_VULKAN_VGPU_SEPARATE, .cross_wait = mode };
    cv_vulkan_gpu_table table;
    cv_result r = cv_vulkan_gpu_table_build(
        &(cv_vulkan_gpu_config){ .virtual_per_adapter = 2, .adapters = vkt_adapter(), .device = options }, &table);
    return r == CV_OK ? cv_vulkan_create_devices(ctx, &table, validation, gpu) : r;
}

static cv_result two_gpus(cv_context *ctx, cv_device *gpu[2], cv_vulkan_cross_wait mode) {
    return two_gpus_validated(ctx, gpu, true, mode);
}

enum { SIZE = 40000, ROUNDS = 12 };

/* Round k: A's range k -> B's range k (ring ab), then B's range k -> A's range k+1 (ring ba), all queued
 * without a host wait: A's range ROUNDS must end up as the original range 0, and every range in between. */
static void ping_pong(cv_context *ctx, cv_device *a, cv_device *b, const char *expect_wait) {
    CHECK(strcmp(cv_device_get_info(a)->cross_wait, expect_wait) == 0);
    CHECK(strcmp(cv_device_get_info(b)->cross_wait, expect_wait) == 0);
    cv_transfer_ring *ab = NULL, *ba = NULL;
    CHECK_OK(cv_transfer_ring_create(a, b, 4096, 2, &ab));
    CHECK_OK(cv_transfer_ring_create(b, a, 4096, 3, &ba));
    cv_buffer buf = { 0 };
    cv_buffer_desc d = { .size = (uint64_t)SIZE * (ROUNDS + 1), .label = "ping-pong" };
    CHECK_OK(cv_buffer_create(ctx, &d, &buf));
    CHECK_OK(cv_device_load(a, cv_any(buf)));
    CHECK_OK(cv_device_load(b, cv_any(buf)));
    uint8_t *init = malloc(d.size), *back = malloc(d.size);
    for (uint64_t i = 0; i < d.size; i++)
        init[i] = (uint8_t)(i * 131 + i / 977);
    CHECK_OK(cv_device_write_buffer(a, buf, 0, d.size, init));
    memset(back, 0x5a, d.size); /* B starts with other bytes */
    CHECK_OK(cv_device_write_buffer(b, buf, 0, d.size, back));
    cv_transfer_async t = { 0 };
    for (uint32_t k = 0; k < ROUNDS && ab && ba; k++) {
        CHECK_OK(cv_transfer_buffer_async(ab, buf, (uint64_t)k * SIZE, buf, (uint64_t)k * SIZE, SIZE, &t));
        CHECK_OK(cv_transfer_buffer_async(ba, buf, (uint64_t)k * SIZE, buf, (uint64_t)(k + 1) * SIZE, SIZE, &t));
    }
    if (t.dst_ticket)
        CHECK_OK(cv_device_wait(a, t.dst_ticket, UINT64_MAX));
    CHECK_OK(cv_device_read_buffer(a, buf, 0, d.size, back));
    for (uint32_t k = 0; k <= ROUNDS; k++)
        CHECK(memcmp(back + (uint64_t)k * SIZE, init, SIZE) == 0);
    cv_transfer_ring_destroy(ab);
    cv_transfer_ring_destroy(ba);
    cv_buffer_destroy(ctx, buf);
    free(init);
    free(back);
}

int main(void) {
    unsetenv("CORVID_TRANSFER_PATH");
    pure_decisions();
    cv_context *ctx;
    CHECK_OK(cv_context_create(NULL, &ctx));
    cv_device *gpu[2] = { NULL, NULL };

    /* A bad value: refused, nothing made. */
    CHECK_RESULT(two_gpus(ctx, gpu, (cv_vulkan_cross_wait)9), CV_ERROR_INVALID_ARGUMENT);
    CHECK(strstr(cv_last_error(), "cross_wait") != NULL);
    CHECK(!gpu[0] && !gpu[1]);
    CHECK_EQ_INT(cv_live_devices(), 0);

    /* import: either every device can (a GPU with the extension), or creation fails cleanly. */
    cv_result r = two_gpus_validated(ctx, gpu, vkt_is_lavapipe(), CV_VULKAN_CROSS_WAIT_IMPORT);
    if (vkt_is_lavapipe()) {
        CHECK_EQ_INT(r, CV_ERROR_UNSUPPORTED);
        CHECK(strstr(cv_last_error(), "cross_wait import") != NULL);
        CHECK(strstr(cv_last_error(), "VK_KHR_external_semaphore_fd") != NULL);
        CHECK(strstr(cv_last_error(), "device '") != NULL);
    }
    if (r == CV_OK) {
        fprintf(stderr, "import path available: ping-pong through imported semaphores\n");
        ping_pong(ctx, gpu[0], gpu[1], "import");
        cv_device_destroy(gpu[1]); /* the source of the last imports first: payloads outlive it */
        cv_device_destroy(gpu[0]);
        gpu[0] = gpu[1] = NULL;
    } else {
        fprintf(stderr, "import refused as expected: %s\n", cv_last_error());
        CHECK(!gpu[0] && !gpu[1]);
        CHECK_EQ_INT(cv_live_devices(), 0);
    }

    /* bridge, then auto (the default): the same bytes. */
    const cv_vulkan_cross_wait modes[] = { CV_VULKAN_CROSS_WAIT_BRIDGE, CV_VULKAN_CROSS_WAIT_AUTO };
    for (int m = 0; m < 2; m++) {
        CHECK_OK(two_gpus(ctx, gpu, modes[m]));
        if (gpu[0] && gpu[1]) {
            /* (auto under the validation layer is the bridge everywhere: vk_cross_wait.c) */
            const char *expect = "bridge";
            ping_pong(ctx, gpu[0], gpu[1], expect);
        }
        cv_device_destroy(gpu[0]);
        cv_device_destroy(gpu[1]);
        gpu[0] = gpu[1] = NULL;
    }
    cv_context_destroy(ctx);
    CHECK_NOTHING_LIVE();
    return vkt_report("vk_cross_wait");
}
