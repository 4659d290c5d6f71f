/* The one table of high-level commands.
 *
 * Everything about a command is derived from here: its enum value, the C
 * structs used to record and store it (command_list.h), its recording function,
 * its protobuf encoding (command_codec.c) and the check that proto/corvid.proto
 * declares the same messages and fields (tests/codec). Add a command here and in
 * the .proto, and everything else follows or a test fails.
 *
 * CV_COMMAND_TABLE: X(id, UPPER, lower, Camel, allowed queue bits)
 *   id is also the field number of the command in proto's Command.cmd oneof;
 *   Camel + "Cmd" is the proto message name. UPPER must be Camel in UPPER_SNAKE
 *   form and lower its lower_snake form: protobuf-c derives CORVID__<UPPER>_CMD__INIT
 *   and CORVID__COMMAND__CMD_<UPPER> from <Camel>Cmd and <lower>, and the codec
 *   pastes these tokens (a mismatch fails to compile).
 * CV_FIELDS_<lower>: F(field number, TYPE, name), TYPE one of
 *   U32 U64 I32 F32          scalars
 *   BUFFER TEXTURE PIPELINE ACCEL  typed handles (uint64 on the wire)
 *   ANY                      a handle of any type, 0 allowed (barrier target)
 *   BYTES                    up to CV_MAX_UPDATE_BYTES of data
 *   STRING                   a label, at most CV_LABEL_MAX-1 bytes
 *   BINDINGS                 up to CV_MAX_BINDINGS cv_binding (repeated Binding) */
#ifndef CORVID_COMMAND_TABLE_H
#define CORVID_COMMAND_TABLE_H

#include "corvid/types.h"

#define CV_Q_ALL CV_QUEUE_BIT_ALL
#define CV_Q_GC (CV_QUEUE_BIT_GRAPHICS | CV_QUEUE_BIT_COMPUTE)
#define CV_Q_G CV_QUEUE_BIT_GRAPHICS

/* clang-format off */
#define CV_COMMAND_TABLE(X)                                                               \
    X(1, DISPATCH, dispatch, Dispatch, CV_Q_GC)                                           \
    X(2, DISPATCH_INDIRECT, dispatch_indirect, DispatchIndirect, CV_Q_GC)                 \
    X(3, BEGIN_RENDER_PASS, begin_render_pass, BeginRenderPass, CV_Q_G)                   \
    X(4, END_RENDER_PASS, end_render_pass, EndRenderPass, CV_Q_G)                         \
    X(5, DRAW, draw, Draw, CV_Q_G)                                                        \
    X(6, DRAW_INDEXED, draw_indexed, DrawIndexed, CV_Q_G)                                 \
    X(7, COPY_BUFFER, copy_buffer, CopyBuffer, CV_Q_ALL)                                  \
    X(8, COPY_TEXTURE, copy_texture, CopyTexture, CV_Q_ALL)                               \
    X(9, COPY_BUFFER_TO_TEXTURE, copy_buffer_to_texture, CopyBufferToTexture, CV_Q_ALL)   \
    X(10, COPY_TEXTURE_TO_BUFFER, copy_texture_to_buffer, CopyTextureToBuffer, CV_Q_ALL)  \
    X(11, CLEAR_BUFFER, clear_buffer, ClearBuffer, CV_Q_ALL)                              \
    X(12, CLEAR_TEXTURE, clear_texture, ClearTexture, CV_Q_GC)                            \
    X(13, UPDATE_BUFFER, update_buffer, UpdateBuffer, CV_Q_ALL)                           \
    X(14, BARRIER, barrier, Barrier, CV_Q_ALL)                                            \
    X(15, TIMESTAMP, timestamp, Timestamp, CV_Q_ALL)                                      \
    X(16, BEGIN_MARKER, begin_marker, BeginMarker, CV_Q_ALL)                              \
    X(17, END_MARKER, end_marker, EndMarker, CV_Q_ALL)                                    \
    X(18, TRACE_RAYS, trace_rays, TraceRays, CV_Q_GC)

/* Compute dispatch of groups_x * groups_y * groups_z workgroups. */
#define CV_FIELDS_dispatch(F) \
    F(1, PIPELINE, pipeline) F(2, BINDINGS, bindings) F(3, BYTES, push) \
    F(4, U32, groups_x) F(5, U32, groups_y) F(6, U32, groups_z)
/* Dispatch whose group counts are three u32 read from `args` at `args_offset`. */
#define CV_FIELDS_dispatch_indirect(F) \
    F(1, PIPELINE, pipeline) F(2, BINDINGS, bindings) F(3, BYTES, push) \
    F(4, BUFFER, args) F(5, U64, args_offset)
/* Dynamic rendering into color0 (and color1, depth if non-zero). Targets are
 * cleared when clear is non-zero, else loaded. */
