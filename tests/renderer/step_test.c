/* The progressive, interactive steps (cv_renderer_step, renderer.h) and the
 * pass 'present', on lavapipe with validation, the room at 64x48. Checks:
 *  (a) N steps of a still view give the bytes of cv_renderer_render with
 *      frames = N (radiance, visibility, reflection; a moving camera too),
 *      read with cv_renderer_read_output; accumulated counts 1 .. N;
 *  (b) a camera change restarts: accumulated 1, an image unlike the one
 *      before and the bytes of a fresh renderer's first frame there;
 *  (c) a step with a bad setting is refused and the next good step goes on
 *      as if it had not been (frames and first_frame changes are ignored);
 *      exposure is a setting: its change restarts too;
 *  (d) steps on 2 virtual GPUs give the bytes of 1 device;
 *  (e) the display equals image/'s cv_tonemap_to_srgb8 (ACES) of the radiance
 *      read back within 1 in 255, at exposures 0, 1.5 and -2, on 1 and 2
 *      virtual GPUs;
 *  (f) the display ring: step k writes slot k % CV_RENDER_DISPLAY_SLOTS; read
 *      output before any frame and a step from a render's progress callback
 *      are refused. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "corvid/renderer.h"
#include "corvid/scene_procedural.h"
#include "corvid/tonemap.h"
#include "corvid/vulkan.h"
#include "test_render.h"

enum { W = 64, H = 48, N = 4 };
#define PLANE_BYTES (sizeof(float) * W * H * 4)

typedef struct fixture {
    cv_test_gpus g;
    cv_scene *scene;
    cv_bvh *bvh;
} fixture;

static const cv_render_settings still = { .width = W, .height = H };

static bool same_planes(const cv_render_output *a, const cv_render_output *b) {
    bool reflections = a->reflection && b->reflection;
    return a->radiance && b->radiance && memcmp(a->radiance, b->radiance, PLANE_BYTES) == 0 &&
           memcmp(a->visibility, b->visibility, PLANE_BYTES) == 0 && memcmp(a->motion, b->motion, PLANE_BYTES) == 0 &&
           (!reflections || memcmp(a->reflection, b->reflection, PLANE_BYTES) == 0);
}

/* cv_renderer_render of `s` with `frames` frames on `gpus` devices (its own renderer). */
static void render_frames(const fixture *fx, uint32_t gpus, cv_render_settings s, uint32_t frames,
                          cv_render_output *out) {
    s.frames = frames;
    CHECK_OK(cv_test_gpus_render(&fx->g, gpus, fx->scene, fx->bvh, &s, out, NULL));
}

/* `count` steps of `s` on r, checking accumulated goes from `from` + 1 up. */
static void steps(cv_renderer *r, const cv_render_settings *s, uint32_t count, uint32_t from) {
    for (uint32_t k = 0; k < count; k++) {
        cv_render_step step = { 0 };
        CHECK_OK(cv_renderer_step(r, s, &step));
        CHECK_EQ_INT(step.accumulated, from + k + 1);
        CHECK_EQ_INT(step.width, W);
        CHECK_EQ_INT(step.height, H);
    }
}

/* (a) and (d): N steps on `gpus` devices against a one-device render of N frames. */
static void check_still_and_moving(const fixture *fx, uint32_t gpus) {
    cv_render_settings moving = still;
    moving.orbit_degrees = 2.0f;
    const cv_render_settings *views[2] = { &still, &moving };
    for (int v = 0; v < 2; v++) {
        cv_renderer *r = NULL;
        CHECK_OK(cv_renderer_create(fx->g.devices, gpus, fx->scene, fx->bvh, &r));
        steps(r, views[v], N, 0);
        cv_render_output stepped = { 0 }, rendered = { 0 };
        CHECK_OK(cv_renderer_read_output(r, &stepped));
        render_frames(fx, 1, *views[v], N, &rendered);
        CHECK(same_planes(&stepped, &rendered));
        cv_render_output_free(&stepped);
        cv_render_output_free(&rendered);
        cv_renderer_destroy(r);
    }
}

/* (b) a camera change restarts; (c) bad settings change nothing. */
static void check_restart_and_refusal(const fixture *fx) {
    cv_renderer *r = NULL;
    CHECK_OK(cv_renderer_create(fx->g.devices, 1, fx->scene, fx->bvh, &r));
    cv_render_settings s = still, bad = still;
    steps(r, &s, 2, 0);
    bad.ao_samples = 40;
    cv_render_step step = { 0 };
    CHECK_RESULT(cv_renderer_step(r, &bad, &step), CV_ERROR_OUT_OF_RANGE);
    s.frames = 1000; /* ignored, as first_frame is */
    s.first_frame = 7;
    steps(r, &s, 2, 2);
    cv_render_output stepped = { 0 }, rendered = { 0 }, before = { 0 };
    CHECK_OK(cv_renderer_read_output(r, &before));
    render_frames(fx, 1, still, N, &rendered);
    CHECK(same_planes(&before, &rendered));
    cv_render_output_free(&rendered);

    cv_render_settings moved = still;
    const float eye[3] = { 0.3f, 1.4f, 2.6f }, target[3] = { 0.0f, 1.0f, 0.0f };
    memcpy(moved.camera_eye, eye, sizeof(eye));
    memcpy(moved.camera_target, target, sizeof(target));
    moved.camera_fov_degrees = 60.0f;
    steps(r, &moved, 1, 0);
    CHECK_OK(cv_renderer_read_output(r, &stepped));
    render_frames(fx, 1, moved, 1, &rendered);
    CHECK(same_planes(&stepped, &rendered));
    CHECK(memcmp(stepped.radiance, before.radiance, PLANE_BYTES) != 0);
    cv_render_output_free(&stepped);
    cv_render_output_free(&rendered);
    cv_render_output_free(&before);

    cv_render_settings brighter = moved;
    brighter.exposure = 1.0f;
    steps(r, &moved, 1, 1);
    steps(r, &brighter, 1, 0);
    brighter.exposure = 21.0f;
    CHECK_RESULT(cv_renderer_step(r, &brighter, &step), CV_ERROR_OUT_OF_RANGE);
    cv_renderer_destroy(r);
}

