/* Virtual GPUs sharing one VkDevice (CORVID_VGPU_DEVICE=shared, vk_shared.h),
 * on the test adapter (lavapipe: one queue, so every instance shares it):
 *   - the variable: a bad value is refused naming it, nothing is created;
 *     "separate" gives every device its own VkDevice;
 *   - 3 instances of one adapter share one VkDevice and one registry entry,
 *     each with its own slot, queue index (k % queueCount), ticket, immediate
 *     command pool and command pools; a submit mutex on each queue;
 *   - compute work on each (its own values) is exact;
 *   - a pipeline loaded on several instances is one VkPipeline with a
 *     reference per instance: unloading it from one leaves the others'
 *     dispatches exact, the last unload destroys it;
 *   - buffers and textures written on one instance and transferred to another
 *     are byte-exact through every path the pair takes (staged, host-import,
 *     shared, device, and auto, which must pick shared memory first), and through rings on
 *     the device path (one direct copy per transfer) and the shared path (its
 *     slots, waiting on the other instance's ticket semaphore directly),
 *     queued back and forth without a host wait; between separate VkDevices
 *     the device path is refused naming the devices and the variable;
 *   - destroying the middle instance, then the first, leaves the rest working
 *     (compute and transfers); a new instance takes the freed slot; the last
 *     one destroys the VkDevice (the registry is empty: a new device gets a
 *     fresh entry);
 *   - CORVID_LINK_QUEUE: a bad value is refused naming it; each value puts
 *     the asynchronous link copies on that queue type's slot (compute when
 *     unset), and rings on the device and shared paths stay byte-exact on
 *     the graphics and copy queues too;
 *   - the validation layer reports nothing (synchronization included). */
#include <stdlib.h>
#include <string.h>

#include "corvid/transfer.h"
#include "device_internal.h"
#include "vk_shared.h"
#include "vk_test.h"

static void fill(uint8_t *p, size_t n, uint32_t seed) {
    uint32_t x = seed * 2654435761u + 1;
    for (size_t i = 0; i < n; i++) {
        x = x * 1664525u + 1013904223u;
        p[i] = (uint8_t)(x >> 24);
    }
}

static cv_backend_device *bd_of(cv_device *d) { return d->bd; }

/* The shared entries named `name` (vk_shared.h) and their references. */
static uint32_t shared_pipeline_refs(vk_shared_device *s, const char *name, uint32_t *entries) {
    uint32_t refs = 0;
    *entries = 0;
    pthread_mutex_lock(&s->pipeline_lock);
    for (vk_shared_pipeline *e = s->pipelines; e; e = e->next)
        if (strcmp(e->info.name, name) == 0) {
            refs += e->refs;
            (*entries)++;
        }
    pthread_mutex_unlock(&s->pipeline_lock);
    return refs;
}

static void dispatch_fill(cv_context *ctx, cv_device *dev, cv_pipeline fill_u32, uint32_t seed);

/* One pipeline handle loaded on a and b: one VkPipeline, two references. */
static void pipelines_shared(cv_context *ctx, cv_device *a, cv_device *b, vk_shared_device *s) {
    uint32_t entries = 0;
    CHECK_EQ_INT(shared_pipeline_refs(s, "test.fill_u32", &entries), 0);
    cv_pipeline p = vkt_pipeline(ctx, a, "test.fill_u32");
    CHECK_EQ_INT(shared_pipeline_refs(s, "test.fill_u32", &entries), 1);
    CHECK_OK(cv_device_load(b, cv_any(p)));
    CHECK_EQ_INT(shared_pipeline_refs(s, "test.fill_u32", &entries), 2);
    CHECK_EQ_INT(entries, 1);
    dispatch_fill(ctx, a, p, 500);
    dispatch_fill(ctx, b, p, 600);
    CHECK_OK(cv_device_unload(a, cv_any(p)));
    CHECK_EQ_INT(shared_pipeline_refs(s, "test.fill_u32", &entries), 1);
    dispatch_fill(ctx, b, p, 700); /* b's reference keeps it */
    CHECK_OK(cv_pipeline_destroy(ctx, p));
    CHECK_EQ_INT(shared_pipeline_refs(s, "test.fill_u32", &entries), 0);
    CHECK_EQ_INT(entries, 0);
}

