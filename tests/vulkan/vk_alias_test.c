/* Zero-copy between virtual GPUs of one adapter (device.h: cv_device_load_alias,
 * cv_device_gpu_wait), on separate VkDevices (the lavapipe default) and, as
 * ctest's vk_alias_shared, on one VkDevice:
 *   - texels written on either device are the other's, both ways, and a half
 *     written by each lands side by side;
 *   - a GPU write on the alias is seen by the owner's next GPU work after
 *     cv_device_gpu_wait, with no host wait in between;
 *   - the alias keeps the memory alive after the owner unloads the texture;
 *   - every refusal (not shareable, not a texture, not loaded on the owner,
 *     already loaded, the same device, another backend, a ticket never
 *     submitted) names the problem and changes nothing. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "vk_test.h"

enum { W = 96, H = 40 };

static void fill(float *p, size_t n, uint32_t seed) {
    uint32_t x = seed * 2654435761u + 1;
    for (size_t i = 0; i < n; i++) {
        x = x * 1664525u + 1013904223u;
        p[i] = (float)(x >> 8) / 16777216.0f;
    }
}

static cv_texture shared_texture(cv_context *ctx, const char *label) {
    cv_texture t = { 0 };
    cv_texture_desc desc = { .width = W,
                             .height = H,
                             .format = CV_FORMAT_RGBA32F,
                             .usage = CV_TEXTURE_USAGE_STORAGE | CV_TEXTURE_USAGE_SAMPLED | CV_TEXTURE_USAGE_SHARED };
    snprintf(desc.label, sizeof(desc.label), "%s", label);
    CHECK_OK(cv_texture_create(ctx, &desc, &t));
    return t;
}

/* Host writes on each side are the other's texels. */
static void host_both_ways(cv_context *ctx, cv_device *a, cv_device *b) {
    cv_texture t = shared_texture(ctx, "both ways");
    CHECK_OK(cv_device_load(a, cv_any(t)));
    CHECK_OK(cv_device_load_alias(b, cv_any(t), a));
    CHECK(cv_device_has(b, cv_any(t)));
    size_t n = (size_t)W * H * 4;
    float *left = malloc(n * sizeof(float)), *right = malloc(n * sizeof(float)), *back = malloc(n * sizeof(float));
    fill(left, n, 1);
    fill(right, n, 2);
    /* a writes columns [0, 40), b columns [40, 96): one image holds both. */
    float *want = malloc(n * sizeof(float));
    for (uint32_t y = 0; y < H; y++)
        for (uint32_t x = 0; x < W; x++)
            memcpy(&want[(y * W + x) * 4], x < 40 ? &left[(y * 40 + x) * 4] : &right[(y * 56 + x - 40) * 4], 16);
    CHECK_OK(cv_device_write_texture(a, t, (cv_rect){ 0, 0, 40, H }, left));
    CHECK_OK(cv_device_write_texture(b, t, (cv_rect){ 40, 0, 56, H }, right));
    CHECK_OK(cv_device_read_texture(a, t, (cv_rect){ 0, 0, W, H }, back));
    CHECK(memcmp(back, want, n * sizeof(float)) == 0);
    memset(back, 0, n * sizeof(float));
    CHECK_OK(cv_device_read_texture(b, t, (cv_rect){ 0, 0, W, H }, back));
    CHECK(memcmp(back, want, n * sizeof(float)) == 0);
    /* The owner unloads: the alias still holds the memory and its texels. */
    CHECK_OK(cv_device_unload(a, cv_any(t)));
    memset(back, 0, n * sizeof(float));
    CHECK_OK(cv_device_read_texture(b, t, (cv_rect){ 0, 0, W, H }, back));
    CHECK(memcmp(back, want, n * sizeof(float)) == 0);
    CHECK_OK(cv_texture_destroy(ctx, t));
    free(left);
    free(right);
    free(back);
    free(want);
}

static float gradient_ref(uint32_t coord) { return (float)(coord & 255u) / 256.0f; }

/* b's compute pass writes the alias; a waits for it on the GPU and copies the
 * texels into a texture of its own; the host reads that copy. */
