/* Lists that move data: updates, copies, clears between buffers and textures,
 * checked byte for byte against what the commands say. */
#include <string.h>

#include "check.h"
#include "conformance.h"
#include "corvid/texel.h"

void conformance_data_movement(world *w) {
    uint32_t words[64];
    for (int i = 0; i < 64; i++)
        words[i] = 0x01000000u * (uint32_t)i + 0x1234u;
    uint8_t zeros[65536] = { 0 };
    CHECK_OK(cv_device_write_buffer(w->dev, w->big, 0, sizeof(zeros), zeros));

    cv_command_list *l = world_begin(w);
    cv_cmd_update_buffer(l, CV_QUEUE_COPY,
                         &(cv_update_buffer_args){
                             .buffer = w->big, .offset = 0, .data = words, .data_size = sizeof(words) });
    cv_cmd_copy_buffer(l, CV_QUEUE_COPY,
                       &(cv_copy_buffer_args){
                           .src = w->big, .src_offset = 16, .dst = w->big, .dst_offset = 1024, .size = 64 });
    cv_cmd_clear_buffer(l, CV_QUEUE_COMPUTE,
                        &(cv_clear_buffer_args){
                            .buffer = w->big, .offset = 2048, .size = 32, .value = 0xA5A5F00Du });
    /* 4x2 texels of rgba8 from the buffer into rgba8 at (3,5), then a texture copy and a read back to a buffer. */
    cv_cmd_copy_buffer_to_texture(
        l, CV_QUEUE_COPY,
        &(cv_copy_buffer_to_texture_args){
            .src = w->big, .src_offset = 0, .dst = w->rgba8, .dst_x = 3, .dst_y = 5, .width = 4, .height = 2 });
    cv_cmd_copy_texture(l, CV_QUEUE_COPY,
                        &(cv_copy_texture_args){ .src = w->rgba8,
                                                 .src_x = 3,
                                                 .src_y = 5,
                                                 .dst = w->rgba8_b,
                                                 .dst_x = 10,
                                                 .dst_y = 0,
                                                 .width = 4,
                                                 .height = 2 });
    cv_cmd_copy_texture_to_buffer(
        l, CV_QUEUE_COPY,
        &(cv_copy_texture_to_buffer_args){
            .src = w->rgba8_b, .src_x = 10, .src_y = 0, .width = 4, .height = 2, .dst = w->big, .dst_offset = 4096 });
    cv_cmd_clear_texture(l, CV_QUEUE_COMPUTE,
                         &(cv_clear_texture_args){
                             .texture = w->rgba32f, .r = 0.25f, .g = -2.0f, .b = 1e6f, .a = 1.0f });
    cv_cmd_clear_texture(l, CV_QUEUE_GRAPHICS,
                         &(cv_clear_texture_args){
                             .texture = w->sampled, .r = 0.2f, .g = 0.6f, .b = 1.0f, .a = 0.0f });
    CHECK_OK(world_end_and_run(w));

    uint32_t out[64];
    CHECK_OK(cv_device_read_buffer(w->dev, w->big, 0, sizeof(out), out));
    CHECK(memcmp(out, words, sizeof(words)) == 0);
    CHECK_OK(cv_device_read_buffer(w->dev, w->big, 1024, 64, out));
    CHECK(memcmp(out, words + 4, 64) == 0);
    CHECK_OK(cv_device_read_buffer(w->dev, w->big, 2048, 36, out));
    for (int i = 0; i < 8; i++)
        CHECK_EQ_INT(out[i], 0xA5A5F00Du);
    CHECK_EQ_INT(out[8], 0); /* the clear stops where it was told to */
    CHECK_OK(cv_device_read_buffer(w->dev, w->big, 4096, 32, out));
    CHECK(memcmp(out, words, 32) == 0); /* round trip buffer -> texture -> texture -> buffer */

    uint8_t texels[16 * 16 * 4];
    CHECK_OK(cv_device_read_texture(w->dev, w->rgba8, (cv_rect){ 0, 0, 16, 16 }, texels));
    CHECK(memcmp(texels + (5 * 16 + 3) * 4, words, 16) == 0);
    CHECK(memcmp(texels + (6 * 16 + 3) * 4, words + 4, 16) == 0);

    float f[16 * 16 * 4];
    CHECK_OK(cv_device_read_texture(w->dev, w->rgba32f, (cv_rect){ 0, 0, 16, 16 }, f));
    CHECK(f[0] == 0.25f && f[1] == -2.0f && f[2] == 1e6f && f[3] == 1.0f);
    CHECK(f[16 * 16 * 4 - 4] == 0.25f && f[16 * 16 * 4 - 1] == 1.0f);

    uint8_t expect[4];
    cv_texel_encode(CV_FORMAT_RGBA8_UNORM, (const float[4]){ 0.2f, 0.6f, 1.0f, 0.0f }, expect);
    CHECK(expect[0] == 51 && expect[1] == 153 && expect[2] == 255 && expect[3] == 0);
    CHECK_OK(cv_device_read_texture(w->dev, w->sampled, (cv_rect){ 15, 15, 1, 1 }, texels));
    CHECK(memcmp(texels, expect, 4) == 0);
}