/* (e) the display against the CPU's tone map of the radiance read back. */
static void check_display(const fixture *fx, cv_renderer *r, float exposure) {
    cv_render_settings s = still;
    s.exposure = exposure;
    cv_render_step step = { 0 };
    CHECK_OK(cv_renderer_step(r, &s, &step));
    CHECK_OK(cv_device_wait(fx->g.devices[0], step.ticket, UINT64_MAX));
    float *radiance = malloc(PLANE_BYTES);
    uint8_t *display = malloc(W * H * 4), *cpu = malloc(W * H * 4);
    cv_rect all = { 0, 0, W, H };
    CHECK_OK(cv_device_read_texture(fx->g.devices[0], step.radiance, all, radiance));
    CHECK_OK(cv_device_read_texture(fx->g.devices[0], step.display, all, display));
    CHECK_OK(cv_tonemap_to_srgb8(&(cv_tonemap_desc){ .exposure = exposure, .curve = CV_TONEMAP_ACES }, radiance, 4, W,
                                 H, cpu, 4));
    int worst = 0;
    uint32_t off = 0, mid = 0;
    for (uint32_t i = 0; i < W * H * 4; i++) {
        int d = abs((int)display[i] - (int)cpu[i]);
        worst = d > worst ? d : worst;
        off += d != 0;
        mid += i % 4 != 3 && cpu[i] > 16 && cpu[i] < 240;
    }
    fprintf(stderr, "display at exposure %g: %u of %u bytes differ, by %d at most; %u mid-tone bytes\n",
            (double)exposure, off, W * H * 4, worst, mid);
    CHECK(worst <= 1);
    CHECK(mid > W * H); /* the room's tones, not a black or white image */
    free(radiance);
    free(display);
    free(cpu);
}

static void refuse_step(uint32_t frame, uint32_t frames, void *user) {
    (void)frame;
    (void)frames;
    cv_render_step step;
    CHECK_RESULT(cv_renderer_step(user, &still, &step), CV_ERROR_BAD_STATE);
}

/* (e) and (f) */
static void check_display_ring(const fixture *fx, uint32_t gpus) {
    cv_renderer *r = NULL;
    CHECK_OK(cv_renderer_create(fx->g.devices, gpus, fx->scene, fx->bvh, &r));
    cv_render_output out = { 0 };
    CHECK_RESULT(cv_renderer_read_output(r, &out), CV_ERROR_BAD_STATE);
    cv_render_step step[CV_RENDER_DISPLAY_SLOTS + 1];
    for (uint32_t k = 0; k <= CV_RENDER_DISPLAY_SLOTS; k++)
        CHECK_OK(cv_renderer_step(r, &still, &step[k]));
    for (uint32_t k = 1; k < CV_RENDER_DISPLAY_SLOTS; k++)
        CHECK(step[k].display.id != step[0].display.id && step[k].display.id != step[k - 1].display.id);
    CHECK_EQ_INT(step[CV_RENDER_DISPLAY_SLOTS].display.id, step[0].display.id);
    CHECK_EQ_INT(step[1].radiance.id, step[0].radiance.id);
    const float exposures[3] = { 0.0f, 1.5f, -2.0f };
    for (int e = 0; e < 3; e++)
        check_display(fx, r, exposures[e]);
    cv_render_settings s = still;
    s.frames = 2;
    CHECK_OK(cv_renderer_render(r, &s, &out, NULL, refuse_step, r));
    cv_render_output_free(&out);
    CHECK_OK(cv_renderer_step(r, &still, &step[0]));
    CHECK_EQ_INT(step[0].accumulated, 1); /* a render ends the steps' history */
    cv_renderer_destroy(r);
}

int main(void) {
    fixture fx = { 0 };
    CHECK_OK(cv_test_gpus_open(2, &fx.g));
    CHECK_OK(cv_scene_make_room(1, &fx.scene));
    if (fx.scene)
        CHECK_OK(cv_bvh_build_flat(fx.scene, NULL, &fx.bvh));
    if (fx.g.count == 2 && fx.bvh) {
        check_still_and_moving(&fx, 1);
        check_still_and_moving(&fx, 2);
        check_restart_and_refusal(&fx);
        check_display_ring(&fx, 1);
        check_display_ring(&fx, 2);
    }
    cv_test_gpus_close(&fx.g);
    CHECK_EQ_INT(cv_vulkan_validation_message_count(), 0);
    cv_bvh_destroy(fx.bvh);
    cv_scene_destroy(fx.scene);
    CHECK_NOTHING_LIVE();
    return check_report("renderer steps");
}