/* y = fill(seed) then checked on the host: work on one instance alone. */
static void compute_exact(cv_context *ctx, cv_device *dev, uint32_t seed) {
    cv_pipeline fill_u32 = vkt_pipeline(ctx, dev, "test.fill_u32");
    dispatch_fill(ctx, dev, fill_u32, seed);
    CHECK_OK(cv_pipeline_destroy(ctx, fill_u32));
}

static void dispatch_fill(cv_context *ctx, cv_device *dev, cv_pipeline fill_u32, uint32_t seed) {
    enum { N = 4096 };
    cv_buffer x = vkt_buffer(ctx, dev, 4 * N, 0, "filled");
    cv_cmdlist list;
    CHECK_OK(cv_cmdlist_create(ctx, &list));
    cv_command_list *l;
    CHECK_OK(cv_cmdlist_begin(ctx, list, &l));
    uint32_t push[2] = { seed, N };
    cv_binding b = { .resource = cv_any(x) };
    cv_cmd_dispatch(l, CV_QUEUE_COMPUTE,
                    &(cv_dispatch_args){ .pipeline = fill_u32,
                                         .bindings = &b,
                                         .bindings_count = 1,
                                         .push = push,
                                         .push_size = sizeof(push),
                                         .groups_x = (N + 63) / 64,
                                         .groups_y = 1,
                                         .groups_z = 1 });
    CHECK_OK(cv_command_list_end(l));
    CHECK_OK(vkt_run(dev, list, NULL));
    uint32_t *out = malloc(4 * N);
    CHECK_OK(cv_device_read_buffer(dev, x, 0, 4 * N, out));
    int bad = 0;
    for (uint32_t i = 0; i < N; i++)
        bad += out[i] != seed + i;
    CHECK_EQ_INT(bad, 0);
    free(out);
    CHECK_OK(cv_cmdlist_destroy(ctx, list));
    CHECK_OK(cv_buffer_destroy(ctx, x));
}

/* A buffer range and a texture rectangle from a to b on the path in force (`path` expected). */
static void transfer_exact(cv_context *ctx, cv_device *a, cv_device *b, cv_transfer_path path, uint32_t seed) {
    enum { SIZE = (9u << 20) + 77, W = 67, H = 45 };
    cv_buffer buf;
    CHECK_OK(cv_buffer_create(ctx, &(cv_buffer_desc){ .size = SIZE, .label = "moved" }, &buf));
    CHECK_OK(cv_device_load(a, cv_any(buf)));
    CHECK_OK(cv_device_load(b, cv_any(buf)));
    uint8_t *src = malloc(SIZE), *dst = malloc(SIZE), *back = malloc(SIZE);
    fill(src, SIZE, seed);
    fill(dst, SIZE, seed + 1);
    CHECK_OK(cv_device_write_buffer(a, buf, 0, SIZE, src));
    CHECK_OK(cv_device_write_buffer(b, buf, 0, SIZE, dst));
    cv_transfer_stats st = { 0 };
    CHECK_OK(cv_transfer_buffer(a, buf, 5, b, buf, 70, SIZE - 77, &st));
    CHECK_EQ_INT(st.path, path);
    memcpy(dst + 70, src + 5, SIZE - 77);
    CHECK_OK(cv_device_read_buffer(b, buf, 0, SIZE, back));
    CHECK(memcmp(back, dst, SIZE) == 0);
    CHECK_OK(cv_buffer_destroy(ctx, buf));

    cv_texture tex;
    CHECK_OK(cv_texture_create(
        ctx, &(cv_texture_desc){ .width = W, .height = H, .format = CV_FORMAT_RGBA8_UNORM, .label = "img" }, &tex));
    CHECK_OK(cv_device_load(a, cv_any(tex)));
    CHECK_OK(cv_device_load(b, cv_any(tex)));
    size_t row = W * 4;
    fill(src, row * H, seed + 2);
    fill(dst, row * H, seed + 3);
    CHECK_OK(cv_device_write_texture(a, tex, (cv_rect){ 0, 0, W, H }, src));
    CHECK_OK(cv_device_write_texture(b, tex, (cv_rect){ 0, 0, W, H }, dst));
    cv_rect rect = { 3, 4, 51, 33 };
    CHECK_OK(cv_transfer_texture(a, tex, rect, b, tex, 9, 7, &st));
    CHECK_EQ_INT(st.path, path);
    for (uint32_t y = 0; y < rect.height; y++)
        memcpy(dst + (7 + y) * row + 9 * 4, src + (rect.y + y) * row + rect.x * 4, rect.width * 4);
    CHECK_OK(cv_device_read_texture(b, tex, (cv_rect){ 0, 0, W, H }, back));
    CHECK(memcmp(back, dst, row * H) == 0);
    CHECK_OK(cv_texture_destroy(ctx, tex));
    free(src);
    free(dst);
    free(back);
}

