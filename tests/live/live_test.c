/* The live loop (corvid/live.h) on lavapipe at 128x72, the consumer played by
 * this test:
 *  - with no credit frames render and are spoiled, none is presented; a still
 *    view stops at max_accumulate (the rendered count stops growing);
 *  - credit 1 gives exactly one frame; frames come with increasing index;
 *  - an update with a new camera gives a frame of its input_seq whose decoded
 *    pixels match a fresh renderer's display after as many steps, within the
 *    JPEG tolerance; a bad update is refused and rendering goes on;
 *  - snapshots: PNG equals the display bytes exactly, ZSTD the radiance;
 *  - H.264: every frame decodes, the first and a requested one are keyframes;
 *  - stats: passes per device, the adaptation's choice, motion-to-photon;
 *  - a proxy device on a corvid-node on loopback gives frames; the node's death
 *    ends the live with the error in its stats, and stop returns. */
#include <pthread.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "check.h"
#include "corvid/clock.h"
#include "corvid/frame_codec.h"
#include "corvid/live.h"
#include "corvid/proxy.h"
#include "corvid/scene_procedural.h"
#include "corvid/vulkan.h"
#include "scratch_node.h"
#include "test_adapter.h"

#define W 128
#define H 72
#define MAX_ACCUMULATE 4u
#define WAIT_MS 60000u

/* JPEG at quality 90 (4:2:0) against the display it encodes, a 4-frame image
 * still noisy at 128x72: a mean error per channel of at most 4 (of 255), no
 * channel more than 96 off (chroma subsampling at sharp colour edges; seen:
 * mean 3.4, max 79). The bytes themselves must equal a fresh encode of the
 * display at that quality (the same encoder, on the node too). H.264 at 2
 * Mbit/s, the last frame of a still view: mean at most 4. */
#define JPEG_QUALITY 90u
#define JPEG_MEAN 4.0
#define JPEG_MAX 96
#define H264_KBPS 2000u
#define H264_MEAN 4.0

typedef struct sink {
    pthread_mutex_t lock;
    pthread_cond_t cond;
    uint64_t frames;
    bool index_ok;      /* every index was the one before plus 1 */
    cv_live_frame last; /* data: the copy below */
    uint8_t *data;
    cv_decoder *h264; /* set: every frame goes through it */
    uint32_t h264_errors, keyframes;
    uint8_t *picture; /* the H.264 decoder's last picture (RGBA8) */
} sink;

static void on_frame(const cv_live_frame *f, void *user) {
    sink *k = user;
    pthread_mutex_lock(&k->lock);
    if (f->index != k->frames + 1)
        k->index_ok = false;
    k->frames++;
    free(k->data);
    k->data = malloc(f->size);
    memcpy(k->data, f->data, f->size);
    k->last = *f;
    k->last.data = k->data;
    k->keyframes += f->keyframe;
    if (k->h264) {
        uint8_t *pic = NULL;
        size_t n = 0;
        uint32_t w = 0, h = 0;
        if (cv_decoder_decode(k->h264, f->data, f->size, &pic, &n, &w, &h) != CV_OK || w != f->width ||
            h != f->height || n != (size_t)w * h * 4) {
            k->h264_errors++;
            free(pic);
        } else {
            free(k->picture);
            k->picture = pic;
        }
    }
    pthread_cond_broadcast(&k->cond);
    pthread_mutex_unlock(&k->lock);
}

static bool wait_frames(sink *k, uint64_t n) {
    uint64_t deadline = cv_deadline_after_ms(WAIT_MS);
    pthread_mutex_lock(&k->lock);
    while (k->frames < n && cv_cond_wait_until(&k->cond, &k->lock, deadline) == 0) {
    }
    bool ok = k->frames >= n;
    pthread_mutex_unlock(&k->lock);
    return ok;
}

static uint64_t sink_frames(sink *k) {
    pthread_mutex_lock(&k->lock);
    uint64_t n = k->frames;
    pthread_mutex_unlock(&k->lock);
    return n;
}

