/* Encode/decode round trips: random lists of every command type survive
 * exactly (field by field and byte for byte), the encoding is the one
 * protobuf-c itself gives for a CommandList, and limits hold in both
 * directions. */
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "corvid.pb-c.h"
#include "corvid/command_codec.h"
#include "random_list.h"

/* Independent view through protobuf-c's own CommandList unpack and pack:
 * same bytes, and each Command carries the table id and queue of its
 * recorded command. */
static void check_against_protobuf_c(const cv_command_list *list, const uint8_t *bytes, size_t size) {
    Corvid__CommandList *pl = corvid__command_list__unpack(NULL, size, bytes);
    CHECK(pl != NULL);
    if (!pl)
        return;
    CHECK_EQ_INT(pl->n_commands, list->count);
    for (size_t i = 0; i < pl->n_commands && i < list->count; i++) {
        CHECK_EQ_INT(pl->commands[i]->cmd_case, list->commands[i].type);
        CHECK_EQ_INT(pl->commands[i]->queue, list->commands[i].queue);
    }
    size_t repacked_size = corvid__command_list__get_packed_size(pl);
    CHECK_EQ_INT(repacked_size, size);
    uint8_t *repacked = malloc(repacked_size + 1);
    corvid__command_list__pack(pl, repacked);
    CHECK(repacked_size == size && memcmp(repacked, bytes, size) == 0);
    free(repacked);
    corvid__command_list__free_unpacked(pl, NULL);
}

static void round_trip(const cv_command_list *list, const char *what) {
    uint8_t *bytes = NULL;
    size_t size = 0;
    CHECK_OK(cv_command_list_encode(list, &bytes, &size));
    check_against_protobuf_c(list, bytes, size);

    cv_command_list decoded;
    cv_command_list_init(&decoded);
    CHECK_OK(cv_command_list_decode(bytes, size, &decoded));
    CHECK(lists_equal(list, &decoded, what));
    CHECK(decoded.ended_ok);
    CHECK(!decoded.recording);

    /* Decoding then encoding again gives the same bytes. */
    uint8_t *again = NULL;
    size_t again_size = 0;
    CHECK_OK(cv_command_list_encode(&decoded, &again, &again_size));
    CHECK(again_size == size && memcmp(again, bytes, size) == 0);
    free(again);
    free(bytes);
    cv_command_list_finish(&decoded);
}

static void test_random_lists(void) {
    for (uint64_t seed = 1; seed <= 24; seed++) {
        cv_command_list list;
        cv_command_list_init(&list);
        CHECK_OK(random_list_record(&list, seed * 7919, 40 + (uint32_t)seed * 20));
        CHECK(list.count > 17);
        char what[32];
        snprintf(what, sizeof(what), "seed %llu", (unsigned long long)seed);
        round_trip(&list, what);
        cv_command_list_finish(&list);
    }
}

/* Every field at its limit: 16 bindings, 128 bytes of push constants, a
 * 64 KiB update, a 47-byte label, all-ones scalars, negative offsets. */
