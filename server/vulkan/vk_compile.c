/* The list compiler: one switch over the command types, each case declaring
 * its resource uses to the barrier tracker (vk_barriers.h) and recording the
 * Vulkan commands. Redundant pipeline binds and identical consecutive
 * descriptor pushes are filtered out. */
#include <stdlib.h>
#include <string.h>

#include "vk_barriers.h"
#include "vk_compile.h"
#include "vk_pipelines.h"
#include "vk_resources.h"
#include "vk_trace.h"

#define TRANSFER_STAGE VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT
#define SLOT_FLOATING ((uint8_t)0xff)

typedef struct compiler {
    cv_backend_device *bd;
    cv_device *dev;
    const cv_command_list *list;
    vk_compiled *out;
    vk_tracker tracker;
    VkCommandBuffer cmd;
    const vk_queue *queue;
    const vk_pipeline *bound[2];      /* [compute, graphics] */
    const vk_pipeline *pushed_for[2]; /* pipeline whose bindings were pushed last */
    cv_binding pushed[2][CV_MAX_BINDINGS];
    bool in_render_pass;
    cv_vulkan_trace_path trace_path; /* chosen before recording when the list traces rays */
} compiler;

/* ---- lookups (the list was validated: every handle is loaded and typed) --------- */

static void *object_of(const compiler *c, uint64_t id) {
    const cv_device_resource *r = cv_device_lookup(c->dev, id);
    return r ? r->obj : NULL;
}

static bool is_depth_texture(const compiler *c, uint64_t id) {
    const cv_device_resource *r = cv_device_lookup(c->dev, id);
    return r && r->desc.type == CV_HANDLE_TEXTURE && cv_format_is_depth(r->desc.texture.format);
}

/* ---- uses ------------------------------------------------------------------------- */

static void use_buffer(compiler *c, uint64_t id, VkPipelineStageFlags2 stages, VkAccessFlags2 reads,
                       VkAccessFlags2 writes) {
    const vk_buffer *b = object_of(c, id);
    vk_tracker_use(&c->tracker,
                   &(vk_use){ .id = id, .buffer = b->buffer, .stages = stages, .reads = reads, .writes = writes });
}

static void use_texture(compiler *c, uint64_t id, VkPipelineStageFlags2 stages, VkAccessFlags2 reads,
                        VkAccessFlags2 writes, VkImageLayout layout) {
    const vk_texture *t = object_of(c, id);
    vk_tracker_use(&c->tracker, &(vk_use){ .id = id,
                                           .image = t->image,
                                           .aspect = t->aspect,
                                           .stages = stages,
                                           .reads = reads,
                                           .writes = writes,
                                           .layout = layout });
}