/* The live says nothing when a step finishes: its stats are polled. */
static cv_live_stats wait_stats(cv_live *l, bool (*done)(const cv_live_stats *s, uint64_t n), uint64_t n) {
    cv_live_stats s;
    uint64_t deadline = cv_deadline_after_ms(WAIT_MS);
    for (;;) {
        cv_live_get_stats(l, &s);
        if (done(&s, n) || cv_deadline_passed(deadline))
            return s;
        nanosleep(&(struct timespec){ .tv_nsec = 2000000 }, NULL);
    }
}

static bool is_still(const cv_live_stats *s, uint64_t n) {
    (void)n;
    return s->still || s->failed;
}

static bool failed(const cv_live_stats *s, uint64_t n) {
    (void)n;
    return s->failed;
}

/* Time for frames that must not come to come (a still view, no credit). */
static void settle(void) { nanosleep(&(struct timespec){ .tv_nsec = 300000000 }, NULL); }

static cv_render_settings base_settings(void) {
    return (cv_render_settings){
        .width = W, .height = H, .ao_samples = 2, .sun_cone_degrees = 1.0f, .filter_iterations = 2
    };
}

static cv_render_settings camera_settings(float x) {
    cv_render_settings s = base_settings();
    float eye[3] = { x, 2.4f, 11.0f }, target[3] = { 0.0f, 1.2f, 0.0f };
    memcpy(s.camera_eye, eye, sizeof(eye));
    memcpy(s.camera_target, target, sizeof(target));
    s.camera_fov_degrees = 50.0f;
    return s;
}

/* The display (RGBA8) and radiance (RGBA32F) of a fresh renderer after `steps` steps of s. */
static cv_result fresh_frame(cv_device *dev, const cv_scene *scene, const cv_bvh *bvh, const cv_render_settings *s,
                             uint32_t steps, uint8_t *display, float *radiance) {
    cv_renderer *r = NULL;
    cv_render_step step = { 0 };
    cv_result res = cv_renderer_create(&dev, 1, scene, bvh, &r);
    for (uint32_t i = 0; res == CV_OK && i < steps; i++)
        res = cv_renderer_step(r, s, &step);
    if (res == CV_OK)
        res = cv_device_wait(dev, step.ticket, UINT64_MAX);
    if (res == CV_OK)
        res = cv_device_read_texture(dev, step.display, (cv_rect){ 0, 0, W, H }, display);
    if (res == CV_OK && radiance)
        res = cv_device_read_texture(dev, step.radiance, (cv_rect){ 0, 0, W, H }, radiance);
    cv_renderer_destroy(r);
    return res;
}

/* Mean and largest difference of the RGB channels of two RGBA8 images. */
static double rgb_error(const uint8_t *a, const uint8_t *b, int *max) {
    double sum = 0;
    *max = 0;
    for (size_t i = 0; i < (size_t)W * H * 4; i++) {
        if (i % 4 == 3)
            continue;
        int d = abs((int)a[i] - (int)b[i]);
        sum += d;
        if (d > *max)
            *max = d;
    }
    return sum / ((double)W * H * 3);
}

/* The sink's last frame, decoded (JPEG), against a display; its bytes against a fresh encode. */
static void check_jpeg_matches(sink *k, const uint8_t *display) {
    cv_decoder *d = NULL;
    cv_encoder *e = NULL;
    cv_encoded fresh = { 0 };
    uint8_t *pic = NULL;
    size_t n = 0;
    uint32_t w = 0, h = 0;
    CHECK_OK(cv_decoder_create(CV_CODEC_JPEG, &d));
    CHECK_OK(cv_encoder_create(CV_CODEC_JPEG, W, H, &e));
    CHECK_OK(cv_encoder_encode(e, display, W * 4, &(cv_encode_params){ .quality = JPEG_QUALITY }, &fresh));
    pthread_mutex_lock(&k->lock);
    CHECK_OK(cv_decoder_decode(d, k->last.data, k->last.size, &pic, &n, &w, &h));
    CHECK(fresh.size == k->last.size && memcmp(fresh.data, k->last.data, fresh.size) == 0);
    pthread_mutex_unlock(&k->lock);
    CHECK(w == W && h == H && n == (size_t)W * H * 4);
    if (pic && n == (size_t)W * H * 4) {
        int max;
        double mean = rgb_error(pic, display, &max);
        printf("jpeg against the display: mean %.2f, max %d\n", mean, max);
        CHECK(mean <= JPEG_MEAN);
        CHECK(max <= JPEG_MAX);
    }
    free(pic);
    cv_encoded_free(&fresh);
    cv_encoder_destroy(e);
    cv_decoder_destroy(d);
}