/* Every path the pair can take, each forced, then auto (which must pick `best`). */
static void every_path(cv_context *ctx, cv_device *a, cv_device *b, cv_transfer_path best, uint32_t seed) {
    static const cv_transfer_path forced[] = { CV_TRANSFER_STAGED, CV_TRANSFER_HOST_IMPORT, CV_TRANSFER_SHARED,
                                               CV_TRANSFER_DEVICE };
    for (size_t i = 0; i < sizeof(forced) / sizeof(forced[0]); i++) {
        cv_transfer_path p;
        CHECK_OK(cv_transfer_set_path(forced[i]));
        if (cv_transfer_choose_path(a, b, &p) != CV_OK) {
            fprintf(stderr, "  (path %s not offered: %s)\n", cv_transfer_path_name(forced[i]), cv_last_error());
            continue;
        }
        fprintf(stderr, "  path %s\n", cv_transfer_path_name(forced[i]));
        transfer_exact(ctx, a, b, forced[i], seed + (uint32_t)i * 10);
    }
    CHECK_OK(cv_transfer_set_path(CV_TRANSFER_AUTO));
    transfer_exact(ctx, a, b, best, seed + 100);
    cv_transfer_clear_path();
}

/* 10 round trips a -> b -> a through two rings with no host wait in between, on `path`. */
static void ring_round_trips_on(cv_context *ctx, cv_device *a, cv_device *b, cv_transfer_path path) {
    enum { N = 20000, ROUNDS = 10 };
    cv_transfer_ring *ab = NULL, *ba = NULL;
    CHECK_OK(cv_transfer_set_path(path));
    CHECK_OK(cv_transfer_ring_create(a, b, 4096, 2, &ab));
    CHECK_OK(cv_transfer_ring_create(b, a, 4096, 2, &ba));
    cv_transfer_clear_path();
    CHECK(!ab || cv_transfer_ring_path(ab) == path);
    if (!ab || !ba) {
        cv_transfer_ring_destroy(ab);
        cv_transfer_ring_destroy(ba);
        return;
    }
    cv_buffer buf;
    CHECK_OK(cv_buffer_create(ctx, &(cv_buffer_desc){ .size = 2 * N, .label = "ping" }, &buf));
    CHECK_OK(cv_device_load(a, cv_any(buf)));
    CHECK_OK(cv_device_load(b, cv_any(buf)));
    uint8_t *src = malloc(2 * N), *back = malloc(2 * N), *zero = calloc(1, 2 * N);
    fill(src, N, 77);
    memset(src + N, 0, N);
    CHECK_OK(cv_device_write_buffer(a, buf, 0, 2 * N, src));
    CHECK_OK(cv_device_write_buffer(b, buf, 0, 2 * N, zero));
    /* Round k: a's [0,N) -> b's [N,2N) -> a's [0,N): the bytes must survive every hop; each
     * round a adds nothing but a's own write of [N,2N) must not leak into what b sends back. */
    for (int k = 0; k < ROUNDS; k++) {
        cv_transfer_async t = { 0 };
        CHECK_OK(cv_transfer_buffer_async(ab, buf, 0, buf, N, N, &t));
        CHECK_EQ_INT(t.path, path);
        CHECK(t.src_ticket > 0 && t.dst_ticket > 0);
        CHECK_OK(cv_transfer_buffer_async(ba, buf, N, buf, 0, N, NULL));
    }
    CHECK_OK(cv_device_read_buffer(a, buf, 0, 2 * N, back));
    CHECK(memcmp(back, src, N) == 0);
    CHECK_OK(cv_device_read_buffer(b, buf, N, N, back));
    CHECK(memcmp(back, src, N) == 0);
    cv_transfer_ring_destroy(ab);
    cv_transfer_ring_destroy(ba);
    CHECK_OK(cv_buffer_destroy(ctx, buf));
    free(src);
    free(back);
    free(zero);
}