/* Declares the uses of a dispatch's or draw's bindings, as the shaders use them. */
static void use_bindings(compiler *c, const vk_pipeline *p, const cv_binding *b) {
    for (uint32_t i = 0; i < p->info->binding_count; i++) {
        const vk_binding_use *u = &p->uses[i];
        if (!u->stages)
            continue;
        switch (p->info->bindings[i]) {
        case CV_BINDING_STORAGE_BUFFER:
            use_buffer(c, b[i].resource.id, u->stages, u->reads ? VK_ACCESS_2_SHADER_STORAGE_READ_BIT : 0,
                       u->writes ? VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT : 0);
            break;
        case CV_BINDING_UNIFORM_BUFFER:
            use_buffer(c, b[i].resource.id, u->stages, VK_ACCESS_2_UNIFORM_READ_BIT, 0);
            break;
        case CV_BINDING_STORAGE_TEXTURE:
            use_texture(c, b[i].resource.id, u->stages, u->reads ? VK_ACCESS_2_SHADER_STORAGE_READ_BIT : 0,
                        u->writes ? VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT : 0, VK_IMAGE_LAYOUT_GENERAL);
            break;
        case CV_BINDING_SAMPLED_TEXTURE:
            use_texture(c, b[i].resource.id, u->stages, VK_ACCESS_2_SHADER_SAMPLED_READ_BIT, 0,
                        VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
            break;
        }
    }
}

/* ---- pipeline state ------------------------------------------------------------------ */

static void bind_and_push(compiler *c, const vk_pipeline *p, const cv_binding *b, cv_span push) {
    int k = p->bind_point == VK_PIPELINE_BIND_POINT_GRAPHICS;
    if (c->bound[k] != p) {
        vkCmdBindPipeline(c->cmd, p->bind_point, p->pipeline);
        c->bound[k] = p;
    }
    uint32_t n = p->info->binding_count;
    if (n && (c->pushed_for[k] != p || memcmp(c->pushed[k], b, n * sizeof(*b)) != 0)) {
        VkWriteDescriptorSet writes[CV_MAX_BINDINGS];
        VkDescriptorBufferInfo buffers[CV_MAX_BINDINGS];
        VkDescriptorImageInfo images[CV_MAX_BINDINGS];
        for (uint32_t i = 0; i < n; i++) {
            cv_binding_kind kind = p->info->bindings[i];
            writes[i] = (VkWriteDescriptorSet){ .sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET,
                                                .dstBinding = i,
                                                .descriptorCount = 1 };
            if (kind == CV_BINDING_STORAGE_BUFFER || kind == CV_BINDING_UNIFORM_BUFFER) {
                const vk_buffer *buf = object_of(c, b[i].resource.id);
                buffers[i] = (VkDescriptorBufferInfo){ buf->buffer, b[i].offset,
                                                       b[i].range ? b[i].range : VK_WHOLE_SIZE };
                writes[i].descriptorType = kind == CV_BINDING_STORAGE_BUFFER ? VK_DESCRIPTOR_TYPE_STORAGE_BUFFER
                                                                             : VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER;
                writes[i].pBufferInfo = &buffers[i];
            } else {
                const vk_texture *tex = object_of(c, b[i].resource.id);
                const vk_sampler *s = kind == CV_BINDING_SAMPLED_TEXTURE ? object_of(c, b[i].sampler.id) : NULL;
                images[i] = (VkDescriptorImageInfo){ s ? s->sampler : VK_NULL_HANDLE, tex->view,
                                                     vk_tracker_layout(&c->tracker, b[i].resource.id) };
                writes[i].descriptorType = kind == CV_BINDING_STORAGE_TEXTURE
                                               ? VK_DESCRIPTOR_TYPE_STORAGE_IMAGE
                                               : VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
                writes[i].pImageInfo = &images[i];
            }
        }
        c->bd->cmd_push_descriptor_set(c->cmd, p->bind_point, p->layout, 0, n, writes);
        c->pushed_for[k] = p;
        memcpy(c->pushed[k], b, n * sizeof(*b));
    }
    if (push.size)
        vkCmdPushConstants(c->cmd, p->layout, p->stages, 0, push.size, cv_list_bytes(c->list, push));
}

/* ---- commands ----------------------------------------------------------------------- */

static void record_dispatch(compiler *c, const cv_dispatch_cmd *d) {
    const vk_pipeline *p = object_of(c, d->pipeline.id);
    const cv_binding *b = cv_list_bindings(c->list, d->bindings);
    use_bindings(c, p, b);
    vk_tracker_apply(&c->tracker, c->cmd);
    bind_and_push(c, p, b, d->push);
    vkCmdDispatch(c->cmd, d->groups_x, d->groups_y, d->groups_z);
}

/* The client's counts are bounded on the GPU first (vk_indirect.h): the
 * dispatch reads the list's own slot, never the client's buffer. */
static void record_dispatch_indirect(compiler *c, uint32_t index, const cv_dispatch_indirect_cmd *d) {
    const vk_pipeline *p = object_of(c, d->pipeline.id);
    const cv_binding *b = cv_list_bindings(c->list, d->bindings);
    use_bindings(c, p, b);
    use_buffer(c, d->args.id, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_READ_BIT, 0);
    vk_tracker_apply(&c->tracker, c->cmd);
    const vk_buffer *args = object_of(c, d->args.id);
    vk_indirect_slots *slots = &c->out->indirect;
    VkDeviceSize slot = vk_indirect_record(c->bd, slots, c->cmd, args->address + d->args_offset, index);
    c->bound[0] = NULL; /* the bound's pipeline and push constants replaced ours */
    c->pushed_for[0] = NULL;
    bind_and_push(c, p, b, d->push);
    vkCmdDispatchIndirect(c->cmd, slots->buffer->buffer, slot);
}

static void record_trace_rays(compiler *c, const cv_trace_rays_cmd *d) {
    vk_trace_job job = {
        .accel = object_of(c, d->accel.id),
        .accel_key = d->accel.id,
        .rays = object_of(c, d->rays.id),
        .rays_key = d->rays.id,
        .rays_offset = d->rays_offset,
        .hits = object_of(c, d->hits.id),
        .hits_key = d->hits.id,
        .hits_offset = d->hits_offset,
        .count = d->count,
        .flags = d->flags,
    };
    vk_trace_record(c->bd, c->trace_path, &c->tracker, c->cmd, &job);
    /* It bound a pipeline of its own: the next dispatch binds and pushes again. */
    c->bound[0] = NULL;
    c->pushed_for[0] = NULL;
}

static void use_attachment(compiler *c, uint64_t id, bool depth, bool clear) {
    if (depth)
        use_texture(c, id, VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT,
                    clear ? 0 : VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT,
                    VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT, VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL);
    else
        use_texture(c, id, VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
                    clear ? 0 : VK_ACCESS_2_COLOR_ATTACHMENT_READ_BIT, VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT,
                    VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL);
}

/* Barriers are not allowed inside a render pass (without self-dependencies),
 * so the uses of every draw of the pass are declared up front. Draws inside
 * one pass are therefore not ordered against each other's storage writes. */
static void record_begin_render_pass(compiler *c, uint32_t index, const cv_begin_render_pass_cmd *rp) {
    uint32_t end = index + 1;
    for (; end < c->list->count && c->list->commands[end].type != CV_CMD_END_RENDER_PASS; end++) {
        const cv_command *cmd = &c->list->commands[end];
        if (cmd->type == CV_CMD_DRAW) {
            use_bindings(c, object_of(c, cmd->u.draw.pipeline.id), cv_list_bindings(c->list, cmd->u.draw.bindings));
        } else if (cmd->type == CV_CMD_DRAW_INDEXED) {
            const cv_draw_indexed_cmd *d = &cmd->u.draw_indexed;
            use_bindings(c, object_of(c, d->pipeline.id), cv_list_bindings(c->list, d->bindings));
            use_buffer(c, d->index_buffer.id, VK_PIPELINE_STAGE_2_INDEX_INPUT_BIT, VK_ACCESS_2_INDEX_READ_BIT, 0);
        }
    }
    c->in_render_pass = true;
    bool clear = rp->clear != 0;
    const uint64_t colors[CV_MAX_COLOR_TARGETS] = { rp->color0.id, rp->color1.id };
    for (int i = 0; i < CV_MAX_COLOR_TARGETS; i++)
        if (colors[i])
            use_attachment(c, colors[i], false, clear);
    if (rp->depth.id)
        use_attachment(c, rp->depth.id, true, clear);
    vk_tracker_apply(&c->tracker, c->cmd);

    VkRenderingAttachmentInfo color_infos[CV_MAX_COLOR_TARGETS];
    uint32_t color_count = 0;
    for (int i = 0; i < CV_MAX_COLOR_TARGETS; i++) {
        if (!colors[i])
            continue;
        const vk_texture *t = object_of(c, colors[i]);
        VkClearValue value = { .color.float32 = { rp->clear_r, rp->clear_g, rp->clear_b, rp->clear_a } };
        if (t->format == VK_FORMAT_R32_UINT)
            value.color = (VkClearColorValue){ .uint32 = { (uint32_t)rp->clear_r, (uint32_t)rp->clear_g,
                                                           (uint32_t)rp->clear_b, (uint32_t)rp->clear_a } };
        color_infos[color_count++] = (VkRenderingAttachmentInfo){
            .sType = VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO,
            .imageView = t->view,
            .imageLayout = vk_tracker_layout(&c->tracker, colors[i]),
            .loadOp = clear ? VK_ATTACHMENT_LOAD_OP_CLEAR : VK_ATTACHMENT_LOAD_OP_LOAD,
            .storeOp = VK_ATTACHMENT_STORE_OP_STORE,
            .clearValue = value,
        };
    }
    VkRenderingAttachmentInfo depth_info;
    if (rp->depth.id) {
        const vk_texture *t = object_of(c, rp->depth.id);
        depth_info = (VkRenderingAttachmentInfo){
            .sType = VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO,
            .imageView = t->view,
            .imageLayout = vk_tracker_layout(&c->tracker, rp->depth.id),
            .loadOp = clear ? VK_ATTACHMENT_LOAD_OP_CLEAR : VK_ATTACHMENT_LOAD_OP_LOAD,
            .storeOp = VK_ATTACHMENT_STORE_OP_STORE,
            .clearValue = { .depthStencil = { rp->clear_depth, 0 } },
        };
    }
    const vk_texture *first = object_of(c, rp->color0.id);
    VkRect2D area = { { 0, 0 }, { first->width, first->height } };
    VkRenderingInfo info = {
        .sType = VK_STRUCTURE_TYPE_RENDERING_INFO,
        .renderArea = area,
        .layerCount = 1,
        .colorAttachmentCount = color_count,
        .pColorAttachments = color_infos,
        .pDepthAttachment = rp->depth.id ? &depth_info : NULL,
    };
    vkCmdBeginRendering(c->cmd, &info);
    VkViewport viewport = { 0.0f, 0.0f, (float)first->width, (float)first->height, 0.0f, 1.0f };
    vkCmdSetViewport(c->cmd, 0, 1, &viewport);
    vkCmdSetScissor(c->cmd, 0, 1, &area);
}

static void record_draw(compiler *c, const cv_draw_cmd *d) {
    const vk_pipeline *p = object_of(c, d->pipeline.id);
    bind_and_push(c, p, cv_list_bindings(c->list, d->bindings), d->push);
    vkCmdDraw(c->cmd, d->vertex_count, d->instance_count, d->first_vertex, d->first_instance);
}

static void record_draw_indexed(compiler *c, const cv_draw_indexed_cmd *d) {
    const vk_pipeline *p = object_of(c, d->pipeline.id);
    bind_and_push(c, p, cv_list_bindings(c->list, d->bindings), d->push);
    const vk_buffer *ib = object_of(c, d->index_buffer.id);
    vkCmdBindIndexBuffer(c->cmd, ib->buffer, d->index_offset, VK_INDEX_TYPE_UINT32);
    vkCmdDrawIndexed(c->cmd, d->index_count, d->instance_count, d->first_index, d->vertex_offset, d->first_instance);
}

static void record_copy_buffer(compiler *c, const cv_copy_buffer_cmd *d) {
    use_buffer(c, d->src.id, TRANSFER_STAGE, VK_ACCESS_2_TRANSFER_READ_BIT, 0);
    use_buffer(c, d->dst.id, TRANSFER_STAGE, 0, VK_ACCESS_2_TRANSFER_WRITE_BIT);
    vk_tracker_apply(&c->tracker, c->cmd);
    const vk_buffer *src = object_of(c, d->src.id), *dst = object_of(c, d->dst.id);
    VkBufferCopy region = { d->src_offset, d->dst_offset, d->size };
    vkCmdCopyBuffer(c->cmd, src->buffer, dst->buffer, 1, &region);
}

static void record_copy_texture(compiler *c, const cv_copy_texture_cmd *d) {
    use_texture(c, d->src.id, TRANSFER_STAGE, VK_ACCESS_2_TRANSFER_READ_BIT, 0, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL);
    use_texture(c, d->dst.id, TRANSFER_STAGE, 0, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL);
    vk_tracker_apply(&c->tracker, c->cmd);
    const vk_texture *src = object_of(c, d->src.id), *dst = object_of(c, d->dst.id);
    VkImageCopy region = {
        .srcSubresource = { src->aspect, 0, 0, 1 },
        .srcOffset = { (int32_t)d->src_x, (int32_t)d->src_y, 0 },
        .dstSubresource = { dst->aspect, 0, 0, 1 },
        .dstOffset = { (int32_t)d->dst_x, (int32_t)d->dst_y, 0 },
        .extent = { d->width, d->height, 1 },
    };
    vkCmdCopyImage(c->cmd, src->image, vk_tracker_layout(&c->tracker, d->src.id), dst->image,
                   vk_tracker_layout(&c->tracker, d->dst.id), 1, &region);
}

static VkBufferImageCopy buffer_image_region(const vk_texture *t, uint64_t offset, uint32_t x, uint32_t y,
                                             uint32_t width, uint32_t height) {
    return (VkBufferImageCopy){
        .bufferOffset = offset,
        .imageSubresource = { t->aspect, 0, 0, 1 },
        .imageOffset = { (int32_t)x, (int32_t)y, 0 },
        .imageExtent = { width, height, 1 },
    };
}

static void record_copy_buffer_to_texture(compiler *c, const cv_copy_buffer_to_texture_cmd *d) {
    use_buffer(c, d->src.id, TRANSFER_STAGE, VK_ACCESS_2_TRANSFER_READ_BIT, 0);
    use_texture(c, d->dst.id, TRANSFER_STAGE, 0, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL);
    vk_tracker_apply(&c->tracker, c->cmd);
    const vk_buffer *src = object_of(c, d->src.id);
    const vk_texture *dst = object_of(c, d->dst.id);
    VkBufferImageCopy region = buffer_image_region(dst, d->src_offset, d->dst_x, d->dst_y, d->width, d->height);
    vkCmdCopyBufferToImage(c->cmd, src->buffer, dst->image, vk_tracker_layout(&c->tracker, d->dst.id), 1, &region);
}

static void record_copy_texture_to_buffer(compiler *c, const cv_copy_texture_to_buffer_cmd *d) {
    use_texture(c, d->src.id, TRANSFER_STAGE, VK_ACCESS_2_TRANSFER_READ_BIT, 0, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL);
    use_buffer(c, d->dst.id, TRANSFER_STAGE, 0, VK_ACCESS_2_TRANSFER_WRITE_BIT);
    vk_tracker_apply(&c->tracker, c->cmd);
    const vk_texture *src = object_of(c, d->src.id);
    const vk_buffer *dst = object_of(c, d->dst.id);
    VkBufferImageCopy region = buffer_image_region(src, d->dst_offset, d->src_x, d->src_y, d->width, d->height);
    vkCmdCopyImageToBuffer(c->cmd, src->image, vk_tracker_layout(&c->tracker, d->src.id), dst->buffer, 1, &region);
}

static void record_clear_buffer(compiler *c, const cv_clear_buffer_cmd *d) {
    use_buffer(c, d->buffer.id, TRANSFER_STAGE, 0, VK_ACCESS_2_TRANSFER_WRITE_BIT);
    vk_tracker_apply(&c->tracker, c->cmd);
    const vk_buffer *b = object_of(c, d->buffer.id);
    vkCmdFillBuffer(c->cmd, b->buffer, d->offset, d->size, d->value);
}

/* R32_UINT textures are cleared to (uint32_t)r; float formats to (r, g, b, a). */
static void record_clear_texture(compiler *c, const cv_clear_texture_cmd *d) {
    use_texture(c, d->texture.id, TRANSFER_STAGE, 0, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL);
    vk_tracker_apply(&c->tracker, c->cmd);
    const vk_texture *t = object_of(c, d->texture.id);
    VkClearColorValue value = { .float32 = { d->r, d->g, d->b, d->a } };
    if (t->format == VK_FORMAT_R32_UINT)
        value = (VkClearColorValue){ .uint32 = { (uint32_t)d->r, (uint32_t)d->g, (uint32_t)d->b, (uint32_t)d->a } };
    VkImageSubresourceRange range = { t->aspect, 0, 1, 0, 1 };
    vkCmdClearColorImage(c->cmd, t->image, vk_tracker_layout(&c->tracker, d->texture.id), &value, 1, &range);
}

static void record_update_buffer(compiler *c, const cv_update_buffer_cmd *d) {
    use_buffer(c, d->buffer.id, TRANSFER_STAGE, 0, VK_ACCESS_2_TRANSFER_WRITE_BIT);
    vk_tracker_apply(&c->tracker, c->cmd);
    const vk_buffer *b = object_of(c, d->buffer.id);
    vkCmdUpdateBuffer(c->cmd, b->buffer, d->offset, d->data.size, cv_list_bytes(c->list, d->data));
}

static void begin_label(const compiler *c, const char *label) {
    PFN_vkCmdBeginDebugUtilsLabelEXT begin = c->bd->instance->cmd_begin_label;
    if (begin) {
        VkDebugUtilsLabelEXT info = { .sType = VK_STRUCTURE_TYPE_DEBUG_UTILS_LABEL_EXT, .pLabelName = label };
        begin(c->cmd, &info);
    }
}

static void end_label(const compiler *c) {
    if (c->bd->instance->cmd_end_label)
        c->bd->instance->cmd_end_label(c->cmd);
}

/* Debug labels must open and close in one command buffer: the markers still
 * open when a segment ends are closed there and reopened in the next one. */
static void reopen_labels(const compiler *c) {
    const vk_timestamps *ts = &c->out->timestamps;
    for (uint32_t i = 0; i < ts->open_count; i++)
        begin_label(c, ts->passes[ts->open[i]].label);
}

static void close_labels(const compiler *c) {
    for (uint32_t i = 0; i < c->out->timestamps.open_count; i++)
        end_label(c);
}

static void record_marker(compiler *c, const cv_command *cmd) {
    char label[CV_LABEL_MAX];
    switch (cmd->type) {
    case CV_CMD_BEGIN_MARKER:
        cv_list_string(c->list, cmd->u.begin_marker.label, label, sizeof(label));
        vk_timestamps_begin_pass(&c->out->timestamps, c->cmd, c->queue, label);
        begin_label(c, label);
        break;
    case CV_CMD_END_MARKER:
        end_label(c);
        vk_timestamps_end_pass(&c->out->timestamps, c->cmd, c->queue);
        break;
    default:
        cv_list_string(c->list, cmd->u.timestamp.label, label, sizeof(label));
        vk_timestamps_point(&c->out->timestamps, c->cmd, c->queue, label);
        break;
    }
}

static void record_command(compiler *c, uint32_t index) {
    const cv_command *cmd = &c->list->commands[index];
    switch (cmd->type) {
    case CV_CMD_DISPATCH: record_dispatch(c, &cmd->u.dispatch); break;
    case CV_CMD_DISPATCH_INDIRECT: record_dispatch_indirect(c, index, &cmd->u.dispatch_indirect); break;
    case CV_CMD_BEGIN_RENDER_PASS: record_begin_render_pass(c, index, &cmd->u.begin_render_pass); break;
    case CV_CMD_END_RENDER_PASS:
        vkCmdEndRendering(c->cmd);
        c->in_render_pass = false;
        break;
    case CV_CMD_DRAW: record_draw(c, &cmd->u.draw); break;
    case CV_CMD_DRAW_INDEXED: record_draw_indexed(c, &cmd->u.draw_indexed); break;
    case CV_CMD_COPY_BUFFER: record_copy_buffer(c, &cmd->u.copy_buffer); break;
    case CV_CMD_COPY_TEXTURE: record_copy_texture(c, &cmd->u.copy_texture); break;
    case CV_CMD_COPY_BUFFER_TO_TEXTURE: record_copy_buffer_to_texture(c, &cmd->u.copy_buffer_to_texture); break;
    case CV_CMD_COPY_TEXTURE_TO_BUFFER: record_copy_texture_to_buffer(c, &cmd->u.copy_texture_to_buffer); break;
    case CV_CMD_CLEAR_BUFFER: record_clear_buffer(c, &cmd->u.clear_buffer); break;
    case CV_CMD_CLEAR_TEXTURE: record_clear_texture(c, &cmd->u.clear_texture); break;
    case CV_CMD_UPDATE_BUFFER: record_update_buffer(c, &cmd->u.update_buffer); break;
    case CV_CMD_TRACE_RAYS: record_trace_rays(c, &cmd->u.trace_rays); break;
    case CV_CMD_BARRIER:
        /* Inside a render pass the hint has nothing to order: its uses were declared up front. */
        if (!c->in_render_pass)
            vk_tracker_barrier(&c->tracker, c->cmd, cmd->u.barrier.resource.id);
        break;
    case CV_CMD_TIMESTAMP:
    case CV_CMD_BEGIN_MARKER:
    case CV_CMD_END_MARKER: record_marker(c, cmd); break;
    default: break;
    }
}

/* ---- segments ------------------------------------------------------------------------ */

/* The queue of each command; markers, timestamps and barrier hints float. */
static uint8_t slot_of(const compiler *c, const cv_command *cmd, bool in_render_pass) {
    if (cmd->type == CV_CMD_TIMESTAMP || cmd->type == CV_CMD_BEGIN_MARKER || cmd->type == CV_CMD_END_MARKER ||
        cmd->type == CV_CMD_BARRIER)
        return in_render_pass ? VK_SLOT_GRAPHICS : SLOT_FLOATING;
    if (in_render_pass)
        return VK_SLOT_GRAPHICS;
    vk_queue_slot slot = c->bd->slot_of_type[cmd->queue < CV_QUEUE_TYPE_COUNT ? cmd->queue : CV_QUEUE_GRAPHICS];
    /* Depth aspects can only be copied on a graphics queue. */
    bool depth = false;
    switch (cmd->type) {
    case CV_CMD_COPY_TEXTURE:
        depth = is_depth_texture(c, cmd->u.copy_texture.src.id) || is_depth_texture(c, cmd->u.copy_texture.dst.id);
        break;
    case CV_CMD_COPY_BUFFER_TO_TEXTURE: depth = is_depth_texture(c, cmd->u.copy_buffer_to_texture.dst.id); break;
    case CV_CMD_COPY_TEXTURE_TO_BUFFER: depth = is_depth_texture(c, cmd->u.copy_texture_to_buffer.src.id); break;
    default: break;
    }
    return depth ? VK_SLOT_GRAPHICS : (uint8_t)slot;
}

static cv_result plan_slots(const compiler *c, uint8_t **out) {
    uint32_t n = c->list->count;
    uint8_t *slots = malloc(n ? n : 1);
    if (!slots)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "vulkan: queue plan of %u commands", n);
    bool in_pass = false;
    uint8_t first = SLOT_FLOATING;
    for (uint32_t i = 0; i < n; i++) {
        const cv_command *cmd = &c->list->commands[i];
        if (cmd->type == CV_CMD_BEGIN_RENDER_PASS)
            in_pass = true;
        slots[i] = slot_of(c, cmd, in_pass);
        if (cmd->type == CV_CMD_END_RENDER_PASS)
            in_pass = false;
        if (first == SLOT_FLOATING)
            first = slots[i];
    }
    uint8_t current = first == SLOT_FLOATING ? (uint8_t)VK_SLOT_GRAPHICS : first;
    for (uint32_t i = 0; i < n; i++) {
        if (slots[i] == SLOT_FLOATING)
            slots[i] = current;
        current = slots[i];
    }
    *out = slots;
    return CV_OK;
}