#define CV_FIELDS_begin_render_pass(F) \
    F(1, TEXTURE, color0) F(2, TEXTURE, color1) F(3, TEXTURE, depth) F(4, U32, clear) \
    F(5, F32, clear_r) F(6, F32, clear_g) F(7, F32, clear_b) F(8, F32, clear_a) \
    F(9, F32, clear_depth)
#define CV_FIELDS_end_render_pass(F)
/* Non-indexed draw; vertices are pulled from storage buffers by the shader. */
#define CV_FIELDS_draw(F) \
    F(1, PIPELINE, pipeline) F(2, BINDINGS, bindings) F(3, BYTES, push) \
    F(4, U32, vertex_count) F(5, U32, instance_count) F(6, U32, first_vertex) \
    F(7, U32, first_instance)
/* Indexed draw with 32-bit indices from index_buffer at index_offset. */
#define CV_FIELDS_draw_indexed(F) \
    F(1, PIPELINE, pipeline) F(2, BINDINGS, bindings) F(3, BYTES, push) \
    F(4, BUFFER, index_buffer) F(5, U64, index_offset) F(6, U32, index_count) \
    F(7, U32, instance_count) F(8, U32, first_index) F(9, I32, vertex_offset) \
    F(10, U32, first_instance)
#define CV_FIELDS_copy_buffer(F) \
    F(1, BUFFER, src) F(2, U64, src_offset) F(3, BUFFER, dst) F(4, U64, dst_offset) \
    F(5, U64, size)
/* Texel rectangle copy between textures of the same format. */
#define CV_FIELDS_copy_texture(F) \
    F(1, TEXTURE, src) F(2, U32, src_x) F(3, U32, src_y) F(4, TEXTURE, dst) \
    F(5, U32, dst_x) F(6, U32, dst_y) F(7, U32, width) F(8, U32, height)
/* Rows are tightly packed in the buffer (width * texel bytes). */
#define CV_FIELDS_copy_buffer_to_texture(F) \
    F(1, BUFFER, src) F(2, U64, src_offset) F(3, TEXTURE, dst) F(4, U32, dst_x) \
    F(5, U32, dst_y) F(6, U32, width) F(7, U32, height)
#define CV_FIELDS_copy_texture_to_buffer(F) \
    F(1, TEXTURE, src) F(2, U32, src_x) F(3, U32, src_y) F(4, U32, width) \
    F(5, U32, height) F(6, BUFFER, dst) F(7, U64, dst_offset)
/* Fills size bytes (a multiple of 4) with the 32-bit value. */
#define CV_FIELDS_clear_buffer(F) \
    F(1, BUFFER, buffer) F(2, U64, offset) F(3, U64, size) F(4, U32, value)
#define CV_FIELDS_clear_texture(F) \
    F(1, TEXTURE, texture) F(2, F32, r) F(3, F32, g) F(4, F32, b) F(5, F32, a)
/* Writes data (a multiple of 4 bytes, at most CV_MAX_UPDATE_BYTES) at offset. */
#define CV_FIELDS_update_buffer(F) \
    F(1, BUFFER, buffer) F(2, U64, offset) F(3, BYTES, data)
/* A hint: backends insert barriers themselves. resource 0 = everything. */
#define CV_FIELDS_barrier(F) F(1, ANY, resource)
#define CV_FIELDS_timestamp(F) F(1, STRING, label)
/* Debug marker; each begin/end pair is also a timed pass (device.h). */
#define CV_FIELDS_begin_marker(F) F(1, STRING, label)
#define CV_FIELDS_end_marker(F)
/* Traces `count` rays (cv_ray) against `accel`, writing one cv_hit per ray.
 * flags: cv_trace_flags. The device runs whichever trace path it measured
 * faster (its own compute traversal or the driver's ray-tracing pipeline);
 * both report the same hits. */
#define CV_FIELDS_trace_rays(F) \
    F(1, ACCEL, accel) F(2, BUFFER, rays) F(3, U64, rays_offset) F(4, BUFFER, hits) \
    F(5, U64, hits_offset) F(6, U32, count) F(7, U32, flags)

typedef enum cv_command_type {
    CV_CMD_NONE = 0,
#define CV_CMD_ENUM(id, UPPER, lower, Camel, queues) CV_CMD_##UPPER = id,
    CV_COMMAND_TABLE(CV_CMD_ENUM)
#undef CV_CMD_ENUM
    CV_CMD_TYPE_END
} cv_command_type;
/* clang-format on */

const char *cv_command_name(cv_command_type t); /* "dispatch", ... or "unknown" */
uint32_t cv_command_queues(cv_command_type t);  /* allowed queue bits, 0 if unknown */

#endif