static cv_result start_live(cv_device *dev, cv_renderer *r, cv_codec codec, sink *k, cv_live **out) {
    cv_live_desc d = { .renderer = r,
                       .primary = dev,
                       .settings = base_settings(),
                       .codec = codec,
                       .encode = { .quality = JPEG_QUALITY },
                       .max_accumulate = MAX_ACCUMULATE,
                       .frame = on_frame,
                       .user = k };
    return cv_live_start(&d, out);
}

/* No credit: frames render up to max_accumulate and are spoiled; credit 1: one frame. */
static void credits(cv_device *dev, const cv_scene *scene, const cv_bvh *bvh, cv_live *l, sink *k) {
    cv_live_stats s = wait_stats(l, is_still, 0);
    CHECK(s.still);
    settle();
    cv_live_get_stats(l, &s);
    CHECK_EQ_INT(s.rendered, MAX_ACCUMULATE); /* still: it stopped there */
    CHECK_EQ_INT(s.spoiled, MAX_ACCUMULATE - 1);
    CHECK_EQ_INT(s.presented, 0);
    CHECK_EQ_INT(sink_frames(k), 0);

    cv_live_credit(l, 1);
    CHECK(wait_frames(k, 1));
    settle();
    cv_live_get_stats(l, &s);
    CHECK_EQ_INT(s.presented, 1);
    CHECK_EQ_INT(sink_frames(k), 1);
    CHECK_EQ_INT(k->last.index, 1);
    CHECK_EQ_INT(k->last.input_seq, 0);
    CHECK_EQ_INT(k->last.accumulated, MAX_ACCUMULATE);
    CHECK(k->last.codec == CV_CODEC_JPEG && k->last.width == W && k->last.height == H);
    uint8_t *display = malloc((size_t)W * H * 4);
    cv_render_settings base = base_settings();
    CHECK_OK(fresh_frame(dev, scene, bvh, &base, MAX_ACCUMULATE, display, NULL));
    check_jpeg_matches(k, display);
    free(display);
}

/* The caller's observer in the settings: called for every step (the live wraps it). */
static pthread_mutex_t observed_lock = PTHREAD_MUTEX_INITIALIZER;
static uint32_t observed;

static void on_observed(const cv_render_frame_info *info, void *user) {
    (void)info;
    (void)user;
    pthread_mutex_lock(&observed_lock);
    observed++;
    pthread_mutex_unlock(&observed_lock);
}

