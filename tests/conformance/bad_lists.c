/* Bad command lists: each must be rejected with its expected code, on every
 * backend, and must change nothing on the device (the list's first command, a
 * valid write, must not have run). Each list is tried twice: as recorded, and
 * as decoded from its own wire encoding, the way a node receives it. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "conformance.h"
#include "corvid/command_codec.h"

#define U32S(...) \
    (const uint32_t[]) { __VA_ARGS__ }

static cv_binding buf_binding(cv_buffer b) { return (cv_binding){ .resource = cv_any(b) }; }
static cv_binding tex_binding(cv_texture t) { return (cv_binding){ .resource = cv_any(t) }; }

static void copy_out_of_range(world *w, cv_command_list *l) {
    cv_cmd_copy_buffer(l, CV_QUEUE_COPY,
                       &(cv_copy_buffer_args){ .src = w->small, .src_offset = 200, .dst = w->big, .size = 100 });
}
static void copy_overlap(world *w, cv_command_list *l) {
    cv_cmd_copy_buffer(l, CV_QUEUE_COPY,
                       &(cv_copy_buffer_args){
                           .src = w->big, .src_offset = 0, .dst = w->big, .dst_offset = 64, .size = 128 });
}
static void copy_texture_formats(world *w, cv_command_list *l) {
    cv_cmd_copy_texture(l, CV_QUEUE_COPY,
                        &(cv_copy_texture_args){ .src = w->rgba8, .dst = w->rgba32f, .width = 4, .height = 4 });
}
static void copy_texture_bounds(world *w, cv_command_list *l) {
    cv_cmd_copy_texture(l, CV_QUEUE_COPY,
                        &(cv_copy_texture_args){
                            .src = w->rgba8, .dst = w->rgba8_b, .dst_x = 10, .width = 8, .height = 4 });
}
static void buffer_to_texture_short(world *w, cv_command_list *l) {
    cv_cmd_copy_buffer_to_texture(l, CV_QUEUE_COPY,
                                  &(cv_copy_buffer_to_texture_args){ .src = w->small,
                                                                     .dst = w->rgba8,
                                                                     .width = 16,
                                                                     .height = 16 }); /* needs 1024 bytes, has 256 */
}
static void not_loaded(world *w, cv_command_list *l) {
    cv_cmd_copy_buffer(l, CV_QUEUE_COPY, &(cv_copy_buffer_args){ .src = w->unloaded, .dst = w->big, .size = 16 });
}
static void stale(world *w, cv_command_list *l) {
    cv_cmd_clear_buffer(l, CV_QUEUE_COMPUTE, &(cv_clear_buffer_args){ .buffer = w->destroyed, .size = 16 });
}
static void dispatch_graphics_pipeline(world *w, cv_command_list *l) {
    cv_binding b = buf_binding(w->big);
    cv_cmd_dispatch(l, CV_QUEUE_COMPUTE,
                    &(cv_dispatch_args){ .pipeline = w->triangle,
                                         .bindings = &b,
                                         .bindings_count = 1,
                                         .push = U32S(0, 0, 0, 0),
                                         .push_size = 16,
                                         .groups_x = 1,
                                         .groups_y = 1,
                                         .groups_z = 1 });
}
static void dispatch_binding_count(world *w, cv_command_list *l) {
    cv_binding b = buf_binding(w->big);
    cv_cmd_dispatch(l, CV_QUEUE_COMPUTE,
                    &(cv_dispatch_args){ .pipeline = w->saxpy,
                                         .bindings = &b,
                                         .bindings_count = 1,
                                         .push = U32S(0, 0),
                                         .push_size = 8,
                                         .groups_x = 1,
                                         .groups_y = 1,
                                         .groups_z = 1 });
}
static void dispatch_binding_kind(world *w, cv_command_list *l) {
    cv_binding b = tex_binding(w->rgba8);
    cv_cmd_dispatch(l, CV_QUEUE_COMPUTE,
                    &(cv_dispatch_args){ .pipeline = w->fill,
                                         .bindings = &b,
                                         .bindings_count = 1,
                                         .push = U32S(0, 0),
                                         .push_size = 8,
                                         .groups_x = 1,
                                         .groups_y = 1,
                                         .groups_z = 1 });
}
static void dispatch_push_size(world *w, cv_command_list *l) {
    cv_binding b = buf_binding(w->big);
    cv_cmd_dispatch(l, CV_QUEUE_COMPUTE,
                    &(cv_dispatch_args){ .pipeline = w->fill,
                                         .bindings = &b,
                                         .bindings_count = 1,
                                         .push = U32S(0),
                                         .push_size = 4,
                                         .groups_x = 1,
                                         .groups_y = 1,
                                         .groups_z = 1 });
}
static void dispatch_zero_groups(world *w, cv_command_list *l) {
    cv_binding b = buf_binding(w->big);
    cv_cmd_dispatch(l, CV_QUEUE_COMPUTE,
                    &(cv_dispatch_args){ .pipeline = w->fill,
                                         .bindings = &b,
                                         .bindings_count = 1,
                                         .push = U32S(0, 0),
                                         .push_size = 8,
                                         .groups_x = 0,
                                         .groups_y = 1,
                                         .groups_z = 1 });
}
static void dispatch_too_many_groups(world *w, cv_command_list *l) {
    cv_binding b = buf_binding(w->big);
    uint32_t limit = cv_device_get_info(w->dev)->max_dispatch[1]; /* 65535 on lavapipe and NVIDIA */
    cv_cmd_dispatch(l, CV_QUEUE_COMPUTE,
                    &(cv_dispatch_args){ .pipeline = w->fill,
                                         .bindings = &b,
                                         .bindings_count = 1,
                                         .push = U32S(0, 0),
                                         .push_size = 8,
                                         .groups_x = 1,
                                         .groups_y = limit + 1,
                                         .groups_z = 1 });
}
static void storage_texture_without_usage(world *w, cv_command_list *l) {
    cv_binding b = tex_binding(w->sampled);
    cv_cmd_dispatch(l, CV_QUEUE_COMPUTE,
                    &(cv_dispatch_args){ .pipeline = w->gradient,
                                         .bindings = &b,
                                         .bindings_count = 1,
                                         .push = U32S(16, 16),
                                         .push_size = 8,
                                         .groups_x = 2,
                                         .groups_y = 2,
                                         .groups_z = 1 });
}
static void indirect_without_usage(world *w, cv_command_list *l) {
    cv_binding b = buf_binding(w->big);
    cv_cmd_dispatch_indirect(l, CV_QUEUE_COMPUTE,
                             &(cv_dispatch_indirect_args){ .pipeline = w->fill,
                                                           .bindings = &b,
                                                           .bindings_count = 1,
                                                           .push = U32S(0, 0),
                                                           .push_size = 8,
                                                           .args = w->small });
}
static void storage_binding_unaligned(world *w, cv_command_list *l) {
    cv_binding b = { .resource = cv_any(w->big), .offset = 100 };
    cv_cmd_dispatch(l, CV_QUEUE_COMPUTE,
                    &(cv_dispatch_args){ .pipeline = w->fill,
                                         .bindings = &b,
                                         .bindings_count = 1,
                                         .push = U32S(0, 0),
                                         .push_size = 8,
                                         .groups_x = 1,
                                         .groups_y = 1,
                                         .groups_z = 1 });
}
static void sampled_without_sampler(world *w, cv_command_list *l) {
    cv_binding b[2] = { tex_binding(w->sampled), tex_binding(w->rgba8) };
    cv_cmd_dispatch(l, CV_QUEUE_COMPUTE,
                    &(cv_dispatch_args){ .pipeline = w->sample_copy,
                                         .bindings = b,
                                         .bindings_count = 2,
                                         .push = U32S(16, 16),
                                         .push_size = 8,
                                         .groups_x = 2,
                                         .groups_y = 2,
                                         .groups_z = 1 });
}
static void draw_target_format(world *w, cv_command_list *l) {
    cv_binding b = buf_binding(w->big);
    cv_cmd_begin_render_pass(l, CV_QUEUE_GRAPHICS, &(cv_begin_render_pass_args){ .color0 = w->rgba8 });
    cv_cmd_draw(l, CV_QUEUE_GRAPHICS,
                &(cv_draw_args){ .pipeline = w->triangle,
                                 .bindings = &b,
                                 .bindings_count = 1,
                                 .push = U32S(0, 0, 0, 0),
                                 .push_size = 16,
                                 .vertex_count = 3,
                                 .instance_count = 1 }); /* pipeline wants depth too */
    cv_cmd_end_render_pass(l, CV_QUEUE_GRAPHICS, &(cv_end_render_pass_args){ 0 });
}
static void render_target_without_usage(world *w, cv_command_list *l) {
    cv_cmd_begin_render_pass(l, CV_QUEUE_GRAPHICS, &(cv_begin_render_pass_args){ .color0 = w->rgba32f });
    cv_cmd_end_render_pass(l, CV_QUEUE_GRAPHICS, &(cv_end_render_pass_args){ 0 });
}
static void index_out_of_range(world *w, cv_command_list *l) {
    cv_binding b = buf_binding(w->big);
    cv_cmd_begin_render_pass(l, CV_QUEUE_GRAPHICS,
                             &(cv_begin_render_pass_args){ .color0 = w->rgba8, .depth = w->depth });
    cv_cmd_draw_indexed(l, CV_QUEUE_GRAPHICS,
                        &(cv_draw_indexed_args){ .pipeline = w->triangle,
                                                 .bindings = &b,
                                                 .bindings_count = 1,
                                                 .push = U32S(0, 0, 0, 0),
                                                 .push_size = 16,
                                                 .index_buffer = w->big,
                                                 .index_offset = 65536 - 8,
                                                 .index_count = 3,
                                                 .instance_count = 1 });
    cv_cmd_end_render_pass(l, CV_QUEUE_GRAPHICS, &(cv_end_render_pass_args){ 0 });
}
/* Offsets and counts whose sums or products pass 2^64 (or 2^32 for u32 counts):
 * each would wrap to a small, in-range value if computed naively. */
