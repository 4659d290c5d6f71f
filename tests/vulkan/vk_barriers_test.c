/* The barrier tracker's decisions, command by command, on real Vulkan objects
 * recorded into a real command buffer (so the validation layer checks every
 * barrier it emits): read-after-write, write-after-read and write-after-write
 * get a barrier; read-after-read and first uses get none; an image's first
 * layout change in a segment goes to the prologue; uses by one command are
 * merged into one barrier call; the epilogue returns images to GENERAL. */
#include "corvid/backend.h"
#include "vk_barriers.h"
#include "vk_device_core.h"
#include "vk_resources.h"
#include "vk_test.h"

#define C VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT
#define F VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT
#define T VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT
#define SR VK_ACCESS_2_SHADER_STORAGE_READ_BIT
#define SW VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT
#define TR VK_ACCESS_2_TRANSFER_READ_BIT
#define TW VK_ACCESS_2_TRANSFER_WRITE_BIT
#define SAMPLED VK_ACCESS_2_SHADER_SAMPLED_READ_BIT

typedef struct scene {
    vk_tracker tracker;
    VkCommandBuffer cmd;
    vk_buffer *a, *b;
    vk_texture *i, *j;
} scene;

static void buffer_use(scene *s, uint64_t id, const vk_buffer *buf, VkPipelineStageFlags2 stages,
                       VkAccessFlags2 reads, VkAccessFlags2 writes) {
    vk_tracker_use(&s->tracker,
                   &(vk_use){ .id = id, .buffer = buf->buffer, .stages = stages, .reads = reads, .writes = writes });
}

static void image_use(scene *s, uint64_t id, const vk_texture *tex, VkPipelineStageFlags2 stages,
                      VkAccessFlags2 reads, VkAccessFlags2 writes, VkImageLayout layout) {
    vk_tracker_use(&s->tracker, &(vk_use){ .id = id,
                                           .image = tex->image,
                                           .aspect = tex->aspect,
                                           .stages = stages,
                                           .reads = reads,
                                           .writes = writes,
                                           .layout = layout });
}

/* Applies the declared uses; returns how many barrier calls that recorded. */
static uint32_t apply(scene *s) {
    uint32_t before = s->tracker.barriers_emitted;
    vk_tracker_apply(&s->tracker, s->cmd);
    return s->tracker.barriers_emitted - before;
}

enum { A = 1, B = 2, I = 3, J = 4 };