/* A new camera: a frame of its seq, the fresh renderer's image; a bad update changes nothing. */
static void updates(cv_device *dev, const cv_scene *scene, const cv_bvh *bvh, cv_live *l, sink *k) {
    cv_render_settings moved = camera_settings(2.0f);
    static const cv_render_observer counter = { .frame = on_observed };
    moved.observer = &counter;
    CHECK_OK(cv_live_update(l, &moved, 5));
    cv_live_stats s = wait_stats(l, is_still, 0);
    CHECK_EQ_INT(s.rendered, 2 * MAX_ACCUMULATE);
    pthread_mutex_lock(&observed_lock);
    CHECK_EQ_INT(observed, MAX_ACCUMULATE);
    pthread_mutex_unlock(&observed_lock);
    cv_live_credit(l, 1);
    CHECK(wait_frames(k, 2));
    CHECK_EQ_INT(k->last.input_seq, 5);
    CHECK_EQ_INT(k->last.accumulated, MAX_ACCUMULATE);
    CHECK(k->last.input_age_ms > 0);
    uint8_t *display = malloc((size_t)W * H * 4);
    CHECK_OK(fresh_frame(dev, scene, bvh, &moved, MAX_ACCUMULATE, display, NULL));
    check_jpeg_matches(k, display);
    free(display);

    cv_render_settings bad = moved;
    bad.ao_samples = 40;
    CHECK_RESULT(cv_live_update(l, &bad, 6), CV_ERROR_OUT_OF_RANGE);
    CHECK(strstr(cv_last_error(), "live: update 6: ") == cv_last_error());
    CHECK(strstr(cv_last_error(), "AO samples 40") != NULL);
    settle();
    cv_live_get_stats(l, &s);
    CHECK_EQ_INT(s.rendered, 2 * MAX_ACCUMULATE); /* nothing restarted */
    CHECK(!s.failed);

    /* Rendering goes on with the next good input: credit while it renders gives one frame. */
    cv_render_settings back = camera_settings(-1.0f);
    CHECK_OK(cv_live_update(l, &back, 7));
    cv_live_credit(l, 1);
    CHECK(wait_frames(k, 3));
    s = wait_stats(l, is_still, 0);
    settle();
    cv_live_get_stats(l, &s);
    CHECK_EQ_INT(s.rendered, 3 * MAX_ACCUMULATE);
    CHECK_EQ_INT(s.presented, 3);
    CHECK_EQ_INT(sink_frames(k), 3);
    CHECK_EQ_INT(k->last.input_seq, 7);
    /* Every step is presented, spoiled, or the newest (not taken yet). */
    CHECK(s.spoiled + s.presented == s.rendered || s.spoiled + s.presented + 1 == s.rendered);
    CHECK(k->index_ok);
}

/* Snapshots of the still view (camera -1): the display exactly, the radiance exactly. */
static void snapshots(cv_device *dev, const cv_scene *scene, const cv_bvh *bvh, cv_live *l) {
    uint8_t *display = malloc((size_t)W * H * 4);
    float *radiance = malloc((size_t)W * H * 4 * sizeof(float));
    cv_render_settings back = camera_settings(-1.0f);
    CHECK_OK(fresh_frame(dev, scene, bvh, &back, MAX_ACCUMULATE, display, radiance));
    cv_encoded png = { 0 }, zst = { 0 };
    CHECK_OK(cv_live_snapshot(l, CV_CODEC_PNG, &png));
    CHECK_OK(cv_live_snapshot(l, CV_CODEC_ZSTD, &zst));
    CHECK(png.codec == CV_CODEC_PNG && png.width == W && png.height == H);
    CHECK(zst.codec == CV_CODEC_ZSTD && zst.width == W && zst.height == H);
    CHECK_RESULT(cv_live_snapshot(l, CV_CODEC_JPEG, &(cv_encoded){ 0 }), CV_ERROR_INVALID_ARGUMENT);
    cv_decoder *d = NULL;
    uint8_t *pixels = NULL;
    size_t n = 0;
    uint32_t w = 0, h = 0;
    CHECK_OK(cv_decoder_create(CV_CODEC_PNG, &d));
    CHECK_OK(cv_decoder_decode(d, png.data, png.size, &pixels, &n, &w, &h));
    CHECK(n == (size_t)W * H * 4 && w == W && h == H);
    int max = 1;
    if (n == (size_t)W * H * 4)
        rgb_error(pixels, display, &max);
    CHECK_EQ_INT(max, 0); /* lossless: the display's RGB bytes */
    free(pixels);
    cv_decoder_destroy(d);
    pixels = NULL;
    CHECK_OK(cv_decoder_create(CV_CODEC_ZSTD, &d));
    CHECK_OK(cv_decoder_decode(d, zst.data, zst.size, &pixels, &n, &w, &h));
    CHECK(n == (size_t)W * H * 4 * sizeof(float) && memcmp(pixels, radiance, n) == 0);
    free(pixels);
    cv_decoder_destroy(d);
    cv_encoded_free(&png);
    cv_encoded_free(&zst);
    free(display);
    free(radiance);
}

