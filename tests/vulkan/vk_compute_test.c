/* Compute on the Vulkan backend, checked exactly against the CPU: fill and
 * saxpy over a few thousand elements, a chain of dependent commands in one
 * list (read-after-write, write-after-read, write-after-write), the gradient
 * written to RGBA32F and RGBA16F storage textures, and sampled copies through
 * NEAREST samplers with clamping and wrapping. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "corvid/texel.h"
#include "vk_test.h"

typedef struct fixture {
    cv_context *ctx;
    cv_device *dev;
    cv_cmdlist list;
} fixture;

static uint32_t groups(uint32_t n, uint32_t size) { return (n + size - 1) / size; }

static float random_float(uint32_t *state) {
    *state = *state * 1664525u + 1013904223u;
    return (float)(*state >> 8) / (float)(1u << 24) * 200.0f - 100.0f;
}

/* C's a * x + y with the product rounded to float first (as the shader does). */
static float saxpy_ref(float a, float x, float y) {
    volatile float product = a * x;
    return product + y;
}

static void test_fill(fixture *f) {
    enum { N = 4099, SLACK = 5 };
    cv_pipeline fill = vkt_pipeline(f->ctx, f->dev, "test.fill_u32");
    cv_buffer buf = vkt_buffer(f->ctx, f->dev, 4 * (N + SLACK), 0, "fill");
    uint32_t *data = malloc(4 * (N + SLACK));
    for (int i = 0; i < N + SLACK; i++)
        data[i] = 0xdeadbeefu;
    CHECK_OK(cv_device_write_buffer(f->dev, buf, 0, 4 * (N + SLACK), data));

    cv_command_list *l;
    CHECK_OK(cv_cmdlist_begin(f->ctx, f->list, &l));
    uint32_t push[2] = { 0xfffff000u, N }; /* wraps past 2^32 */
    cv_binding b = { .resource = cv_any(buf) };
    cv_cmd_dispatch(l, CV_QUEUE_COMPUTE,
                    &(cv_dispatch_args){ .pipeline = fill,
                                         .bindings = &b,
                                         .bindings_count = 1,
                                         .push = push,
                                         .push_size = 8,
                                         .groups_x = groups(N, 64),
                                         .groups_y = 1,
                                         .groups_z = 1 });
    CHECK_OK(cv_command_list_end(l));
    CHECK_OK(vkt_run(f->dev, f->list, NULL));
    CHECK_OK(cv_device_read_buffer(f->dev, buf, 0, 4 * (N + SLACK), data));
    int wrong = 0;
    for (uint32_t i = 0; i < N; i++)
        wrong += data[i] != push[0] + i;
    for (uint32_t i = N; i < N + SLACK; i++)
        wrong += data[i] != 0xdeadbeefu;
    CHECK_EQ_INT(wrong, 0);
    free(data);
}

