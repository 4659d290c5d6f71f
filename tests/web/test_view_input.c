/* corvid-view's wire formats without a browser: the page's input messages (view_input.c)
 * read into settings or refused naming the field, and the frame header (view_frame.c)
 * laid out as docs/live-view.md says. */
#include "check.h"
#include "view_frame.h"
#include "view_input.h"

#include <string.h>

static cv_render_settings start(void) { return (cv_render_settings){ .width = 64, .height = 48 }; }

/* Expects `text` refused with a message that contains `field`; nothing of *out is used. */
static void refused(const char *text, const char *field) {
    cv_render_settings s = start();
    view_input in;
    CHECK_RESULT(view_input_parse(text, &s, &in), CV_ERROR_INVALID_ARGUMENT);
    if (!strstr(cv_last_error(), field)) {
        CHECK(!"the message names the field");
        fprintf(stderr, "  %s -> %s (expected '%s')\n", text, cv_last_error(), field);
    }
}

static void test_accepted(void) {
    cv_render_settings s = start();
    view_input in;
    CHECK_OK(view_input_parse("{\"seq\":7,\"t\":12.5,\"camera\":{\"eye\":[1,2,3],\"target\":[0,0.5,0],\"fov\":50}}",
                              &s, &in));
    CHECK(in.has_seq && in.seq == 7 && in.changed);
    CHECK(in.settings.camera_eye[1] == 2.0f && in.settings.camera_target[1] == 0.5f);
    CHECK(in.settings.camera_fov_degrees == 50.0f);
    CHECK(in.settings.width == 64); /* the rest as it was */

    CHECK_OK(
        view_input_parse("{\"settings\":{\"exposure\":1.5,\"shadow_samples\":4,\"reflections\":false,"
                         "\"filter_iterations\":0}}",
                         &s, &in));
    CHECK(in.settings.exposure == 1.5f && in.settings.shadow_samples == 4);
    CHECK_EQ_INT(in.settings.reflections, -1);       /* off */
    CHECK_EQ_INT(in.settings.filter_iterations, -1); /* the option's 0: none */

    CHECK_OK(view_input_parse("{\"ack\":12,\"bytes_per_s\":5000,\"shown\":7,\"m2p\":33.5}", &s, &in));
    CHECK(!in.changed && in.has_ack && in.ack == 12 && in.bytes_per_s == 5000);
    CHECK(in.has_shown && in.shown == 7 && in.m2p_ms == 33.5);

    CHECK_OK(view_input_parse("{\"codec\":\"h264\",\"keyframe\":true,\"sun\":[0,1,0]}", &s, &in));
    CHECK(in.has_codec && in.codec == CV_CODEC_H264 && in.keyframe && in.settings.sun_toward[1] == 1.0f);
}

static void test_refused(void) {
    refused("{\"seq\":1,", "not JSON");
    refused("[1,2]", "message");
    refused("{\"colour\":1}", "colour");
    refused("{\"camera\":{\"eye\":[1,2],\"target\":[0,0,0],\"fov\":50}}", "camera.eye");
    refused("{\"camera\":{\"eye\":[1,2,3],\"target\":[0,0,0],\"fov\":171}}", "camera.fov");
    refused("{\"camera\":{\"eye\":[1,2,3],\"target\":[0,0,0],\"zoom\":2}}", "camera.zoom");
    refused("{\"camera\":{\"eye\":[1,2,3]}}", "camera"); /* no fov yet: the scene's camera stays whole */
    refused("{\"sun\":[0,\"up\",0]}", "sun");
    refused("{\"settings\":{\"shadow_samples\":3}}", "settings.shadow_samples");
    refused("{\"settings\":{\"ao_samples\":2.5}}", "settings.ao_samples");
    refused("{\"settings\":{\"exposure\":99}}", "settings.exposure");
    refused("{\"settings\":{\"width\":100}}", "settings.width"); /* not the page's to change */
    refused("{\"settings\":{\"reflections\":\"on\"}}", "settings.reflections");
    refused("{\"seq\":-1}", "seq");
    refused("{\"ack\":1.5}", "ack");
    refused("{\"m2p\":-3}", "m2p");
    refused("{\"codec\":\"png\"}", "codec");
    refused("{\"keyframe\":1}", "keyframe");
}

static uint64_t get64(const uint8_t *p) {
    uint64_t v = 0;
    for (int i = 7; i >= 0; i--)
        v = v << 8 | p[i];
    return v;
}

static void test_frame_header(void) {
    cv_live_frame f = { .index = 0x0102030405ull,
                        .input_seq = 99,
                        .accumulated = 5,
                        .width = 160,
                        .height = 90,
                        .codec = CV_CODEC_H264,
                        .keyframe = true,
                        .input_age_ms = 12.5,
                        .encode_ms = 1.25 };
    uint8_t h[VIEW_FRAME_HEADER_BYTES];
    view_frame_header(h, &f, 42);
    CHECK(memcmp(h, "CVF1", 4) == 0); /* the magic, little-endian */
    CHECK_EQ_INT(h[4], CV_CODEC_H264);
    CHECK_EQ_INT(h[5], 1);
    CHECK_EQ_INT(h[6] | h[7] << 8, VIEW_FRAME_HEADER_BYTES);
    CHECK(get64(h + 8) == 0x0102030405ull);
    CHECK(get64(h + 16) == 42); /* the page's seq, not the live's */
    CHECK_EQ_INT(h[24] | h[25] << 8, 160);
    CHECK_EQ_INT(h[28] | h[29] << 8, 90);
    CHECK_EQ_INT(h[32], 5);
    float age, enc;
    memcpy(&age, h + 36, 4);
    memcpy(&enc, h + 40, 4);
    CHECK(age == 12.5f && enc == 1.25f);
}

int main(void) {
    test_accepted();
    test_refused();
    test_frame_header();
    CHECK_NOTHING_LIVE();
    return check_report("test_view_input");
}
