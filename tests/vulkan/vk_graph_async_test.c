/* The render graph on three virtual GPUs (lavapipe, validation on) with its
 * transfers through asynchronous rings: a primary pass fills a buffer with the
 * frame's value, the buffer is multicast, every device copies its columns,
 * the columns are gathered back to the primary. 20 frames are submitted
 * without waiting (cv_graph_submit); every fifth frame the primary's result
 * is read (a host read waits for the buffer's last use, the ring copies
 * included) and must hold that frame's value in every column; each frame
 * seven back is collected (its timings: the bytes moved, a 'spread' per
 * device with columns). Then six more frames are submitted and the graph destroyed with
 * them in flight, then the devices: nothing may be left and validation
 * (synchronization included) must stay silent, on shared and host-import. */
#include <stdlib.h>
#include <string.h>

#include "corvid/graph.h"
#include "corvid/transfer.h"
#include "env_vulkan.h"
#include "vk_test.h"

enum { COLUMNS = 96, FRAMES = 20, DEVICES = 3 };

typedef struct fill_frame {
    cv_graph_resource src;
    uint32_t value;
} fill_frame;

static void fill_src(const cv_graph_pass_context *pc, cv_command_list *list, void *user) {
    const fill_frame *f = user;
    cv_cmd_clear_buffer(list, pc->queue,
                        &(cv_clear_buffer_args){
                            .buffer = cv_graph_buffer(pc, f->src), .size = COLUMNS * 4, .value = f->value });
}