static cv_result begin_buffer(compiler *c, vk_queue_slot slot, VkCommandBuffer *out) {
    VkCommandBufferAllocateInfo alloc = { .sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO,
                                          .commandPool = c->bd->queues[slot].pool,
                                          .level = VK_COMMAND_BUFFER_LEVEL_PRIMARY,
                                          .commandBufferCount = 1 };
    VkResult vr = vkAllocateCommandBuffers(c->bd->device, &alloc, out);
    if (vr != VK_SUCCESS) {
        *out = VK_NULL_HANDLE;
        return vk_fail(vr, "vkAllocateCommandBuffers");
    }
    /* A list may be submitted again before its previous submission finished. */
    VkCommandBufferBeginInfo begin = { .sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO,
                                       .flags = VK_COMMAND_BUFFER_USAGE_SIMULTANEOUS_USE_BIT };
    vr = vkBeginCommandBuffer(*out, &begin);
    if (vr != VK_SUCCESS) {
        vk_device_free_command_buffers(c->bd, alloc.commandPool, 1, out);
        *out = VK_NULL_HANDLE;
        return vk_fail(vr, "vkBeginCommandBuffer");
    }
    return CV_OK;
}

static cv_result add_segment(compiler *c, vk_queue_slot slot) {
    vk_compiled *out = c->out;
    vk_segment *seg = &out->segments[out->segment_count];
    *seg = (vk_segment){ .slot = slot };
    cv_result r = begin_buffer(c, slot, &seg->body);
    if (r != CV_OK)
        return r;
    out->segment_count++;
    c->cmd = seg->body;
    c->queue = &c->bd->queues[slot];
    memset(c->bound, 0, sizeof(c->bound));
    memset(c->pushed_for, 0, sizeof(c->pushed_for));
    vk_tracker_reset(&c->tracker);
    if (out->segment_count == 1)
        vk_timestamps_start(&out->timestamps, c->cmd, c->queue);
    reopen_labels(c);
    return CV_OK;
}