/* The figures: passes per device, the adaptation's choice, what the viewer reported. */
static void stats(cv_live *l, sink *k) {
    cv_live_stats s;
    cv_live_get_stats(l, &s);
    printf("passes of the last frame:\n%s", s.passes);
    CHECK(strstr(s.passes, "composite dev0 ") != NULL);
    CHECK(s.bytes > 0 && s.codec == CV_CODEC_JPEG && s.width == W && s.height == H);
    CHECK_EQ_INT(s.quality, JPEG_QUALITY); /* no link reported: the starting quality */
    CHECK(s.input_age_ms > 0 && s.input_age_max_ms >= s.input_age_ms);
    CHECK_EQ_INT(s.input_seq, 7);
    cv_live_report_display(l, 7, 40.0);
    cv_live_report_display(l, 8, 25.0);
    cv_live_report_link(l, 1000.0); /* 1 kB/s: a JPEG frame of ours is over the budget */
    cv_live_get_stats(l, &s);
    CHECK(s.motion_to_photon_ms == 25.0 && s.motion_to_photon_max_ms == 40.0);
    CHECK_EQ_INT(s.displayed_seq, 8);
    CHECK(s.link_bytes_per_s == 1000.0);
    CHECK_EQ_INT(s.bitrate_kbps, 100); /* the floor */
    /* The next frames come at lower quality. */
    uint64_t presented = s.presented;
    cv_render_settings moved = camera_settings(0.5f);
    CHECK_OK(cv_live_update(l, &moved, 9));
    cv_live_credit(l, 2);
    CHECK(wait_frames(k, presented + 2));
    cv_live_get_stats(l, &s);
    CHECK_EQ_INT(s.presented, presented + 2);
    CHECK(s.quality < JPEG_QUALITY && s.quality >= 40);
    printf("quality after 1 kB/s: %u\n", s.quality);
}