static void test_limits_round_trip(void) {
    cv_command_list list;
    cv_command_list_init(&list);
    cv_command_list_begin(&list);
    cv_binding bindings[CV_MAX_BINDINGS];
    for (uint32_t i = 0; i < CV_MAX_BINDINGS; i++)
        bindings[i] = (cv_binding){ { cv_handle_pack(CV_HANDLE_TEXTURE, CV_HANDLE_TAG_MAX, CV_HANDLE_GENERATION_MAX,
                                                     CV_HANDLE_INDEX_MAX - i) },
                                    { cv_handle_pack(CV_HANDLE_SAMPLER, 1, 1, i) },
                                    UINT64_MAX - i,
                                    UINT64_MAX };
    uint8_t push[CV_MAX_PUSH_CONSTANTS];
    for (uint32_t i = 0; i < sizeof(push); i++)
        push[i] = (uint8_t)(255 - i);
    static uint8_t update[CV_MAX_UPDATE_BYTES];
    for (uint32_t i = 0; i < sizeof(update); i++)
        update[i] = (uint8_t)(i * 31 + 7);
    char label[CV_LABEL_MAX];
    memset(label, '\xe2', sizeof(label) - 1);
    label[sizeof(label) - 1] = '\0';
    cv_pipeline pipe = { cv_handle_pack(CV_HANDLE_PIPELINE, CV_HANDLE_TAG_MAX, CV_HANDLE_GENERATION_MAX,
                                        CV_HANDLE_INDEX_MAX) };
    cv_buffer buf = { cv_handle_pack(CV_HANDLE_BUFFER, CV_HANDLE_TAG_MAX, CV_HANDLE_GENERATION_MAX,
                                     CV_HANDLE_INDEX_MAX) };
    cv_texture tex = { cv_handle_pack(CV_HANDLE_TEXTURE, 1, 1, 0) };

    CHECK_OK(cv_cmd_begin_marker(&list, CV_QUEUE_GRAPHICS, &(cv_begin_marker_args){ .label = label }));
    CHECK_OK(cv_cmd_dispatch(&list, CV_QUEUE_COMPUTE,
                             &(cv_dispatch_args){ .pipeline = pipe,
                                                  .bindings = bindings,
                                                  .bindings_count = CV_MAX_BINDINGS,
                                                  .push = push,
                                                  .push_size = sizeof(push),
                                                  .groups_x = UINT32_MAX,
                                                  .groups_y = 1,
                                                  .groups_z = 0 }));
    CHECK_OK(cv_cmd_update_buffer(&list, CV_QUEUE_COPY,
                                  &(cv_update_buffer_args){ .buffer = buf,
                                                            .offset = UINT64_MAX - 3,
                                                            .data = update,
                                                            .data_size = sizeof(update) }));
    CHECK_OK(cv_cmd_begin_render_pass(&list, CV_QUEUE_GRAPHICS,
                                      &(cv_begin_render_pass_args){ .color0 = tex,
                                                                    .clear = 1,
                                                                    .clear_r = -1e-45f,
                                                                    .clear_g = 1e-45f,
                                                                    .clear_b = 3.4e38f,
                                                                    .clear_a = -1.5f,
                                                                    .clear_depth = 1.0f }));
    CHECK_OK(cv_cmd_draw_indexed(&list, CV_QUEUE_GRAPHICS,
                                 &(cv_draw_indexed_args){ .pipeline = pipe,
                                                          .index_buffer = buf,
                                                          .index_count = 3,
                                                          .vertex_offset = INT32_MIN,
                                                          .first_instance = UINT32_MAX }));
    CHECK_OK(cv_cmd_draw_indexed(&list, CV_QUEUE_GRAPHICS,
                                 &(cv_draw_indexed_args){
                                     .pipeline = pipe, .index_buffer = buf, .index_count = 3, .vertex_offset = -1 }));
    CHECK_OK(cv_cmd_end_render_pass(&list, CV_QUEUE_GRAPHICS, &(cv_end_render_pass_args){ 0 }));
    CHECK_OK(cv_cmd_end_marker(&list, CV_QUEUE_GRAPHICS, &(cv_end_marker_args){ 0 }));
    CHECK_OK(cv_command_list_end(&list));
    round_trip(&list, "limits");

    /* Spot checks on the decoded values themselves, not only equality. */
    uint8_t *bytes;
    size_t size;
    CHECK_OK(cv_command_list_encode(&list, &bytes, &size));
    cv_command_list d;
    cv_command_list_init(&d);
    CHECK_OK(cv_command_list_decode(bytes, size, &d));
    CHECK_EQ_INT(d.count, 8);
    if (d.count == 8) {
        CHECK_EQ_INT(d.commands[1].u.dispatch.bindings.size, CV_MAX_BINDINGS);
        CHECK(cv_list_bindings(&d, d.commands[1].u.dispatch.bindings)[15].resource.id == bindings[15].resource.id);
        CHECK(cv_list_bindings(&d, d.commands[1].u.dispatch.bindings)[15].offset == UINT64_MAX - 15);
        CHECK_EQ_INT(d.commands[2].u.update_buffer.data.size, CV_MAX_UPDATE_BYTES);
        CHECK(memcmp(cv_list_bytes(&d, d.commands[2].u.update_buffer.data), update, sizeof(update)) == 0);
        CHECK_EQ_INT(d.commands[4].u.draw_indexed.vertex_offset, INT32_MIN);
        CHECK_EQ_INT(d.commands[5].u.draw_indexed.vertex_offset, -1);
        char text[CV_LABEL_MAX];
        cv_list_string(&d, d.commands[0].u.begin_marker.label, text, sizeof(text));
        CHECK(strcmp(text, label) == 0);
        CHECK_EQ_INT(d.queue_mask, CV_QUEUE_BIT_ALL);
    }
    free(bytes);
    cv_command_list_finish(&d);
    cv_command_list_finish(&list);
}

