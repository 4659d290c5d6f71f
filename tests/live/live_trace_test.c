/* The live's trace (corvid/live_trace.h) on lavapipe at 96x54: a live given a
 * trace presents FRAMES frames against credits given one at a time (the
 * render thread runs ahead, so steps are spoiled), with a settings change
 * midway; the file written afterwards is valid JSON (cJSON parses it) whose
 * spans are in time order with no negative duration, with exactly one read,
 * encode, link and send span per presented frame (frames 1..FRAMES), a render
 * span for every step (presented, spoiled or the last) that ends before its
 * frame's read starts, and a spoiled instant per spoiled step. A path that
 * cannot be written gives CV_ERROR_IO naming it. */
#include <cjson/cJSON.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "check.h"
#include "corvid/bvh.h"
#include "corvid/clock.h"
#include "corvid/live.h"
#include "corvid/live_trace.h"
#include "corvid/scene_procedural.h"
#include "corvid/vulkan.h"
#include "test_adapter.h"

#define FRAMES 8u
#define MAX_STEPS 256u
#define WAIT_MS 60000u

typedef struct sink {
    pthread_mutex_t lock;
    pthread_cond_t cond;
    uint64_t frames;
} sink;

static void on_frame(const cv_live_frame *f, void *user) {
    sink *k = user;
    (void)f;
    pthread_mutex_lock(&k->lock);
    k->frames++;
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

/* The live run: FRAMES frames, one credit at a time; its stats before it stops. */
static void run_live(cv_device *dev, cv_renderer *r, cv_live_trace *trace, cv_live_stats *st) {
    sink k = { 0 };
    pthread_mutex_init(&k.lock, NULL);
    cv_cond_init(&k.cond);
    cv_render_settings s = { .width = 96, .height = 54, .ao_samples = 1 };
    cv_live_desc d = { .renderer = r,
                       .primary = dev,
                       .settings = s,
                       .codec = CV_CODEC_JPEG,
                       .max_accumulate = 64,
                       .frame = on_frame,
                       .user = &k,
                       .trace = trace };
    cv_live *l = NULL;
    CHECK_OK(cv_live_start(&d, &l));
    for (uint32_t i = 1; l && i <= FRAMES; i++) {
        if (i == FRAMES / 2) {
            s.ao_samples = 2;
            CHECK_OK(cv_live_update(l, &s, 1));
        }
        cv_live_credit(l, 1);
        CHECK(wait_frames(&k, i));
    }
    if (l)
        cv_live_get_stats(l, st);
    cv_live_stop(l);
    CHECK_EQ_INT(st->presented, FRAMES);
    pthread_mutex_destroy(&k.lock);
    pthread_cond_destroy(&k.cond);
}

static double number(const cJSON *o, const char *key) {
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(o, key);
    return cJSON_IsNumber(v) ? v->valuedouble : -1.0;
}

/* Per track: spans (or instants) per frame / step; render spans' ends by step; reads' starts by frame. */
typedef struct seen {
    uint32_t per_frame[4][FRAMES + 1]; /* read, encode, link, send */
    uint64_t step_of[FRAMES + 1];      /* the step frame f presented */
    double read_start[FRAMES + 1];
    double render_end[MAX_STEPS + 1];
    uint32_t renders, spoiled, others;
    bool ordered, durations_ok;
} seen;

static void tally(const cJSON *e, seen *s, double *last_ts) {
    static const char *const tracks[4] = { "read", "encode", "link", "send" };
    const cJSON *ph = cJSON_GetObjectItemCaseSensitive(e, "ph");
    const cJSON *name = cJSON_GetObjectItemCaseSensitive(e, "name");
    if (!cJSON_IsString(ph) || !cJSON_IsString(name) || !strcmp(ph->valuestring, "M"))
        return;
    double ts = number(e, "ts"), dur = !strcmp(ph->valuestring, "X") ? number(e, "dur") : 0.0;
    const cJSON *args = cJSON_GetObjectItemCaseSensitive(e, "args");
    uint64_t frame = (uint64_t)number(args, "frame"), step = (uint64_t)number(args, "step");
    s->ordered = s->ordered && ts >= *last_ts;
    s->durations_ok = s->durations_ok && dur >= 0.0;
    *last_ts = ts;
    for (int t = 0; t < 4; t++) {
        if (strcmp(name->valuestring, tracks[t]) || frame < 1 || frame > FRAMES)
            continue;
        s->per_frame[t][frame]++;
        s->step_of[frame] = step;
        if (t == 0)
            s->read_start[frame] = ts;
        return;
    }
    if (!strcmp(name->valuestring, "render") && step >= 1 && step <= MAX_STEPS) {
        s->renders++;
        s->render_end[step] = ts + dur;
    } else if (!strcmp(name->valuestring, "spoiled") && !strcmp(ph->valuestring, "i")) {
        s->spoiled++;
    } else {
        s->others++;
    }
}

static void check_file(const char *path, const cv_live_stats *st) {
    FILE *f = fopen(path, "rb");
    char *text = calloc(1, 1 << 22);
    size_t n = f && text ? fread(text, 1, (1 << 22) - 1, f) : 0;
    if (f)
        fclose(f);
    cJSON *root = cJSON_Parse(text);
    CHECK(n > 0 && root);
    const cJSON *events = cJSON_GetObjectItemCaseSensitive(root, "traceEvents");
    CHECK(cJSON_IsArray(events));
    seen s = { .ordered = true, .durations_ok = true };
    double last_ts = 0.0;
    const cJSON *e;
    cJSON_ArrayForEach(e, events) tally(e, &s, &last_ts);
    CHECK(s.ordered && s.durations_ok);
    CHECK_EQ_INT(s.others, 0);
    for (uint32_t fr = 1; fr <= FRAMES; fr++) {
        for (int t = 0; t < 4; t++)
            CHECK_EQ_INT(s.per_frame[t][fr], 1);
        uint64_t step = s.step_of[fr];
        CHECK(step >= 1 && step <= MAX_STEPS && s.render_end[step] > 0.0 &&
              s.render_end[step] <= s.read_start[fr] + 1e-3);
    }
    /* Every step is a render span: presented, spoiled, or the newest (not yet taken) when the live stopped. */
    CHECK(s.spoiled >= st->spoiled && s.renders >= st->rendered);
    CHECK(s.renders - FRAMES - s.spoiled <= 1);
    cJSON_Delete(root);
    free(text);
}

int main(void) {
    cv_scene *scene = NULL;
    cv_bvh *bvh = NULL;
    cv_context *ctx = NULL;
    cv_device *dev = NULL;
    cv_renderer *r = NULL;
    cv_live_trace *trace = NULL;
    CHECK_OK(cv_scene_make_room(1, &scene));
    CHECK_OK(cv_bvh_build_flat(scene, NULL, &bvh));
    CHECK_OK(cv_context_create(NULL, &ctx));
    CHECK_OK(cv_device_create(ctx, cv_vulkan_backend(),
                              &(cv_device_desc){ .adapter = cv_test_adapter(), .validation = true }, &dev));
    CHECK_OK(cv_renderer_create(&dev, 1, scene, bvh, &r));
    CHECK_OK(cv_live_trace_create(&trace));
    char path[64];
    snprintf(path, sizeof path, "/tmp/corvid_live_trace_%d.json", (int)getpid());
    if (r && trace) {
        cv_live_stats st = { 0 };
        run_live(dev, r, trace, &st);
        CHECK_OK(cv_live_trace_write(trace, path));
        check_file(path, &st);
        remove(path);
        CHECK_RESULT(cv_live_trace_write(trace, "/nonexistent-dir/x.json"), CV_ERROR_IO);
        CHECK(strstr(cv_last_error(), "/nonexistent-dir/x.json") != NULL);
    }
    cv_live_trace_destroy(trace);
    cv_renderer_destroy(r);
    cv_context_destroy(ctx);
    cv_bvh_destroy(bvh);
    cv_scene_destroy(scene);
    CHECK_NOTHING_LIVE();
    return check_report("live_trace");
}