/* H.264: keyframes at the switch and on request, every frame decodes, the last picture is the display's. */
static void h264(cv_device *dev, const cv_scene *scene, const cv_bvh *bvh, cv_live *l, sink *k) {
    CHECK_OK(cv_decoder_create(CV_CODEC_H264, &k->h264));
    CHECK_RESULT(cv_live_set_codec(l, CV_CODEC_PNG, NULL), CV_ERROR_INVALID_ARGUMENT);
    cv_live_report_link(l, 10e6); /* 80 Mbit/s for frames: the starting bitrate caps it */
    CHECK_OK(cv_live_set_codec(l, CV_CODEC_H264, &(cv_encode_params){ .bitrate_kbps = H264_KBPS }));
    cv_live_stats st;
    cv_live_get_stats(l, &st);
    CHECK_EQ_INT(st.bitrate_kbps, H264_KBPS);
    CHECK(st.codec == CV_CODEC_H264);
    cv_render_settings odd = camera_settings(1.0f);
    odd.width = W + 1;
    CHECK_RESULT(cv_live_update(l, &odd, 10), CV_ERROR_INVALID_ARGUMENT); /* H.264 sizes are even */
    uint64_t first = sink_frames(k) + 1;
    pthread_mutex_lock(&k->lock);
    k->keyframes = 0;
    pthread_mutex_unlock(&k->lock);
    cv_render_settings s = base_settings();
    for (uint64_t i = 0; i < 6; i++) {
        s = camera_settings(1.0f + 0.25f * (float)i);
        if (i == 3) { /* a keyframe request alone keeps the bitrate */
            CHECK_OK(cv_live_set_codec(l, CV_CODEC_H264, &(cv_encode_params){ .keyframe = true }));
            cv_live_get_stats(l, &st);
            CHECK_EQ_INT(st.bitrate_kbps, H264_KBPS);
        }
        CHECK_OK(cv_live_update(l, &s, 11 + i));
        cv_live_credit(l, 1);
        CHECK(wait_frames(k, first + i));
    }
    /* The last view, converged, as the next frame. */
    st = wait_stats(l, is_still, 0);
    CHECK(st.still);
    pthread_mutex_lock(&k->lock);
    bool converged = k->last.input_seq == 16 && k->last.accumulated == MAX_ACCUMULATE;
    pthread_mutex_unlock(&k->lock);
    if (!converged) {
        cv_live_credit(l, 1);
        CHECK(wait_frames(k, first + 6));
    }
    uint8_t *display = malloc((size_t)W * H * 4);
    CHECK_OK(fresh_frame(dev, scene, bvh, &s, MAX_ACCUMULATE, display, NULL));
    pthread_mutex_lock(&k->lock);
    CHECK_EQ_INT(k->h264_errors, 0);
    CHECK_EQ_INT(k->keyframes, 2); /* the switch and the request */
    CHECK(k->last.codec == CV_CODEC_H264 && k->last.input_seq == 16);
    CHECK_EQ_INT(k->last.accumulated, MAX_ACCUMULATE);
    CHECK(k->picture != NULL);
    if (k->picture) {
        int max;
        double mean = rgb_error(k->picture, display, &max);
        printf("h264 against the display: mean %.2f, max %d\n", mean, max);
        CHECK(mean <= H264_MEAN);
    }
    pthread_mutex_unlock(&k->lock);
    free(display);

    /* A new size: a new stream, from a keyframe, still decodable by the same decoder. */
    cv_render_settings small = s;
    small.width = 96;
    small.height = 54;
    CHECK_OK(cv_live_update(l, &small, 17));
    uint64_t before = sink_frames(k);
    cv_live_credit(l, 1);
    CHECK(wait_frames(k, before + 1));
    pthread_mutex_lock(&k->lock);
    CHECK(k->last.width == 96 && k->last.height == 54 && k->last.input_seq == 17 && k->last.keyframe);
    CHECK_EQ_INT(k->h264_errors, 0);
    CHECK_EQ_INT(k->keyframes, 3);
    pthread_mutex_unlock(&k->lock);
}

static void local(const cv_scene *scene, const cv_bvh *bvh) {
    cv_context *ctx = NULL;
    cv_device *dev = NULL;
    cv_renderer *r = NULL;
    CHECK_OK(cv_context_create(NULL, &ctx));
    CHECK_OK(cv_device_create(ctx, cv_vulkan_backend(),
                              &(cv_device_desc){ .adapter = cv_test_adapter(), .validation = true }, &dev));
    CHECK_OK(cv_renderer_create(&dev, 1, scene, bvh, &r));
    sink k = { .index_ok = true };
    pthread_mutex_init(&k.lock, NULL);
    cv_cond_init(&k.cond);
    cv_live *l = NULL;
    CHECK_RESULT(start_live(dev, r, CV_CODEC_PNG, &k, &l), CV_ERROR_INVALID_ARGUMENT);
    CHECK_OK(start_live(dev, r, CV_CODEC_JPEG, &k, &l));
    if (l) {
        credits(dev, scene, bvh, l, &k);
        updates(dev, scene, bvh, l, &k);
        snapshots(dev, scene, bvh, l);
        stats(l, &k);
        h264(dev, scene, bvh, l, &k);
        cv_live_stats s;
        cv_live_get_stats(l, &s);
        CHECK(!s.failed && s.error[0] == '\0');
        cv_live_stop(l);
    }
    /* The renderer is the caller's again. */
    cv_render_step step;
    CHECK_OK(cv_renderer_step(r, &(cv_render_settings){ .width = W, .height = H, .ao_samples = 1 }, &step));
    cv_renderer_destroy(r);
    cv_context_destroy(ctx);
    cv_decoder_destroy(k.h264);
    free(k.data);
    free(k.picture);
    pthread_mutex_destroy(&k.lock);
    pthread_cond_destroy(&k.cond);
}