/* proto3 leaves out a float equal to its default 0, and protobuf-c compares
 * by value, so -0.0 arrives as +0.0: equal as a number, not as bits. */
static void test_negative_zero_arrives_as_zero(void) {
    cv_command_list list, d;
    cv_command_list_init(&list);
    cv_command_list_init(&d);
    cv_command_list_begin(&list);
    CHECK_OK(cv_cmd_clear_texture(&list, CV_QUEUE_COMPUTE,
                                  &(cv_clear_texture_args){ .texture = { cv_handle_pack(CV_HANDLE_TEXTURE, 1, 1, 1) },
                                                            .r = -0.0f,
                                                            .g = 0.5f }));
    CHECK_OK(cv_command_list_end(&list));
    uint8_t *bytes;
    size_t size;
    CHECK_OK(cv_command_list_encode(&list, &bytes, &size));
    CHECK_OK(cv_command_list_decode(bytes, size, &d));
    if (d.count == 1) {
        uint32_t bits;
        memcpy(&bits, &d.commands[0].u.clear_texture.r, sizeof(bits));
        CHECK_EQ_INT(bits, 0);
        CHECK(d.commands[0].u.clear_texture.g == 0.5f);
    }
    CHECK_EQ_INT(d.count, 1);
    free(bytes);
    cv_command_list_finish(&d);
    cv_command_list_finish(&list);
}

static void test_empty_list(void) {
    cv_command_list list;
    cv_command_list_init(&list);
    cv_command_list_begin(&list);
    CHECK_OK(cv_command_list_end(&list));
    uint8_t *bytes = NULL;
    size_t size = 1;
    CHECK_OK(cv_command_list_encode(&list, &bytes, &size));
    CHECK_EQ_INT(size, 0);
    CHECK(bytes != NULL);
    cv_command_list d;
    cv_command_list_init(&d);
    CHECK_OK(cv_command_list_decode(bytes, size, &d));
    CHECK(d.ended_ok);
    CHECK_EQ_INT(d.count, 0);
    CHECK_OK(cv_command_list_decode(NULL, 0, &d));
    CHECK_EQ_INT(d.count, 0);
    free(bytes);
    cv_command_list_finish(&d);
    cv_command_list_finish(&list);

    /* Commands with every field empty or zero: the list has no side arrays. */
    cv_command_list_init(&list);
    cv_command_list_begin(&list);
    CHECK_OK(cv_cmd_timestamp(&list, CV_QUEUE_COPY, &(cv_timestamp_args){ .label = "" }));
    CHECK_OK(cv_cmd_begin_marker(&list, CV_QUEUE_COPY, &(cv_begin_marker_args){ .label = NULL }));
    CHECK_OK(cv_cmd_dispatch(&list, CV_QUEUE_COMPUTE, &(cv_dispatch_args){ 0 }));
    CHECK_OK(cv_cmd_update_buffer(&list, CV_QUEUE_COPY, &(cv_update_buffer_args){ 0 }));
    CHECK_OK(cv_cmd_end_marker(&list, CV_QUEUE_COPY, &(cv_end_marker_args){ 0 }));
    CHECK_OK(cv_command_list_end(&list));
    CHECK(list.data == NULL && list.bindings == NULL);
    round_trip(&list, "all fields empty");
    cv_command_list_finish(&list);
}