static void gpu_ordering(cv_context *ctx, cv_device *a, cv_device *b) {
    cv_texture t = shared_texture(ctx, "ordered");
    cv_texture copy = vkt_texture(ctx, a, W, H, CV_FORMAT_RGBA32F, CV_TEXTURE_USAGE_STORAGE, "copy");
    CHECK_OK(cv_device_load(a, cv_any(t)));
    CHECK_OK(cv_device_load_alias(b, cv_any(t), a));
    cv_pipeline gradient = vkt_pipeline(ctx, b, "test.gradient");
    cv_cmdlist write_list, copy_list;
    CHECK_OK(cv_cmdlist_create(ctx, &write_list));
    CHECK_OK(cv_cmdlist_create(ctx, &copy_list));
    for (int round = 0; round < 3; round++) {
        int32_t push[2] = { 17 * round, 5 + round };
        cv_command_list *l;
        CHECK_OK(cv_cmdlist_begin(ctx, write_list, &l));
        cv_binding binding = { .resource = cv_any(t) };
        cv_cmd_dispatch(l, CV_QUEUE_COMPUTE,
                        &(cv_dispatch_args){ .pipeline = gradient,
                                             .bindings = &binding,
                                             .bindings_count = 1,
                                             .push = push,
                                             .push_size = 8,
                                             .groups_x = (W + 7) / 8,
                                             .groups_y = (H + 7) / 8,
                                             .groups_z = 1 });
        CHECK_OK(cv_command_list_end(l));
        uint64_t written = 0, waited = 0, copied = 0;
        CHECK_OK(cv_device_submit(b, write_list, &written));
        CHECK_OK(cv_device_gpu_wait(a, b, written, &waited));
        CHECK(waited > 0);
        CHECK_OK(cv_cmdlist_begin(ctx, copy_list, &l));
        cv_cmd_copy_texture(l, CV_QUEUE_COMPUTE,
                            &(cv_copy_texture_args){ .src = t, .dst = copy, .width = W, .height = H });
        CHECK_OK(cv_command_list_end(l));
        CHECK_OK(cv_device_submit(a, copy_list, &copied));
        CHECK(copied > waited);
        float *back = malloc((size_t)W * H * 16);
        CHECK_OK(cv_device_read_texture(a, copy, (cv_rect){ 0, 0, W, H }, back));
        int wrong = 0;
        for (uint32_t y = 0; y < H; y++)
            for (uint32_t x = 0; x < W; x++) {
                const float *p = &back[(y * W + x) * 4];
                uint32_t gx = x + (uint32_t)push[0], gy = y + (uint32_t)push[1];
                wrong += p[0] != gradient_ref(gx) || p[1] != gradient_ref(gy) || p[2] != gradient_ref(gx + gy) ||
                         p[3] != 1.0f;
            }
        CHECK_EQ_INT(wrong, 0);
        free(back);
        CHECK_OK(cv_device_wait_idle(b));
    }
    CHECK_OK(cv_cmdlist_destroy(ctx, write_list));
    CHECK_OK(cv_cmdlist_destroy(ctx, copy_list));
    CHECK_OK(cv_pipeline_destroy(ctx, gradient));
    CHECK_OK(cv_texture_destroy(ctx, copy));
    CHECK_OK(cv_texture_destroy(ctx, t));
}