/* Through the device path (no slots) and the shared path (slots; waits on the other's ticket directly). */
static void ring_round_trips(cv_context *ctx, cv_device *a, cv_device *b) {
    ring_round_trips_on(ctx, a, b, CV_TRANSFER_DEVICE);
    ring_round_trips_on(ctx, a, b, CV_TRANSFER_SHARED);
}

/* Texture rectangles through a device-path ring, 8 hops back and forth, queued without a host wait. */
static void ring_textures(cv_context *ctx, cv_device *a, cv_device *b) {
    enum { W = 45, H = 31 };
    cv_transfer_ring *ab = NULL, *ba = NULL;
    CHECK_OK(cv_transfer_ring_create(a, b, 4096, 2, &ab));
    CHECK_OK(cv_transfer_ring_create(b, a, 4096, 2, &ba));
    cv_texture tex;
    CHECK_OK(cv_texture_create(
        ctx, &(cv_texture_desc){ .width = W, .height = H, .format = CV_FORMAT_RGBA32F, .label = "hop" }, &tex));
    CHECK_OK(cv_device_load(a, cv_any(tex)));
    CHECK_OK(cv_device_load(b, cv_any(tex)));
    size_t size = (size_t)W * H * 16;
    uint8_t *src = malloc(size), *other = malloc(size), *back = malloc(size);
    fill(src, size, 9);
    fill(other, size, 10);
    for (size_t i = 3; i < size; i += 4) /* finite floats */
        src[i] &= 0x3f, other[i] &= 0x3f;
    CHECK_OK(cv_device_write_texture(a, tex, (cv_rect){ 0, 0, W, H }, src));
    CHECK_OK(cv_device_write_texture(b, tex, (cv_rect){ 0, 0, W, H }, other));
    for (int k = 0; ab && ba && k < 4; k++) {
        CHECK_OK(cv_transfer_texture_async(ab, tex, (cv_rect){ 0, 0, W, H }, tex, 0, 0, NULL));
        CHECK_OK(cv_transfer_texture_async(ba, tex, (cv_rect){ 0, 0, W, H }, tex, 0, 0, NULL));
    }
    /* Then the left half of a to the right part of b, one rectangle. */
    CHECK_OK(cv_transfer_texture_async(ab, tex, (cv_rect){ 0, 0, 20, H }, tex, 25, 0, NULL));
    size_t row = (size_t)W * 16;
    memcpy(other, src, size);
    for (uint32_t y = 0; y < H; y++)
        memmove(other + y * row + 25 * 16, src + y * row, 20 * 16);
    CHECK_OK(cv_device_read_texture(a, tex, (cv_rect){ 0, 0, W, H }, back));
    CHECK(memcmp(back, src, size) == 0);
    CHECK_OK(cv_device_read_texture(b, tex, (cv_rect){ 0, 0, W, H }, back));
    CHECK(memcmp(back, other, size) == 0);
    cv_transfer_ring_destroy(ab);
    cv_transfer_ring_destroy(ba);
    CHECK_OK(cv_texture_destroy(ctx, tex));
    free(src);
    free(other);
    free(back);
}