static void test_saxpy_chain(fixture *f) {
    enum { N = 4096 };
    cv_pipeline fill = vkt_pipeline(f->ctx, f->dev, "test.fill_u32");
    cv_pipeline saxpy = vkt_pipeline(f->ctx, f->dev, "test.saxpy");
    cv_buffer x = vkt_buffer(f->ctx, f->dev, 4 * N, 0, "x");
    cv_buffer x2 = vkt_buffer(f->ctx, f->dev, 4 * N, 0, "x2");
    cv_buffer y = vkt_buffer(f->ctx, f->dev, 4 * N, 0, "y");
    cv_buffer z = vkt_buffer(f->ctx, f->dev, 4 * N, 0, "z");
    float *hx = malloc(4 * N), *hy = malloc(4 * N), *expect = malloc(4 * N), *out = malloc(4 * N);
    uint32_t state = 12345;
    for (int i = 0; i < N; i++) {
        hx[i] = random_float(&state);
        hy[i] = random_float(&state);
    }
    CHECK_OK(cv_device_write_buffer(f->dev, x, 0, 4 * N, hx));
    CHECK_OK(cv_device_write_buffer(f->dev, y, 0, 4 * N, hy));

    /* y = 1.75 x + y; y = -0.5 x2 + y with x2 produced by fill in the same list;
     * z = copy of y; then x is cleared after being read (write-after-read). */
    float a1 = 1.75f, a2 = -0.5f;
    uint32_t fill_push[2] = { 0x3f800000u, N }; /* float bit patterns from 1.0 upwards */
    cv_binding xy[2] = { { .resource = cv_any(x) }, { .resource = cv_any(y) } };
    cv_binding x2y[2] = { { .resource = cv_any(x2) }, { .resource = cv_any(y) } };
    cv_binding bx2 = { .resource = cv_any(x2) };
    uint8_t push1[8], push2[8];
    uint32_t count = N;
    memcpy(push1, &a1, 4);
    memcpy(push1 + 4, &count, 4);
    memcpy(push2, &a2, 4);
    memcpy(push2 + 4, &count, 4);
    cv_command_list *l;
    CHECK_OK(cv_cmdlist_begin(f->ctx, f->list, &l));
    cv_cmd_dispatch(l, CV_QUEUE_COMPUTE,
                    &(cv_dispatch_args){ .pipeline = saxpy,
                                         .bindings = xy,
                                         .bindings_count = 2,
                                         .push = push1,
                                         .push_size = 8,
                                         .groups_x = groups(N, 64),
                                         .groups_y = 1,
                                         .groups_z = 1 });
    cv_cmd_dispatch(l, CV_QUEUE_COMPUTE,
                    &(cv_dispatch_args){ .pipeline = fill,
                                         .bindings = &bx2,
                                         .bindings_count = 1,
                                         .push = fill_push,
                                         .push_size = 8,
                                         .groups_x = groups(N, 64),
                                         .groups_y = 1,
                                         .groups_z = 1 });
    cv_cmd_dispatch(l, CV_QUEUE_COMPUTE,
                    &(cv_dispatch_args){ .pipeline = saxpy,
                                         .bindings = x2y,
                                         .bindings_count = 2,
                                         .push = push2,
                                         .push_size = 8,
                                         .groups_x = groups(N, 64),
                                         .groups_y = 1,
                                         .groups_z = 1 });
    cv_cmd_copy_buffer(l, CV_QUEUE_COMPUTE, &(cv_copy_buffer_args){ .src = y, .dst = z, .size = 4 * N });
    cv_cmd_clear_buffer(l, CV_QUEUE_COMPUTE, &(cv_clear_buffer_args){ .buffer = x, .size = 4 * N, .value = 7 });
    CHECK_OK(cv_command_list_end(l));
    CHECK_OK(vkt_run(f->dev, f->list, NULL));

    for (uint32_t i = 0; i < N; i++) {
        uint32_t bits = fill_push[0] + i;
        float x2v;
        memcpy(&x2v, &bits, 4);
        expect[i] = saxpy_ref(a2, x2v, saxpy_ref(a1, hx[i], hy[i]));
    }
    CHECK_OK(cv_device_read_buffer(f->dev, z, 0, 4 * N, out));
    CHECK(memcmp(out, expect, 4 * N) == 0);
    CHECK_OK(cv_device_read_buffer(f->dev, y, 0, 4 * N, out));
    CHECK(memcmp(out, expect, 4 * N) == 0);
    uint32_t *cleared = (uint32_t *)out;
    CHECK_OK(cv_device_read_buffer(f->dev, x, 0, 4 * N, out));
    int wrong = 0;
    for (int i = 0; i < N; i++)
        wrong += cleared[i] != 7;
    CHECK_EQ_INT(wrong, 0);
    free(hx);
    free(hy);
    free(expect);
    free(out);
}

static float gradient_ref(int32_t coord) { return (float)((uint32_t)coord & 255u) / 256.0f; }

/* Runs test.gradient over a whole texture with the given origin. */
static void run_gradient(fixture *f, cv_texture tex, uint32_t w, uint32_t h, int32_t ox, int32_t oy) {
    cv_pipeline gradient = vkt_pipeline(f->ctx, f->dev, "test.gradient");
    cv_command_list *l;
    CHECK_OK(cv_cmdlist_begin(f->ctx, f->list, &l));
    int32_t push[2] = { ox, oy };
    cv_binding b = { .resource = cv_any(tex) };
    cv_cmd_dispatch(l, CV_QUEUE_COMPUTE,
                    &(cv_dispatch_args){ .pipeline = gradient,
                                         .bindings = &b,
                                         .bindings_count = 1,
                                         .push = push,
                                         .push_size = 8,
                                         .groups_x = groups(w, 8),
                                         .groups_y = groups(h, 8),
                                         .groups_z = 1 });
    CHECK_OK(cv_command_list_end(l));
    CHECK_OK(vkt_run(f->dev, f->list, NULL));
    CHECK_OK(cv_pipeline_destroy(f->ctx, gradient));
}

