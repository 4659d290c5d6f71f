/* The live loop over a link: the renderer on a proxy device of a corvid-node
 * reached through a relay that adds 10 ms each way and caps each direction at
 * 2 MB/s (tools/relay), lavapipe at 128x72.
 *  - a viewer that takes every frame: each input's first frame comes after at
 *    most CV_RENDER_DISPLAY_SLOTS frames of older input (input is never
 *    queued behind frames), and the link carries kilobytes a frame;
 *  - a slow viewer (one credit in 400 ms) while the camera moves: frames are
 *    spoiled (counted), only credited ones are sent. */
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "check.h"
#include "corvid/clock.h"
#include "corvid/live.h"
#include "corvid/proxy.h"
#include "corvid/scene_procedural.h"
#include "corvid/vulkan.h"
#include "scratch_node.h"
#include "tcp_relay.h"

#define W 128
#define H 72
#define WAIT_MS 60000u
#define INPUTS 6u

typedef struct viewer {
    pthread_mutex_t lock;
    pthread_cond_t cond;
    cv_live *live;
    bool fast; /* gives a credit back for every frame */
    uint64_t frames, newest_seq;
    uint64_t credits;     /* given, in all */
    uint64_t stale_after; /* frames of a seq older than `awaited` since its update */
    uint64_t awaited;
} viewer;

static void on_frame(const cv_live_frame *f, void *user) {
    viewer *v = user;
    pthread_mutex_lock(&v->lock);
    v->frames++;
    if (f->input_seq < v->awaited)
        v->stale_after++;
    if (f->input_seq > v->newest_seq)
        v->newest_seq = f->input_seq;
    bool fast = v->fast;
    v->credits += fast;
    pthread_cond_broadcast(&v->cond);
    pthread_mutex_unlock(&v->lock);
    if (fast)
        cv_live_credit(v->live, 1);
}

static cv_render_settings view(float angle) {
    cv_render_settings s = { .width = W, .height = H, .ao_samples = 2, .camera_fov_degrees = 50.0f };
    float eye[3] = { 11.0f * sinf(angle), 2.4f, 11.0f * cosf(angle) }, target[3] = { 0.0f, 1.2f, 0.0f };
    memcpy(s.camera_eye, eye, sizeof(eye));
    memcpy(s.camera_target, target, sizeof(target));
    return s;
}

/* Every input's first frame, each after at most CV_RENDER_DISPLAY_SLOTS older ones. */
static void fast_viewer(cv_live *l, viewer *v) {
    pthread_mutex_lock(&v->lock);
    v->fast = true;
    v->credits += 2;
    pthread_mutex_unlock(&v->lock);
    cv_live_credit(l, 2);
    for (uint64_t seq = 1; seq <= INPUTS; seq++) {
        cv_render_settings s = view(0.1f * (float)seq);
        pthread_mutex_lock(&v->lock);
        v->awaited = seq;
        v->stale_after = 0;
        pthread_mutex_unlock(&v->lock);
        CHECK_OK(cv_live_update(l, &s, seq));
        uint64_t deadline = cv_deadline_after_ms(WAIT_MS);
        pthread_mutex_lock(&v->lock);
        while (v->newest_seq < seq && cv_cond_wait_until(&v->cond, &v->lock, deadline) == 0) {
        }
        CHECK(v->newest_seq >= seq);
        CHECK(v->stale_after <= CV_RENDER_DISPLAY_SLOTS);
        pthread_mutex_unlock(&v->lock);
    }
    /* No credit given from here on: the frames of those given come (the view still accumulates). */
    uint64_t deadline = cv_deadline_after_ms(WAIT_MS);
    pthread_mutex_lock(&v->lock);
    v->fast = false;
    while (v->frames < v->credits && cv_cond_wait_until(&v->cond, &v->lock, deadline) == 0) {
    }
    CHECK_EQ_INT(v->frames, v->credits);
    pthread_mutex_unlock(&v->lock);
    cv_live_stats st;
    cv_live_get_stats(l, &st);
    printf("fast viewer: %llu rendered, %llu presented, %llu spoiled, input age last %.0f ms, max %.0f ms\n",
           (unsigned long long)st.rendered, (unsigned long long)st.presented, (unsigned long long)st.spoiled,
           st.input_age_ms, st.input_age_max_ms);
    CHECK(st.input_age_ms > 0 && st.input_age_max_ms >= st.input_age_ms);
}