/* CORVID_LINK_QUEUE, through vkt_device as a program reads it (the link_queue option: vk_device_core.h's link_slot). */
static void link_queue(cv_context *ctx) {
    cv_device *d[2] = { 0 };
    setenv("CORVID_LINK_QUEUE", "gpu", 1);
    CHECK_RESULT(vkt_device(ctx, NULL, "badq", &d[0]), CV_ERROR_INVALID_ARGUMENT);
    CHECK(strstr(cv_last_error(), "CORVID_LINK_QUEUE='gpu'") != NULL);
    CHECK(d[0] == NULL);
    static const struct {
        const char *value;
        cv_queue_type type;
    } values[] = { { NULL, CV_QUEUE_COMPUTE },
                   { "compute", CV_QUEUE_COMPUTE },
                   { "graphics", CV_QUEUE_GRAPHICS },
                   { "copy", CV_QUEUE_COPY } };
    for (size_t k = 0; k < sizeof(values) / sizeof(values[0]); k++) {
        if (values[k].value)
            setenv("CORVID_LINK_QUEUE", values[k].value, 1);
        else
            unsetenv("CORVID_LINK_QUEUE");
        CHECK_OK(vkt_device(ctx, NULL, "link0", &d[0]));
        CHECK_OK(vkt_device(ctx, NULL, "link1", &d[1]));
        if (d[0] && d[1]) {
            const cv_backend_device *bd = bd_of(d[0]);
            CHECK_EQ_INT(bd->link_slot, bd->slot_of_type[values[k].type]);
            fprintf(stderr, "CORVID_LINK_QUEUE=%s: slot %d\n", values[k].value ? values[k].value : "(unset)",
                    (int)bd->link_slot);
            if (values[k].type != CV_QUEUE_COMPUTE) { /* the default ran all of the above */
                ring_round_trips(ctx, d[0], d[1]);
                ring_textures(ctx, d[1], d[0]);
            }
        }
        cv_device_destroy(d[0]);
        cv_device_destroy(d[1]);
        d[0] = d[1] = NULL;
    }
    unsetenv("CORVID_LINK_QUEUE");
}