/* The renderer on a proxy device: frames encoded by the node; the node's death ends the live. */
static void remote(const cv_scene *scene, const cv_bvh *bvh) {
    scratch_node node;
    CHECK_OK(scratch_node_start(&node, cv_vulkan_backend(), 1, true));
    cv_context *ctx = NULL;
    cv_device *dev = NULL;
    cv_renderer *r = NULL;
    CHECK_OK(cv_context_create(NULL, &ctx));
    CHECK_OK(cv_device_create(ctx, cv_proxy_backend(), &(cv_device_desc){ .endpoint = node.endpoint }, &dev));
    CHECK_OK(cv_renderer_create(&dev, 1, scene, bvh, &r));
    sink k = { .index_ok = true };
    pthread_mutex_init(&k.lock, NULL);
    cv_cond_init(&k.cond);
    cv_live *l = NULL;
    CHECK_OK(start_live(dev, r, CV_CODEC_JPEG, &k, &l));
    if (l) {
        cv_live_credit(l, 2);
        CHECK(wait_frames(&k, 2));
        CHECK(k.index_ok);
        /* The still view's frame against a local renderer's display. */
        cv_live_stats s = wait_stats(l, is_still, 0);
        pthread_mutex_lock(&k.lock);
        bool converged = k.last.accumulated == MAX_ACCUMULATE;
        pthread_mutex_unlock(&k.lock);
        if (!converged) {
            cv_live_credit(l, 1);
            CHECK(wait_frames(&k, 3));
        }
        CHECK_EQ_INT(k.last.accumulated, MAX_ACCUMULATE);
        cv_context *local_ctx = NULL;
        cv_device *local_dev = NULL;
        CHECK_OK(cv_context_create(NULL, &local_ctx));
        CHECK_OK(cv_device_create(local_ctx, cv_vulkan_backend(),
                                  &(cv_device_desc){ .adapter = cv_test_adapter(), .validation = true }, &local_dev));
        uint8_t *display = malloc((size_t)W * H * 4);
        cv_render_settings base = base_settings();
        CHECK_OK(fresh_frame(local_dev, scene, bvh, &base, MAX_ACCUMULATE, display, NULL));
        check_jpeg_matches(&k, display);
        free(display);
        cv_context_destroy(local_ctx);

        scratch_node_stop_keep(&node, false); /* the device is lost under the live */
        cv_render_settings moved = camera_settings(1.0f);
        CHECK_OK(cv_live_update(l, &moved, 1));
        s = wait_stats(l, failed, 0);
        CHECK(s.failed);
        printf("after the node's death: %s\n", s.error);
        CHECK(strstr(s.error, "live: step ") == s.error);
        CHECK(strstr(s.error, node.endpoint) != NULL);
        CHECK_RESULT(cv_live_snapshot(l, CV_CODEC_PNG, &(cv_encoded){ 0 }), CV_ERROR_BAD_STATE);
        cv_live_stop(l);
    }
    cv_renderer_destroy(r);
    cv_context_destroy(ctx);
    if (node.node)
        scratch_node_stop(&node);
    free(k.data);
    pthread_mutex_destroy(&k.lock);
    pthread_cond_destroy(&k.cond);
}

int main(void) {
    cv_scene *scene = NULL;
    cv_bvh *bvh = NULL;
    CHECK_OK(cv_scene_make_room(1, &scene));
    CHECK_OK(cv_bvh_build_flat(scene, NULL, &bvh));
    if (scene && bvh) {
        local(scene, bvh);
        CHECK_NOTHING_LIVE();
        remote(scene, bvh);
    }
    cv_bvh_destroy(bvh);
    cv_scene_destroy(scene);
    check_live_counter("encoders", cv_live_encoders);
    check_live_counter("decoders", cv_live_decoders);
    CHECK_NOTHING_LIVE();
    return check_report("live");
}