static cv_result end_segment(compiler *c, bool last) {
    vk_segment *seg = &c->out->segments[c->out->segment_count - 1];
    close_labels(c);
    vk_tracker_end_segment(&c->tracker, seg->body, last);
    VkResult vr = vkEndCommandBuffer(seg->body);
    if (vr != VK_SUCCESS)
        return vk_fail(vr, "vkEndCommandBuffer");
    if (!vk_tracker_has_prologue(&c->tracker))
        return CV_OK;
    cv_result r = begin_buffer(c, seg->slot, &seg->prologue);
    if (r != CV_OK)
        return r;
    vk_tracker_record_prologue(&c->tracker, seg->prologue);
    vr = vkEndCommandBuffer(seg->prologue);
    return vr == VK_SUCCESS ? CV_OK : vk_fail(vr, "vkEndCommandBuffer (prologue)");
}

static bool can_reset_queries(const vk_queue *q) { return q->flags & (VK_QUEUE_GRAPHICS_BIT | VK_QUEUE_COMPUTE_BIT); }

static cv_result compile(compiler *c, const uint8_t *slots) {
    const cv_command_list *list = c->list;
    uint32_t runs = 1;
    for (uint32_t i = 1; i < list->count; i++)
        runs += slots[i] != slots[i - 1];
    c->out->segments = calloc(runs + 1, sizeof(*c->out->segments));
    if (!c->out->segments)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "vulkan: %u segments", runs + 1);
    cv_result r = vk_timestamps_init(c->bd, list, &c->out->timestamps);
    vk_queue_slot first = list->count ? (vk_queue_slot)slots[0] : VK_SLOT_GRAPHICS;
    /* Queries are reset on the first queue; a transfer-only one cannot, so a
     * short graphics segment does it first. */
    if (r == CV_OK && c->out->timestamps.pool && !can_reset_queries(&c->bd->queues[first])) {
        r = add_segment(c, VK_SLOT_GRAPHICS);
        if (r == CV_OK)
            r = end_segment(c, false);
    }
    if (r == CV_OK)
        r = add_segment(c, first);
    for (uint32_t i = 0; i < list->count && r == CV_OK; i++) {
        if (slots[i] != c->out->segments[c->out->segment_count - 1].slot) {
            r = end_segment(c, false);
            if (r == CV_OK)
                r = add_segment(c, (vk_queue_slot)slots[i]);
            if (r != CV_OK)
                break;
        }
        record_command(c, i);
    }
    if (r == CV_OK)
        r = end_segment(c, true);
    if (r == CV_OK)
        r = vk_tracker_status(&c->tracker);
    return r;
}