static void run(cv_transfer_path path) {
    cv_context *ctx;
    CHECK_OK(cv_context_create(NULL, &ctx));
    cv_vulkan_gpu_table table;
    cv_vulkan_gpu_config config = { .virtual_per_adapter = DEVICES, .adapters = vkt_adapter() };
    CHECK_OK(cv_env_vulkan_options(&config.device)); /* vk_graph_async_shared: CORVID_VGPU_DEVICE=shared */
    CHECK_OK(cv_vulkan_gpu_table_build(&config, &table));
    cv_device *gpu[DEVICES] = { NULL };
    CHECK_OK(cv_vulkan_create_devices(ctx, &table, true, gpu));
    cv_graph *g = NULL;
    if (gpu[DEVICES - 1])
        CHECK_OK(cv_graph_create(ctx, gpu, DEVICES, &g));
    if (!g) {
        for (int d = 0; d < DEVICES; d++)
            cv_device_destroy(gpu[d]);
        cv_context_destroy(ctx);
        return;
    }
    CHECK_OK(cv_transfer_set_path(path));
    cv_buffer src_h, result_h;
    CHECK_OK(cv_buffer_create(ctx, &(cv_buffer_desc){ .size = COLUMNS * 4, .label = "src" }, &src_h));
    CHECK_OK(cv_buffer_create(ctx, &(cv_buffer_desc){ .size = COLUMNS * 4, .label = "result" }, &result_h));
    fill_frame f = { 0 };
    cv_graph_resource b, result;
    CHECK_OK(cv_graph_import_buffer(g, src_h, 4, &f.src));
    CHECK_OK(cv_graph_create_buffer(g, &(cv_buffer_desc){ .size = COLUMNS * 4, .label = "b" }, 4, &b));
    CHECK_OK(cv_graph_import_buffer(g, result_h, 4, &result));
    cv_graph_pass fill, spread, gather;
    CHECK_OK(cv_graph_add_pass(g,
                               &(cv_graph_pass_desc){ .name = "fill",
                                                      .queue = CV_QUEUE_COMPUTE,
                                                      .policy = CV_MGPU_PRIMARY_ONLY,
                                                      .record = fill_src,
                                                      .user = &f },
                               &fill));
    CHECK_OK(cv_graph_write(g, fill, f.src, CV_GRAPH_TRANSFER_DST, CV_GRAPH_TRANSFER_AUTO));
    CHECK_OK(cv_graph_add_copy_pass(g, "spread", CV_MGPU_ALL_DEVICES, f.src, b, &spread));
    CHECK_OK(cv_graph_add_copy_pass(g, "gather", CV_MGPU_PRIMARY_ONLY, b, result, &gather));
    CHECK_OK(cv_graph_output(g, result));
    uint64_t ids[FRAMES] = { 0 };
    uint32_t wrong = 0, collected = 0;
    for (uint32_t k = 0; k < FRAMES; k++) {
        f.value = 0x01010101u * (k + 1); /* recorded into this frame's lists */
        CHECK_OK(cv_graph_bake(g, &(cv_graph_bake_desc){ .width = COLUMNS, .tile = 8 }));
        if (k == 0) { /* the rings exist before the first frame: spread out and gather back */
            cv_graph_stats st;
            CHECK_OK(cv_graph_get_stats(g, &st));
            CHECK(st.rings >= 2 && st.rings <= DEVICES * (DEVICES - 1));
        }
        uint64_t tickets[CV_MAX_DEVICES];
        CHECK_OK(cv_graph_submit(g, tickets));
        ids[k] = cv_graph_frame_id(g);
        if (k >= 7) {
            cv_graph_timing t[16];
            uint32_t n = 0, spreads = 0;
            uint64_t moved = 0;
            CHECK_OK(cv_graph_collect(g, ids[k - 7], t, 16, &n));
            for (uint32_t i = 0; i < n && i < 16; i++) {
                moved += strncmp(t[i].name, "transfer ", 9) == 0 ? t[i].bytes : 0;
                spreads += strcmp(t[i].name, "spread") == 0;
            }
            /* One per device with columns that frame (the balancer may leave a device none). */
            CHECK(spreads >= 1 && spreads <= DEVICES);
            /* The whole buffer to each secondary with columns, their windows back:
             * s whole buffers and at most one more (s = spreads - 1 or spreads). */
            CHECK(moved % 4 == 0 && moved >= (uint64_t)(spreads - 1) * COLUMNS * 4 &&
                  moved <= (uint64_t)(spreads + 1) * COLUMNS * 4);
            collected++;
        }
        if (k % 5 == 4) {
            uint32_t got[COLUMNS];
            CHECK_OK(cv_device_read_buffer(gpu[0], result_h, 0, sizeof(got), got));
            for (uint32_t c = 0; c < COLUMNS; c++)
                wrong += got[c] != f.value;
        }
    }
    CHECK_EQ_INT(wrong, 0);
    CHECK_EQ_INT(collected, FRAMES - 7);
    /* In flight when the graph goes: it waits for its rings and devices. */
    for (uint32_t k = 0; k < 6; k++) {
        f.value = 0xabababab;
        uint64_t tickets[CV_MAX_DEVICES];
        CHECK_OK(cv_graph_bake(g, &(cv_graph_bake_desc){ .width = COLUMNS, .tile = 8 }));
        CHECK_OK(cv_graph_submit(g, tickets));
    }
    cv_graph_destroy(g);
    uint32_t got[COLUMNS];
    CHECK_OK(cv_device_read_buffer(gpu[0], result_h, 0, sizeof(got), got));
    CHECK_EQ_INT(got[COLUMNS - 1], 0xabababab);
    CHECK_OK(cv_buffer_destroy(ctx, src_h));
    CHECK_OK(cv_buffer_destroy(ctx, result_h));
    cv_transfer_clear_path();
    for (int d = 0; d < DEVICES; d++)
        cv_device_destroy(gpu[d]);
    cv_context_destroy(ctx);
}

int main(void) {
    unsetenv("CORVID_TRANSFER_PATH");
    run(CV_TRANSFER_SHARED);
    run(CV_TRANSFER_HOST_IMPORT);
    CHECK_NOTHING_LIVE();
    return vkt_report("vk_graph_async");
}