/* One credit in 400 ms while the camera moves: the rest is spoiled. */
static void slow_viewer(cv_live *l, viewer *v) {
    cv_live_stats before, after;
    cv_live_get_stats(l, &before);
    pthread_mutex_lock(&v->lock);
    uint64_t frames = v->frames;
    pthread_mutex_unlock(&v->lock);
    uint64_t seq = INPUTS;
    for (int credit = 0; credit < 4; credit++) {
        double until = cv_now_ms() + 400.0;
        while (cv_now_ms() < until) {
            cv_render_settings s = view(0.1f * (float)++seq);
            CHECK_OK(cv_live_update(l, &s, seq));
            nanosleep(&(struct timespec){ .tv_nsec = 40000000 }, NULL); /* input at 25 Hz */
        }
        cv_live_credit(l, 1);
    }
    uint64_t deadline = cv_deadline_after_ms(WAIT_MS);
    pthread_mutex_lock(&v->lock);
    while (v->frames < frames + 4 && cv_cond_wait_until(&v->cond, &v->lock, deadline) == 0) {
    }
    CHECK_EQ_INT(v->frames, frames + 4);
    pthread_mutex_unlock(&v->lock);
    cv_live_get_stats(l, &after);
    printf("slow viewer: %llu rendered, %llu presented, %llu spoiled\n",
           (unsigned long long)(after.rendered - before.rendered),
           (unsigned long long)(after.presented - before.presented),
           (unsigned long long)(after.spoiled - before.spoiled));
    CHECK_EQ_INT(after.presented - before.presented, 4);
    CHECK(after.spoiled > before.spoiled);
    CHECK(after.spoiled + after.presented <= after.rendered);
}

int main(void) {
    cv_scene *scene = NULL;
    cv_bvh *bvh = NULL;
    CHECK_OK(cv_scene_make_room(1, &scene));
    CHECK_OK(cv_bvh_build_flat(scene, NULL, &bvh));
    scratch_node node;
    tcp_relay *relay = NULL;
    CHECK_OK(scratch_node_start(&node, cv_vulkan_backend(), 1, true));
    tcp_relay_desc link = { .target_port = (uint16_t)atoi(strrchr(node.endpoint, ':') + 1),
                            .delay_us = 10000,
                            .rate_bytes_per_s = 2u << 20 };
    CHECK_OK(tcp_relay_create(&link, &relay));
    cv_context *ctx = NULL;
    cv_device *dev = NULL;
    cv_renderer *r = NULL;
    cv_live *l = NULL;
    viewer v = { 0 };
    pthread_mutex_init(&v.lock, NULL);
    cv_cond_init(&v.cond);
    char endpoint[64] = "";
    if (relay)
        snprintf(endpoint, sizeof(endpoint), "127.0.0.1:%d", tcp_relay_port(relay));
    CHECK_OK(cv_context_create(NULL, &ctx));
    CHECK_OK(cv_device_create(ctx, cv_proxy_backend(), &(cv_device_desc){ .endpoint = endpoint }, &dev));
    if (dev && scene && bvh)
        CHECK_OK(cv_renderer_create(&dev, 1, scene, bvh, &r));
    if (r) {
        cv_live_desc d = { .renderer = r,
                           .primary = dev,
                           .settings = view(0.0f),
                           .codec = CV_CODEC_JPEG,
                           .frame = on_frame,
                           .user = &v };
        CHECK_OK(cv_live_start(&d, &l));
        v.live = l; /* before any credit: no frame comes until then */
    }
    if (l) {
        tcp_relay_stats link_before = tcp_relay_get_stats(relay);
        fast_viewer(l, &v);
        slow_viewer(l, &v);
        cv_live_stats st;
        cv_live_get_stats(l, &st);
        tcp_relay_stats link_after = tcp_relay_get_stats(relay);
        double per_frame = (double)(link_after.bytes_to_client - link_before.bytes_to_client) / (double)st.rendered;
        printf("node to client: %.1f kB per rendered frame (JPEG frames %.1f kB; raw RGBA32F planes: %.1f kB each)\n",
               per_frame / 1e3, (double)st.bytes / (double)st.presented / 1e3, W * H * 16 / 1e3);
        CHECK(!st.failed);
        cv_live_stop(l);
    }
    cv_renderer_destroy(r);
    if (ctx)
        cv_context_destroy(ctx);
    tcp_relay_stop(relay);
    scratch_node_stop(&node);
    cv_bvh_destroy(bvh);
    cv_scene_destroy(scene);
    pthread_mutex_destroy(&v.lock);
    pthread_cond_destroy(&v.cond);
    CHECK_NOTHING_LIVE();
    return check_report("live_link");
}