/* A list that traces rays is recorded for one trace path, chosen and made
 * ready (pipeline, accel structures) before recording. */
static cv_result prepare_traces(compiler *c) {
    uint32_t count = 0;
    for (uint32_t i = 0; i < c->list->count; i++)
        count += c->list->commands[i].type == CV_CMD_TRACE_RAYS;
    if (count == 0)
        return CV_OK;
    vk_accel **accels = malloc(count * sizeof(*accels));
    if (!accels)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "vulkan: %u traced accels", count);
    count = 0;
    for (uint32_t i = 0; i < c->list->count; i++)
        if (c->list->commands[i].type == CV_CMD_TRACE_RAYS)
            accels[count++] = object_of(c, c->list->commands[i].u.trace_rays.accel.id);
    cv_result r = vk_trace_prepare(c->bd, accels, count, &c->trace_path);
    free(accels);
    return r;
}

cv_result vk_compile_list(cv_backend_device *bd, cv_device *dev, const cv_command_list *list, vk_compiled **out) {
    vk_compiled *compiled = calloc(1, sizeof(*compiled));
    if (!compiled)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "vulkan: compiled list");
    compiler c = { .bd = bd, .dev = dev, .list = list, .out = compiled };
    vk_tracker_init(&c.tracker);
    uint8_t *slots = NULL;
    cv_result r = prepare_traces(&c);
    uint32_t indirect = 0;
    for (uint32_t i = 0; i < list->count; i++)
        indirect += list->commands[i].type == CV_CMD_DISPATCH_INDIRECT;
    if (r == CV_OK && indirect)
        r = vk_indirect_prepare(bd, indirect, &compiled->indirect);
    if (r == CV_OK)
        r = plan_slots(&c, &slots);
    if (r == CV_OK)
        r = compile(&c, slots);
    compiled->barrier_count = c.tracker.barriers_emitted;
    free(slots);
    vk_tracker_finish(&c.tracker);
    if (r != CV_OK) {
        vk_compiled_release(bd, compiled);
        return r;
    }
    *out = compiled;
    return CV_OK;
}

void vk_compiled_release(cv_backend_device *bd, vk_compiled *c) {
    for (uint32_t i = 0; i < c->segment_count; i++) {
        vk_segment *s = &c->segments[i];
        VkCommandBuffer buffers[2] = { s->body, s->prologue };
        vk_device_free_command_buffers(bd, bd->queues[s->slot].pool, 2, buffers);
    }
    free(c->segments);
    vk_timestamps_finish(bd, &c->timestamps);
    vk_indirect_release(bd, &c->indirect);
    free(c);
}