static void run(scene *s) {
    buffer_use(s, A, s->a, C, 0, SW);
    CHECK_EQ_INT(apply(s), 0); /* first use */
    buffer_use(s, A, s->a, C, SR, 0);
    CHECK_EQ_INT(apply(s), 1); /* read after write */
    buffer_use(s, A, s->a, C, SR, 0);
    CHECK_EQ_INT(apply(s), 0); /* read after read, already visible */
    buffer_use(s, A, s->a, F, SR, 0);
    CHECK_EQ_INT(apply(s), 1); /* the write is not yet visible to fragment shaders */
    buffer_use(s, B, s->b, C, SR, 0);
    CHECK_EQ_INT(apply(s), 0);
    buffer_use(s, B, s->b, T, TR, 0);
    CHECK_EQ_INT(apply(s), 0); /* read after read */
    buffer_use(s, A, s->a, T, 0, TW);
    CHECK_EQ_INT(apply(s), 1); /* write after read */
    buffer_use(s, A, s->a, T, 0, TW);
    CHECK_EQ_INT(apply(s), 1); /* write after write */
    /* Two uses of one command, two resources: one barrier call. */
    buffer_use(s, A, s->a, C, SR, 0);
    buffer_use(s, B, s->b, C, 0, SW);
    CHECK_EQ_INT(apply(s), 1);

    image_use(s, I, s->i, C, 0, SW, VK_IMAGE_LAYOUT_GENERAL);
    CHECK_EQ_INT(apply(s), 0); /* already in GENERAL */
    CHECK(!vk_tracker_has_prologue(&s->tracker));
    image_use(s, I, s->i, F, SAMPLED, 0, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
    CHECK_EQ_INT(apply(s), 1); /* read after write, with a transition */
    CHECK_EQ_INT(vk_tracker_layout(&s->tracker, I), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
    image_use(s, I, s->i, F, SAMPLED, 0, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
    CHECK_EQ_INT(apply(s), 0);
    image_use(s, J, s->j, VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT, 0, VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT,
              VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL);
    CHECK_EQ_INT(apply(s), 0); /* first transition goes to the prologue */
    CHECK(vk_tracker_has_prologue(&s->tracker));
    CHECK_EQ_INT(vk_tracker_layout(&s->tracker, J), VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL);
    /* Storage write, then a copy that reads it in another layout, then a
     * fragment read: the transition orders the copy, a second barrier (on the
     * transfer stage only) the fragment read. */
    image_use(s, I, s->i, C, 0, SW, VK_IMAGE_LAYOUT_GENERAL);
    CHECK_EQ_INT(apply(s), 1); /* write after read, back to GENERAL */
    image_use(s, I, s->i, T, TR, 0, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL);
    CHECK_EQ_INT(apply(s), 1);
    image_use(s, I, s->i, F, SR, 0, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL);
    CHECK_EQ_INT(apply(s), 1);
    image_use(s, I, s->i, T, TR, 0, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL);
    CHECK_EQ_INT(apply(s), 0);
    /* Sampled and storage in one command: GENERAL for both. */
    image_use(s, I, s->i, C, SAMPLED, 0, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
    image_use(s, I, s->i, C, 0, SW, VK_IMAGE_LAYOUT_GENERAL);
    CHECK_EQ_INT(apply(s), 1);
    CHECK_EQ_INT(vk_tracker_layout(&s->tracker, I), VK_IMAGE_LAYOUT_GENERAL);

    /* A full barrier hint settles everything: the next read needs nothing. */
    uint32_t before = s->tracker.barriers_emitted;
    vk_tracker_barrier(&s->tracker, s->cmd, 0);
    CHECK_EQ_INT(s->tracker.barriers_emitted - before, 1);
    buffer_use(s, B, s->b, F, SR, 0);
    CHECK_EQ_INT(apply(s), 0);

    before = s->tracker.barriers_emitted;
    vk_tracker_end_segment(&s->tracker, s->cmd, true);
    CHECK_EQ_INT(s->tracker.barriers_emitted - before, 1); /* J back to GENERAL, host visibility */
    CHECK_OK(vk_tracker_status(&s->tracker));
    vk_tracker_reset(&s->tracker);
    CHECK(!vk_tracker_has_prologue(&s->tracker));
    CHECK_EQ_INT(vk_tracker_layout(&s->tracker, J), VK_IMAGE_LAYOUT_GENERAL);
}

int main(void) {
    cv_context *ctx;
    cv_device *dev = NULL;
    CHECK_OK(cv_context_create(NULL, &ctx));
    CHECK_OK(vkt_device(ctx, NULL, "barriers", &dev));
    if (!dev) {
        cv_context_destroy(ctx); /* with any device it made */
        return check_report("vk_barriers");
    }
    const cv_backend *backend = cv_vulkan_backend();
    cv_backend_device *bd = cv_device_backend_data(dev);
    scene s = { 0 };
    cv_resource_desc buffer = { .type = CV_HANDLE_BUFFER,
                                .buffer = { .size = 1024, .usage = CV_BUFFER_USAGE_STORAGE } };
    cv_resource_desc image = { .type = CV_HANDLE_TEXTURE,
                               .texture = { .width = 8,
                                            .height = 8,
                                            .format = CV_FORMAT_RGBA8_UNORM,
                                            .usage = CV_TEXTURE_USAGE_SAMPLED | CV_TEXTURE_USAGE_STORAGE |
                                                     CV_TEXTURE_USAGE_COLOR_TARGET } };
    CHECK_OK(backend->resource_create(bd, A, &buffer, NULL, (void **)&s.a));
    CHECK_OK(backend->resource_create(bd, B, &buffer, NULL, (void **)&s.b));
    CHECK_OK(backend->resource_create(bd, I, &image, NULL, (void **)&s.i));
    CHECK_OK(backend->resource_create(bd, J, &image, NULL, (void **)&s.j));

    VkCommandBufferAllocateInfo alloc = { .sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO,
                                          .commandPool = bd->queues[VK_SLOT_GRAPHICS].pool,
                                          .level = VK_COMMAND_BUFFER_LEVEL_PRIMARY,
                                          .commandBufferCount = 1 };
    CHECK_EQ_INT(vkAllocateCommandBuffers(bd->device, &alloc, &s.cmd), VK_SUCCESS);
    VkCommandBufferBeginInfo begin = { .sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO };
    CHECK_EQ_INT(vkBeginCommandBuffer(s.cmd, &begin), VK_SUCCESS);
    vk_tracker_init(&s.tracker);
    run(&s);
    vk_tracker_finish(&s.tracker);
    CHECK_EQ_INT(vkEndCommandBuffer(s.cmd), VK_SUCCESS);
    vkFreeCommandBuffers(bd->device, alloc.commandPool, 1, &s.cmd);

    backend->resource_destroy(bd, CV_HANDLE_BUFFER, s.a);
    backend->resource_destroy(bd, CV_HANDLE_BUFFER, s.b);
    backend->resource_destroy(bd, CV_HANDLE_TEXTURE, s.i);
    backend->resource_destroy(bd, CV_HANDLE_TEXTURE, s.j);
    cv_context_destroy(ctx);
    return vkt_report("vk_barriers");
}