/* Decoding replaces an earlier recording, keeps the list's id and bumps its
 * version as a new recording would. */
static void test_decode_replaces(void) {
    cv_command_list a, b;
    cv_command_list_init(&a);
    cv_command_list_init(&b);
    CHECK_OK(random_list_record(&a, 11, 30));
    CHECK_OK(random_list_record(&b, 12, 60));
    b.id = 0x5000000100000007ull;
    uint32_t version = b.version;
    uint8_t *bytes;
    size_t size;
    CHECK_OK(cv_command_list_encode(&a, &bytes, &size));
    CHECK_OK(cv_command_list_decode(bytes, size, &b));
    CHECK(lists_equal(&a, &b, "replaced"));
    CHECK(b.id == 0x5000000100000007ull);
    CHECK_EQ_INT(b.version, version + 1);
    free(bytes);
    cv_command_list_finish(&a);
    cv_command_list_finish(&b);
}

static void test_encode_refuses_unfinished_lists(void) {
    cv_command_list list;
    cv_command_list_init(&list);
    uint8_t *bytes = (uint8_t *)&list;
    size_t size = 77;
    CHECK_RESULT(cv_command_list_encode(&list, &bytes, &size), CV_ERROR_BAD_STATE); /* never recorded */
    cv_command_list_begin(&list);
    CHECK_OK(cv_cmd_barrier(&list, CV_QUEUE_COPY, &(cv_barrier_args){ { 0 } }));
    CHECK_RESULT(cv_command_list_encode(&list, &bytes, &size), CV_ERROR_BAD_STATE); /* still recording */
    CHECK_RESULT(cv_cmd_draw(&list, CV_QUEUE_GRAPHICS, &(cv_draw_args){ 0 }), CV_ERROR_BAD_STATE);
    CHECK_RESULT(cv_command_list_end(&list), CV_ERROR_BAD_STATE);
    CHECK_RESULT(cv_command_list_encode(&list, &bytes, &size), CV_ERROR_BAD_STATE); /* ended with an error */
    CHECK(bytes == (uint8_t *)&list && size == 77);                                 /* outputs untouched */
    cv_command_list_finish(&list);
}

/* A list that records fine but whose encoding would pass CV_MAX_ENCODED_LIST:
 * 1023 updates of 64 KiB (just under the list data limit) plus copies. */
static void test_encode_size_limit(void) {
    static uint8_t update[CV_MAX_UPDATE_BYTES];
    cv_command_list list;
    cv_command_list_init(&list);
    cv_command_list_begin(&list);
    cv_buffer buf = { cv_handle_pack(CV_HANDLE_BUFFER, 3, 3, 3) };
    for (int i = 0; i < 1023; i++)
        cv_cmd_update_buffer(&list, CV_QUEUE_COPY,
                             &(cv_update_buffer_args){ .buffer = buf, .data = update, .data_size = sizeof(update) });
    cv_copy_buffer_args big = {
        .src = buf, .src_offset = UINT64_MAX, .dst = buf, .dst_offset = UINT64_MAX, .size = UINT64_MAX
    };
    for (int i = 0; i < 2000; i++)
        cv_cmd_copy_buffer(&list, CV_QUEUE_COPY, &big);
    CHECK_OK(cv_command_list_end(&list));
    uint8_t *bytes = NULL;
    size_t size = 0;
    CHECK_RESULT(cv_command_list_encode(&list, &bytes, &size), CV_ERROR_LIMIT_EXCEEDED);
    CHECK(bytes == NULL);
    CHECK(strstr(cv_last_error(), "past 67108864 bytes") != NULL);
    cv_command_list_finish(&list);
}

int main(void) {
    test_random_lists();
    test_limits_round_trip();
    test_negative_zero_arrives_as_zero();
    test_empty_list();
    test_decode_replaces();
    test_encode_refuses_unfinished_lists();
    test_encode_size_limit();
    return check_report("codec_roundtrip");
}