static void test_gradient(fixture *f) {
    enum { W = 100, H = 60 };
    const int32_t ox = 200, oy = -3;
    cv_texture t32 = vkt_texture(f->ctx, f->dev, W, H, CV_FORMAT_RGBA32F, CV_TEXTURE_USAGE_STORAGE, "gradient32");
    run_gradient(f, t32, W, H, ox, oy);
    float *texels = malloc(W * H * 16);
    CHECK_OK(cv_device_read_texture(f->dev, t32, (cv_rect){ 0, 0, W, H }, texels));
    int wrong = 0;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            const float *t = &texels[(y * W + x) * 4];
            int32_t gx = x + ox, gy = y + oy;
            wrong += t[0] != gradient_ref(gx) || t[1] != gradient_ref(gy) || t[2] != gradient_ref(gx + gy) ||
                     t[3] != 1.0f;
        }
    CHECK_EQ_INT(wrong, 0);

    enum { W16 = 40, H16 = 24 };
    cv_texture t16 = vkt_texture(f->ctx, f->dev, W16, H16, CV_FORMAT_RGBA16F, CV_TEXTURE_USAGE_STORAGE, "gradient16");
    run_gradient(f, t16, W16, H16, 0, 0);
    uint16_t halves[W16 * H16 * 4];
    CHECK_OK(cv_device_read_texture(f->dev, t16, (cv_rect){ 0, 0, W16, H16 }, halves));
    wrong = 0;
    for (int y = 0; y < H16; y++)
        for (int x = 0; x < W16; x++) {
            const uint16_t *t = &halves[(y * W16 + x) * 4];
            wrong += cv_half_to_float(t[0]) != gradient_ref(x) || cv_half_to_float(t[1]) != gradient_ref(y) ||
                     cv_half_to_float(t[2]) != gradient_ref(x + y) || cv_half_to_float(t[3]) != 1.0f;
        }
    CHECK_EQ_INT(wrong, 0);
    free(texels);
}

static int wrap(int v, int n) { return ((v % n) + n) % n; }
static int clamp_int(int v, int n) { return v < 0 ? 0 : v >= n ? n - 1 : v; }

static void test_sample_copy(fixture *f, cv_address_mode address) {
    enum { SW = 20, SH = 12, DW = 24, DH = 16 };
    const int32_t ox = -2, oy = 3;
    cv_pipeline copy = vkt_pipeline(f->ctx, f->dev, "test.sample_copy");
    cv_sampler sampler = vkt_sampler(f->ctx, f->dev, CV_FILTER_NEAREST, address);
    cv_texture src = vkt_texture(f->ctx, f->dev, SW, SH, CV_FORMAT_RGBA32F, CV_TEXTURE_USAGE_SAMPLED, "src");
    cv_texture dst = vkt_texture(f->ctx, f->dev, DW, DH, CV_FORMAT_RGBA32F, CV_TEXTURE_USAGE_STORAGE, "dst");
    float source[SH][SW][4], out[DH][DW][4];
    for (int y = 0; y < SH; y++)
        for (int x = 0; x < SW; x++)
            for (int c = 0; c < 4; c++)
                source[y][x][c] = (float)(y * 1000 + x * 10 + c) + 0.25f;
    CHECK_OK(cv_device_write_texture(f->dev, src, (cv_rect){ 0, 0, SW, SH }, source));
    cv_command_list *l;
    CHECK_OK(cv_cmdlist_begin(f->ctx, f->list, &l));
    int32_t push[2] = { ox, oy };
    cv_binding b[2] = { { .resource = cv_any(src), .sampler = sampler }, { .resource = cv_any(dst) } };
    cv_cmd_dispatch(l, CV_QUEUE_COMPUTE,
                    &(cv_dispatch_args){ .pipeline = copy,
                                         .bindings = b,
                                         .bindings_count = 2,
                                         .push = push,
                                         .push_size = 8,
                                         .groups_x = groups(DW, 8),
                                         .groups_y = groups(DH, 8),
                                         .groups_z = 1 });
    CHECK_OK(cv_command_list_end(l));
    CHECK_OK(vkt_run(f->dev, f->list, NULL));
    CHECK_OK(cv_device_read_texture(f->dev, dst, (cv_rect){ 0, 0, DW, DH }, out));
    int wrong = 0;
    for (int y = 0; y < DH; y++)
        for (int x = 0; x < DW; x++) {
            int sx = address == CV_ADDRESS_REPEAT ? wrap(x + ox, SW) : clamp_int(x + ox, SW);
            int sy = address == CV_ADDRESS_REPEAT ? wrap(y + oy, SH) : clamp_int(y + oy, SH);
            wrong += memcmp(out[y][x], source[sy][sx], 16) != 0;
        }
    CHECK_EQ_INT(wrong, 0);
}

int main(void) {
    fixture f = { 0 };
    CHECK_OK(cv_context_create(NULL, &f.ctx));
    CHECK_OK(vkt_device(f.ctx, vkt_adapter(), "compute", &f.dev));
    if (!f.dev) {
        cv_context_destroy(f.ctx); /* with any device it made */
        return check_report("vk_compute");
    }
    CHECK_OK(cv_cmdlist_create(f.ctx, &f.list));
    test_fill(&f);
    test_saxpy_chain(&f);
    test_gradient(&f);
    test_sample_copy(&f, CV_ADDRESS_CLAMP);
    test_sample_copy(&f, CV_ADDRESS_REPEAT);
    cv_context_destroy(f.ctx);
    return vkt_report("vk_compute");
}