static void indexed_draw(world *w, cv_command_list *l, const cv_draw_indexed_args *a) {
    cv_binding b = buf_binding(w->big);
    cv_draw_indexed_args args = *a;
    args.pipeline = w->triangle;
    args.bindings = &b;
    args.bindings_count = 1;
    args.push = U32S(0, 0, 0, 0);
    args.push_size = 16;
    args.index_buffer = w->big;
    cv_cmd_begin_render_pass(l, CV_QUEUE_GRAPHICS,
                             &(cv_begin_render_pass_args){ .color0 = w->rgba8, .depth = w->depth });
    cv_cmd_draw_indexed(l, CV_QUEUE_GRAPHICS, &args);
    cv_cmd_end_render_pass(l, CV_QUEUE_GRAPHICS, &(cv_end_render_pass_args){ 0 });
}
static void index_offset_wraps(world *w, cv_command_list *l) {
    indexed_draw(w, l,
                 &(cv_draw_indexed_args){ .index_offset = 0xFFFFFFFFFFFFFFFCull,
                                          .first_index = 1,
                                          .index_count = 3,
                                          .instance_count = 1 });
}
static void first_index_wraps(world *w, cv_command_list *l) {
    indexed_draw(w, l,
                 &(cv_draw_indexed_args){ .index_offset = UINT64_MAX - 4ull * UINT32_MAX + 1,
                                          .first_index = UINT32_MAX,
                                          .index_count = 1,
                                          .instance_count = 1 });
}
static void indexed_instances_wrap(world *w, cv_command_list *l) {
    indexed_draw(w, l,
                 &(cv_draw_indexed_args){ .index_count = 3, .instance_count = 2, .first_instance = UINT32_MAX });
}
static void vertices_wrap(world *w, cv_command_list *l) {
    cv_binding b = buf_binding(w->big);
    cv_cmd_begin_render_pass(l, CV_QUEUE_GRAPHICS,
                             &(cv_begin_render_pass_args){ .color0 = w->rgba8, .depth = w->depth });
    cv_cmd_draw(l, CV_QUEUE_GRAPHICS,
                &(cv_draw_args){ .pipeline = w->triangle,
                                 .bindings = &b,
                                 .bindings_count = 1,
                                 .push = U32S(0, 0, 0, 0),
                                 .push_size = 16,
                                 .vertex_count = 3,
                                 .first_vertex = UINT32_MAX - 1,
                                 .instance_count = 1 });
    cv_cmd_end_render_pass(l, CV_QUEUE_GRAPHICS, &(cv_end_render_pass_args){ 0 });
}
static void instances_wrap(world *w, cv_command_list *l) {
    cv_binding b = buf_binding(w->big);
    cv_cmd_begin_render_pass(l, CV_QUEUE_GRAPHICS,
                             &(cv_begin_render_pass_args){ .color0 = w->rgba8, .depth = w->depth });
    cv_cmd_draw(l, CV_QUEUE_GRAPHICS,
                &(cv_draw_args){ .pipeline = w->triangle,
                                 .bindings = &b,
                                 .bindings_count = 1,
                                 .push = U32S(0, 0, 0, 0),
                                 .push_size = 16,
                                 .vertex_count = 3,
                                 .instance_count = 4,
                                 .first_instance = UINT32_MAX - 2 });
    cv_cmd_end_render_pass(l, CV_QUEUE_GRAPHICS, &(cv_end_render_pass_args){ 0 });
}
static void copy_offset_wraps(world *w, cv_command_list *l) {
    cv_cmd_copy_buffer(l, CV_QUEUE_COPY,
                       &(cv_copy_buffer_args){
                           .src = w->big, .src_offset = UINT64_MAX - 63, .dst = w->small, .size = 128 });
}
static void copy_dst_offset_wraps(world *w, cv_command_list *l) {
    cv_cmd_copy_buffer(l, CV_QUEUE_COPY,
                       &(cv_copy_buffer_args){
                           .src = w->big, .dst = w->small, .dst_offset = UINT64_MAX - 63, .size = 128 });
}
static void clear_offset_wraps(world *w, cv_command_list *l) {
    cv_cmd_clear_buffer(l, CV_QUEUE_COMPUTE,
                        &(cv_clear_buffer_args){ .buffer = w->small, .offset = UINT64_MAX - 15, .size = 32 });
}
static void update_offset_wraps(world *w, cv_command_list *l) {
    cv_cmd_update_buffer(l, CV_QUEUE_COPY,
                         &(cv_update_buffer_args){
                             .buffer = w->small, .offset = UINT64_MAX - 3, .data = "abcdefgh", .data_size = 8 });
}
static void binding_range_wraps(world *w, cv_command_list *l) {
    cv_binding b = { .resource = cv_any(w->big), .offset = 256, .range = UINT64_MAX - 255 };
    cv_cmd_dispatch(l, CV_QUEUE_COMPUTE,
                    &(cv_dispatch_args){ .pipeline = w->fill,
                                         .bindings = &b,
                                         .bindings_count = 1,
                                         .push = U32S(0, 0),
                                         .push_size = 8,
                                         .groups_x = 1,
                                         .groups_y = 1,
                                         .groups_z = 1 });
}
static void indirect_offset_wraps(world *w, cv_command_list *l) {
    cv_binding b = buf_binding(w->big);
    cv_cmd_dispatch_indirect(l, CV_QUEUE_COMPUTE,
                             &(cv_dispatch_indirect_args){ .pipeline = w->fill,
                                                           .bindings = &b,
                                                           .bindings_count = 1,
                                                           .push = U32S(0, 0),
                                                           .push_size = 8,
                                                           .args = w->big,
                                                           .args_offset = UINT64_MAX - 7 });
}
static void upload_offset_wraps(world *w, cv_command_list *l) {
    cv_cmd_copy_buffer_to_texture(
        l, CV_QUEUE_COPY,
        &(cv_copy_buffer_to_texture_args){
            .src = w->big, .src_offset = UINT64_MAX - 1023, .dst = w->rgba8, .width = 16, .height = 16 });
}
static void download_offset_wraps(world *w, cv_command_list *l) {
    cv_cmd_copy_texture_to_buffer(
        l, CV_QUEUE_COPY,
        &(cv_copy_texture_to_buffer_args){
            .src = w->rgba8, .width = 16, .height = 16, .dst = w->big, .dst_offset = UINT64_MAX - 1023 });
}
static void texture_x_wraps(world *w, cv_command_list *l) {
    cv_cmd_copy_texture(l, CV_QUEUE_COPY,
                        &(cv_copy_texture_args){
                            .src = w->rgba8, .src_x = UINT32_MAX - 1, .dst = w->rgba8_b, .width = 4, .height = 4 });
}
static void texture_y_wraps(world *w, cv_command_list *l) {
    cv_cmd_copy_texture(l, CV_QUEUE_COPY,
                        &(cv_copy_texture_args){
                            .src = w->rgba8, .dst = w->rgba8_b, .dst_y = UINT32_MAX - 1, .width = 4, .height = 4 });
}
static void trace_hits_offset_wraps(world *w, cv_command_list *l) {
    cv_cmd_trace_rays(
        l, CV_QUEUE_COMPUTE,
        &(cv_trace_rays_args){
            .accel = w->accel, .rays = w->big, .hits = w->small, .hits_offset = UINT64_MAX - 255, .count = 4 });
}
static void trace_rays_offset_wraps(world *w, cv_command_list *l) {
    cv_cmd_trace_rays(
        l, CV_QUEUE_COMPUTE,
        &(cv_trace_rays_args){
            .accel = w->accel, .rays = w->big, .rays_offset = UINT64_MAX - 255, .hits = w->small, .count = 4 });
}
static void update_unaligned(world *w, cv_command_list *l) {
    cv_cmd_update_buffer(l, CV_QUEUE_COPY,
                         &(cv_update_buffer_args){ .buffer = w->big, .offset = 8, .data = "abcdef", .data_size = 6 });
}
static void clear_depth_as_color(world *w, cv_command_list *l) {
    cv_cmd_clear_texture(l, CV_QUEUE_COMPUTE, &(cv_clear_texture_args){ .texture = w->depth, .r = 1 });
}
static void trace_unbuilt_accel(world *w, cv_command_list *l) {
    cv_cmd_trace_rays(l, CV_QUEUE_COMPUTE,
                      &(cv_trace_rays_args){
                          .accel = w->accel_unbuilt, .rays = w->big, .hits = w->small, .count = 4 });
}
static void trace_too_many_rays(world *w, cv_command_list *l) {
    cv_cmd_trace_rays(l, CV_QUEUE_COMPUTE,
                      &(cv_trace_rays_args){
                          .accel = w->accel, .rays = w->big, .hits = w->small, .count = 100 }); /* 2000 hit bytes */
}
static void trace_into_its_rays(world *w, cv_command_list *l) {
    cv_cmd_trace_rays(l, CV_QUEUE_COMPUTE,
                      &(cv_trace_rays_args){
                          .accel = w->accel, .rays = w->big, .hits = w->big, .hits_offset = 4096, .count = 4 });
}
/* Recording-time errors: the list never becomes executable. */
static void trace_unknown_flags(world *w, cv_command_list *l) {
    cv_cmd_trace_rays(l, CV_QUEUE_COMPUTE,
                      &(cv_trace_rays_args){
                          .accel = w->accel, .rays = w->big, .hits = w->small, .count = 4, .flags = 0x80 });
}
static void draw_on_compute_queue(world *w, cv_command_list *l) {
    cv_binding b = buf_binding(w->big);
    cv_cmd_draw(l, CV_QUEUE_COMPUTE,
                &(cv_draw_args){ .pipeline = w->triangle,
                                 .bindings = &b,
                                 .bindings_count = 1,
                                 .push = U32S(0, 0, 0, 0),
                                 .push_size = 16,
                                 .vertex_count = 3,
                                 .instance_count = 1 });
}
static void draw_outside_pass(world *w, cv_command_list *l) {
    cv_binding b = buf_binding(w->big);
    cv_cmd_draw(l, CV_QUEUE_GRAPHICS,
                &(cv_draw_args){ .pipeline = w->triangle,
                                 .bindings = &b,
                                 .bindings_count = 1,
                                 .push = U32S(0, 0, 0, 0),
                                 .push_size = 16,
                                 .vertex_count = 3,
                                 .instance_count = 1 });
}
static void texture_in_buffer_field(world *w, cv_command_list *l) {
    cv_cmd_copy_buffer(l, CV_QUEUE_COPY, &(cv_copy_buffer_args){ .src = { w->rgba8.id }, .dst = w->big, .size = 4 });
}
static void update_too_large(world *w, cv_command_list *l) {
    static uint8_t blob[CV_MAX_UPDATE_BYTES + 4];
    cv_cmd_update_buffer(l, CV_QUEUE_COPY,
                         &(cv_update_buffer_args){ .buffer = w->big, .data = blob, .data_size = sizeof(blob) });
}
static void unclosed_render_pass(world *w, cv_command_list *l) {
    cv_cmd_begin_render_pass(l, CV_QUEUE_GRAPHICS, &(cv_begin_render_pass_args){ .color0 = w->rgba8 });
}