int main(void) {
    cv_context *ctx = NULL;
    CHECK_OK(cv_context_create(NULL, &ctx));
    if (!ctx)
        return vkt_report("vk_shared_device");

    /* The variable. */
    cv_device *d[4] = { 0 };
    setenv("CORVID_VGPU_DEVICE", "sharde", 1);
    CHECK_RESULT(vkt_device(ctx, NULL, "bad", &d[0]), CV_ERROR_INVALID_ARGUMENT);
    CHECK(strstr(cv_last_error(), "CORVID_VGPU_DEVICE='sharde'") != NULL);
    CHECK(d[0] == NULL);
    setenv("CORVID_VGPU_DEVICE", "separate", 1);
    CHECK_OK(vkt_device(ctx, NULL, "own0", &d[0]));
    CHECK_OK(vkt_device(ctx, NULL, "own1", &d[1]));
    if (d[0] && d[1]) {
        CHECK(bd_of(d[0])->shared == NULL && bd_of(d[1])->shared == NULL);
        CHECK(bd_of(d[0])->device != bd_of(d[1])->device);
    }
    if (d[0] && d[1]) { /* separate VkDevices: no device path, auto takes another */
        cv_transfer_path p = CV_TRANSFER_DEVICE;
        CHECK_OK(cv_transfer_choose_path(d[0], d[1], &p));
        CHECK(p != CV_TRANSFER_DEVICE);
        CHECK_OK(cv_transfer_set_path(CV_TRANSFER_DEVICE));
        CHECK_RESULT(cv_transfer_choose_path(d[0], d[1], &p), CV_ERROR_UNSUPPORTED);
        CHECK(strstr(cv_last_error(), "'own0'") && strstr(cv_last_error(), "CORVID_VGPU_DEVICE=shared"));
        cv_transfer_ring *ring = (cv_transfer_ring *)1;
        CHECK_RESULT(cv_transfer_ring_create(d[0], d[1], 4096, 2, &ring), CV_ERROR_UNSUPPORTED);
        CHECK(ring == NULL);
        cv_transfer_clear_path();
    }
    cv_device_destroy(d[0]);
    cv_device_destroy(d[1]);
    d[0] = d[1] = NULL;
    /* auto (also unset): shared exactly where the graphics family has more
     * than one queue (NVIDIA: yes; lavapipe: one queue, separate). */
    const char *autos[2] = { "auto", NULL };
    for (int k = 0; k < 2; k++) {
        if (autos[k])
            setenv("CORVID_VGPU_DEVICE", autos[k], 1);
        else
            unsetenv("CORVID_VGPU_DEVICE");
        CHECK_OK(vkt_device(ctx, NULL, "auto0", &d[0]));
        CHECK_OK(vkt_device(ctx, NULL, "auto1", &d[1]));
        if (d[0] && d[1]) {
            const vk_adapter *a = &bd_of(d[0])->adapter;
            bool want = vk_shared_auto_choice(a->physical, a->graphics_family);
            uint32_t n = 0;
            vkGetPhysicalDeviceQueueFamilyProperties(a->physical, &n, NULL);
            VkQueueFamilyProperties props[32];
            n = n > 32 ? 32 : n;
            vkGetPhysicalDeviceQueueFamilyProperties(a->physical, &n, props);
            CHECK(want == (props[a->graphics_family].queueCount > 1));
            CHECK((bd_of(d[0])->shared != NULL) == want && (bd_of(d[1])->shared != NULL) == want);
            CHECK((bd_of(d[0])->device == bd_of(d[1])->device) == want);
            fprintf(stderr, "auto (%s): %s (graphics family: %u queues)\n", autos[k] ? autos[k] : "unset",
                    want ? "shared" : "separate", props[a->graphics_family].queueCount);
        }
        cv_device_destroy(d[0]);
        cv_device_destroy(d[1]);
        d[0] = d[1] = NULL;
    }

    /* Three instances on one VkDevice, each with its own objects. */
    setenv("CORVID_VGPU_DEVICE", "shared", 1);
    const char *labels[] = { "gpu0", "gpu1", "gpu2" };
    for (int i = 0; i < 3; i++)
        CHECK_OK(vkt_device(ctx, NULL, labels[i], &d[i]));
    if (!d[0] || !d[1] || !d[2])
        return vkt_report("vk_shared_device");
    vk_shared_device *s = bd_of(d[0])->shared;
    CHECK(s != NULL);
    uint32_t queues = 1;
    {
        uint32_t n = 0;
        vkGetPhysicalDeviceQueueFamilyProperties(bd_of(d[0])->adapter.physical, &n, NULL);
        VkQueueFamilyProperties props[32];
        n = n > 32 ? 32 : n;
        vkGetPhysicalDeviceQueueFamilyProperties(bd_of(d[0])->adapter.physical, &n, props);
        queues = props[bd_of(d[0])->queues[VK_SLOT_GRAPHICS].family].queueCount;
        queues = queues > VK_SHARED_MAX_QUEUES ? VK_SHARED_MAX_QUEUES : queues;
    }
    CHECK_EQ_INT(s->refs, 3);
    for (int i = 0; i < 3; i++) {
        cv_backend_device *bd = bd_of(d[i]);
        CHECK(bd->shared == s && bd->device == s->device);
        CHECK_EQ_INT(bd->shared_slot, i);
        CHECK_EQ_INT(bd->queues[VK_SLOT_GRAPHICS].index, (uint32_t)i % queues);
        CHECK(bd->queues[VK_SLOT_GRAPHICS].lock == &s->queue_locks[VK_SLOT_GRAPHICS][i % queues]);
        CHECK(bd->host == &s->host_lock);
        CHECK(strcmp(cv_device_get_info(d[i])->cross_wait, "device") == 0);
        for (int j = 0; j < i; j++) {
            cv_backend_device *o = bd_of(d[j]);
            CHECK(bd->ticket != o->ticket && bd->chain != o->chain && bd->immediate != o->immediate);
            CHECK(bd->imm != o->imm && bd->queues[0].pool != o->queues[0].pool);
            CHECK(&bd->memory != &o->memory);
            CHECK_EQ_INT(vk_device_same(bd, o), 1);
        }
    }
    fprintf(stderr, "3 instances, slots 0..2, %u queue(s) in the graphics family\n", queues);
    for (int i = 0; i < 3; i++)
        compute_exact(ctx, d[i], 1000u * (uint32_t)i + 7);
    pipelines_shared(ctx, d[0], d[2], s);

    cv_transfer_path best;
    CHECK_OK(cv_transfer_choose_path(d[0], d[1], &best));
    fprintf(stderr, "auto between instances: %s\n", cv_transfer_path_name(best));
    CHECK_EQ_INT(best, CV_TRANSFER_DEVICE); /* one copy first (transfer_path.c says why) */
    fprintf(stderr, "gpu0 -> gpu1\n");
    every_path(ctx, d[0], d[1], best, 1);
    fprintf(stderr, "gpu2 -> gpu0\n");
    every_path(ctx, d[2], d[0], best, 2);
    ring_round_trips(ctx, d[1], d[2]);
    ring_textures(ctx, d[0], d[2]);

    /* The middle one goes first: the others keep working; a new one takes its slot. */
    cv_device_destroy(d[1]);
    d[1] = NULL;
    CHECK_EQ_INT(s->refs, 2);
    compute_exact(ctx, d[0], 31);
    compute_exact(ctx, d[2], 32);
    every_path(ctx, d[0], d[2], best, 3);
    ring_round_trips(ctx, d[2], d[0]);
    CHECK_OK(vkt_device(ctx, NULL, "gpu3", &d[3]));
    if (d[3]) {
        CHECK(bd_of(d[3])->shared == s);
        CHECK_EQ_INT(bd_of(d[3])->shared_slot, 1);
        every_path(ctx, d[3], d[2], best, 4);
    }
    /* Then the first. */
    cv_device_destroy(d[0]);
    d[0] = NULL;
    compute_exact(ctx, d[2], 41);
    if (d[3]) {
        compute_exact(ctx, d[3], 42);
        every_path(ctx, d[2], d[3], best, 5);
        ring_round_trips(ctx, d[3], d[2]);
    }
    cv_device_destroy(d[3]);
    d[3] = NULL;
    compute_exact(ctx, d[2], 51);
    cv_device_destroy(d[2]); /* the last: destroys the VkDevice */
    d[2] = NULL;

    /* The registry is empty again: a new device makes a new entry at slot 0. */
    CHECK_OK(vkt_device(ctx, NULL, "again", &d[0]));
    if (d[0]) {
        CHECK_EQ_INT(bd_of(d[0])->shared_slot, 0);
        CHECK_EQ_INT(bd_of(d[0])->shared->refs, 1);
        compute_exact(ctx, d[0], 61);
        cv_device_destroy(d[0]);
    }
    link_queue(ctx);
    unsetenv("CORVID_VGPU_DEVICE");
    cv_context_destroy(ctx);
    return vkt_report("vk_shared_device");
}