static void refusals(cv_context *ctx, cv_device *a, cv_device *b) {
    cv_texture plain = vkt_texture(ctx, a, W, H, CV_FORMAT_RGBA32F, CV_TEXTURE_USAGE_STORAGE, "plain");
    cv_texture t = shared_texture(ctx, "refused");
    cv_buffer buf = vkt_buffer(ctx, a, 256, CV_BUFFER_USAGE_STORAGE, "buffer");
    uint32_t loaded_a = cv_device_loaded_count(a), loaded_b = cv_device_loaded_count(b);
    CHECK_RESULT(cv_device_load_alias(b, cv_any(plain), a), CV_ERROR_USAGE_MISMATCH);
    CHECK(strstr(cv_last_error(), "CV_TEXTURE_USAGE_SHARED") != NULL);
    CHECK_RESULT(cv_device_load_alias(b, cv_any(buf), a), CV_ERROR_WRONG_HANDLE_TYPE);
    CHECK_RESULT(cv_device_load_alias(b, cv_any(t), a), CV_ERROR_NOT_LOADED); /* not on the owner */
    CHECK_OK(cv_device_load(a, cv_any(t)));
    loaded_a++;
    CHECK_RESULT(cv_device_load_alias(a, cv_any(t), a), CV_ERROR_UNSUPPORTED);
    CHECK(strstr(cv_last_error(), "same device") != NULL);
    CHECK_RESULT(cv_device_load_alias(b, (cv_handle){ 0 }, a), CV_ERROR_INVALID_HANDLE);
    CHECK_RESULT(cv_device_load_alias(NULL, cv_any(t), a), CV_ERROR_INVALID_ARGUMENT);
    CHECK_OK(cv_device_load_alias(b, cv_any(t), a));
    loaded_b++;
    CHECK_RESULT(cv_device_load_alias(b, cv_any(t), a), CV_ERROR_ALREADY_LOADED);
    CHECK_EQ_INT(cv_device_loaded_count(a), loaded_a);
    CHECK_EQ_INT(cv_device_loaded_count(b), loaded_b);
    /* GPU waits: on itself, on a ticket never submitted. */
    uint64_t ticket = 99;
    CHECK_RESULT(cv_device_gpu_wait(a, a, 1, &ticket), CV_ERROR_INVALID_ARGUMENT);
    CHECK_EQ_INT(ticket, 0);
    CHECK_RESULT(cv_device_gpu_wait(a, b, 1u << 30, &ticket), CV_ERROR_INVALID_ARGUMENT);
    CHECK(strstr(cv_last_error(), "submitted only") != NULL);
    /* A ticket already reached: a ticket of its own, nothing to wait for. */
    CHECK_OK(cv_device_gpu_wait(a, b, 0, &ticket));
    CHECK_OK(cv_device_wait(a, ticket, UINT64_MAX));
    /* Another backend: refused, naming both. */
    cv_device *mock = NULL;
    CHECK_OK(cv_device_create(ctx, cv_mock_backend(), &(cv_device_desc){ .label = "mock" }, &mock));
    if (mock) {
        char why[160];
        CHECK(!cv_device_can_alias(mock, a, why, sizeof(why)));
        CHECK(strstr(why, "different backends") != NULL);
        CHECK_RESULT(cv_device_load_alias(mock, cv_any(t), a), CV_ERROR_UNSUPPORTED);
        CHECK(strstr(cv_last_error(), "'mock'") && strstr(cv_last_error(), "'gpu0'"));
        CHECK_RESULT(cv_device_gpu_wait(mock, a, 0, &ticket), CV_ERROR_UNSUPPORTED);
        CHECK_EQ_INT(cv_device_loaded_count(mock), 0);
        cv_device_destroy(mock);
    }
    CHECK(cv_device_can_alias(b, a, NULL, 0));
    CHECK_OK(cv_texture_destroy(ctx, t));
    CHECK_OK(cv_texture_destroy(ctx, plain));
    CHECK_OK(cv_buffer_destroy(ctx, buf));
}

int main(void) {
    /* Separate VkDevices unless ctest's vk_alias_shared asks for one. */
    setenv("CORVID_VGPU_DEVICE", "separate", 0);
    cv_context *ctx;
    CHECK_OK(cv_context_create(NULL, &ctx));
    cv_device *gpu[2] = { NULL, NULL };
    CHECK_OK(vkt_two_virtual_gpus(ctx, gpu));
    if (gpu[0] && gpu[1]) {
        host_both_ways(ctx, gpu[0], gpu[1]);
        gpu_ordering(ctx, gpu[0], gpu[1]);
        refusals(ctx, gpu[0], gpu[1]);
        cv_device_destroy(gpu[1]); /* the alias's device first, then the owner's */
        cv_device_destroy(gpu[0]);
    }
    cv_context_destroy(ctx);
    CHECK_NOTHING_LIVE();
    return vkt_report("vk_alias");
}