typedef struct bad_case {
    const char *name;
    void (*record)(world *w, cv_command_list *l);
    cv_result expected;
    uint32_t at; /* command index the message must name (0 = 1, the command after the valid write) */
} bad_case;

static const bad_case cases[] = {
    { "copy out of range", copy_out_of_range, CV_ERROR_OUT_OF_RANGE },
    { "copy overlapping itself", copy_overlap, CV_ERROR_INVALID_ARGUMENT },
    { "copy between texture formats", copy_texture_formats, CV_ERROR_FORMAT_MISMATCH },
    { "texture copy out of bounds", copy_texture_bounds, CV_ERROR_OUT_OF_RANGE },
    { "buffer too small for texture upload", buffer_to_texture_short, CV_ERROR_OUT_OF_RANGE },
    { "handle not loaded", not_loaded, CV_ERROR_NOT_LOADED },
    { "stale handle", stale, CV_ERROR_STALE_HANDLE },
    { "dispatch with a graphics pipeline", dispatch_graphics_pipeline, CV_ERROR_INVALID_ARGUMENT },
    { "dispatch with too few bindings", dispatch_binding_count, CV_ERROR_BINDING_MISMATCH },
    { "texture bound as a buffer", dispatch_binding_kind, CV_ERROR_BINDING_MISMATCH },
    { "wrong push constant size", dispatch_push_size, CV_ERROR_INVALID_ARGUMENT },
    { "dispatch of zero groups", dispatch_zero_groups, CV_ERROR_OUT_OF_RANGE },
    { "dispatch over the group limit", dispatch_too_many_groups, CV_ERROR_OUT_OF_RANGE },
    { "storage texture without storage usage", storage_texture_without_usage, CV_ERROR_USAGE_MISMATCH },
    { "indirect args without indirect usage", indirect_without_usage, CV_ERROR_USAGE_MISMATCH },
    { "unaligned storage binding offset", storage_binding_unaligned, CV_ERROR_INVALID_ARGUMENT },
    { "sampled texture without a sampler", sampled_without_sampler, CV_ERROR_INVALID_HANDLE },
    { "pipeline formats differ from the pass", draw_target_format, CV_ERROR_FORMAT_MISMATCH, 2 },
    { "render target without color usage", render_target_without_usage, CV_ERROR_USAGE_MISMATCH },
    { "indices out of range", index_out_of_range, CV_ERROR_OUT_OF_RANGE, 2 },
    { "index offset + first index wraps 2^64", index_offset_wraps, CV_ERROR_OUT_OF_RANGE, 2 },
    { "first index * 4 wraps the index offset", first_index_wraps, CV_ERROR_OUT_OF_RANGE, 2 },
    { "indexed first instance + count wraps 2^32", indexed_instances_wrap, CV_ERROR_OUT_OF_RANGE, 2 },
    { "first vertex + count wraps 2^32", vertices_wrap, CV_ERROR_OUT_OF_RANGE, 2 },
    { "first instance + count wraps 2^32", instances_wrap, CV_ERROR_OUT_OF_RANGE, 2 },
    { "copy source offset + size wraps", copy_offset_wraps, CV_ERROR_OUT_OF_RANGE },
    { "copy destination offset + size wraps", copy_dst_offset_wraps, CV_ERROR_OUT_OF_RANGE },
    { "clear offset + size wraps", clear_offset_wraps, CV_ERROR_OUT_OF_RANGE },
    { "update offset + size wraps", update_offset_wraps, CV_ERROR_OUT_OF_RANGE },
    { "binding offset + range wraps", binding_range_wraps, CV_ERROR_OUT_OF_RANGE },
    { "indirect args offset + 12 wraps", indirect_offset_wraps, CV_ERROR_OUT_OF_RANGE },
    { "upload offset + rows wraps", upload_offset_wraps, CV_ERROR_OUT_OF_RANGE },
    { "download offset + rows wraps", download_offset_wraps, CV_ERROR_OUT_OF_RANGE },
    { "texture copy x + width wraps", texture_x_wraps, CV_ERROR_OUT_OF_RANGE },
    { "texture copy y + height wraps", texture_y_wraps, CV_ERROR_OUT_OF_RANGE },
    { "hits offset + count wraps", trace_hits_offset_wraps, CV_ERROR_OUT_OF_RANGE },
    { "rays offset + count wraps", trace_rays_offset_wraps, CV_ERROR_OUT_OF_RANGE },
    { "unaligned buffer update", update_unaligned, CV_ERROR_INVALID_ARGUMENT },
    { "color clear of a depth texture", clear_depth_as_color, CV_ERROR_FORMAT_MISMATCH },
    { "trace against an unbuilt accel", trace_unbuilt_accel, CV_ERROR_BAD_STATE },
    { "more hits than the hit buffer holds", trace_too_many_rays, CV_ERROR_OUT_OF_RANGE },
    { "hits written over the rays", trace_into_its_rays, CV_ERROR_INVALID_ARGUMENT },
    { "trace with unknown flags", trace_unknown_flags, CV_ERROR_INVALID_ARGUMENT },
    { "draw on the compute queue", draw_on_compute_queue, CV_ERROR_QUEUE_MISMATCH },
    { "draw outside a render pass", draw_outside_pass, CV_ERROR_BAD_STATE },
    { "texture handle in a buffer field", texture_in_buffer_field, CV_ERROR_WRONG_HANDLE_TYPE },
    { "update over 64 KiB", update_too_large, CV_ERROR_LIMIT_EXCEEDED },
    { "list ends inside a render pass", unclosed_render_pass, CV_ERROR_BAD_STATE, 2 },
};

/* Ends the list; if `wire`, replaces it by its own encoding decoded, as a node
 * receives it. Then submits it and waits: the first failure's code. */
static cv_result end_and_run(world *w, bool wire) {
    cv_command_list *l = NULL;
    cv_result r = cv_cmdlist_get(w->ctx, w->list, &l);
    if (r == CV_OK)
        r = cv_command_list_end(l);
    if (r == CV_OK && wire) {
        uint8_t *bytes = NULL;
        size_t size = 0;
        r = cv_command_list_encode(l, &bytes, &size);
        if (r == CV_OK)
            r = cv_command_list_decode(bytes, size, l);
        free(bytes);
    }
    uint64_t ticket = 0;
    if (r == CV_OK)
        r = cv_device_submit(w->dev, w->list, &ticket);
    if (r == CV_OK)
        r = cv_device_wait(w->dev, ticket, UINT64_MAX);
    return r;
}

void conformance_bad_lists(world *w) {
    const uint32_t zero[4] = { 0 }, marker[4] = { 0xC0FFEE01, 0xC0FFEE02, 0xC0FFEE03, 0xC0FFEE04 };
    uint32_t distinct_codes = 0;
    cv_result seen[32];
    for (size_t i = 0; i < sizeof(cases) / sizeof(cases[0]); i++) {
        for (int wire = 0; wire < 2; wire++) {
            const char *how = wire ? "decoded" : "recorded";
            CHECK_OK(cv_device_write_buffer(w->dev, w->small, 0, sizeof(zero), zero));
            cv_command_list *l = world_begin(w);
            /* A valid first command: if the list ran at all, small[0..16) would change. */
            cv_cmd_update_buffer(l, CV_QUEUE_COPY,
                                 &(cv_update_buffer_args){
                                     .buffer = w->small, .data = marker, .data_size = sizeof(marker) });
            cases[i].record(w, l);
            cv_result r = end_and_run(w, wire);
            if (r != cases[i].expected)
                fprintf(stderr, "[%s] bad list '%s' (%s): got %s, expected %s (%s)\n", w->fx->name, cases[i].name,
                        how, cv_result_name(r), cv_result_name(cases[i].expected), cv_last_error());
            CHECK_EQ_INT(r, cases[i].expected);
            char where[32];
            snprintf(where, sizeof(where), "command %u", cases[i].at ? cases[i].at : 1);
            if (!strstr(cv_last_error(), where))
                fprintf(stderr, "[%s] bad list '%s' (%s): message does not name %s: %s\n", w->fx->name, cases[i].name,
                        how, where, cv_last_error());
            CHECK(strstr(cv_last_error(), where) != NULL); /* the message names the offending command */
            uint32_t after[4] = { 1, 1, 1, 1 };
            CHECK_OK(cv_device_read_buffer(w->dev, w->small, 0, sizeof(after), after));
            CHECK(memcmp(after, zero, sizeof(zero)) == 0);
            uint32_t k = 0;
            while (k < distinct_codes && seen[k] != r)
                k++;
            if (k == distinct_codes && distinct_codes < 32)
                seen[distinct_codes++] = r;
        }
    }
    CHECK(sizeof(cases) / sizeof(cases[0]) >= 15);
    CHECK(distinct_codes >= 10);
    /* A rejected list stays rejected: submitting it again fails the same way. */
    uint64_t ticket;
    CHECK_RESULT(cv_device_submit(w->dev, w->list, &ticket), CV_ERROR_BAD_STATE);
}
