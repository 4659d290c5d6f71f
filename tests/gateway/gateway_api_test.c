/* The REST gateway through cv_gateway_handle (no HTTP server): every endpoint
 * and every refusal (bad JSON, unknown fields, sizes, out-of-range settings,
 * unknown scene hash, cancel twice, a full queue), and two jobs rendering at
 * once with different settings, each image bit for bit the renderer's own for
 * its settings (EXR radiance, PNG bytes). Lavapipe, 64x48. */
#include <dirent.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "check.h"
#include "corvid/image_exr.h"
#include "corvid/image_png.h"
#include "corvid/scene_import.h"
#include "corvid/scene_procedural.h"
#include "corvid/sha256.h"
#include "corvid/tonemap.h"
#include "corvid/clock.h"
#include "gateway_support.h"
#include "test_render.h"

static char temp_dir[256];

/* A gate in the jobs' open_devices: while armed, a job waits there until a second one comes, so two jobs
 * that both pass it were on the two workers at once (or it times out and the test says so). */
typedef struct job_gate {
    pthread_mutex_t lock;
    pthread_cond_t both;
    bool armed;
    int arrived;
} job_gate;

static job_gate gate = { .lock = PTHREAD_MUTEX_INITIALIZER, .both = PTHREAD_COND_INITIALIZER };

static cv_result open_gated_gpu(void *user, cv_gateway_devices *out) {
    pthread_mutex_lock(&gate.lock);
    if (gate.armed) {
        gate.arrived++;
        pthread_cond_broadcast(&gate.both);
        double deadline = cv_now_ms() + 60000;
        while (gate.arrived < 2 && cv_now_ms() < deadline) {
            struct timespec t;
            clock_gettime(CLOCK_REALTIME, &t);
            t.tv_sec += 1;
            pthread_cond_timedwait(&gate.both, &gate.lock, &t);
        }
        gate.armed = false;
    }
    pthread_mutex_unlock(&gate.lock);
    return gw_test_open_gpu(user, out);
}

static size_t temp_entries(void) {
    size_t n = 0;
    DIR *d = opendir(temp_dir);
    for (struct dirent *e; d && (e = readdir(d)) != NULL;)
        n += strcmp(e->d_name, ".") != 0 && strcmp(e->d_name, "..") != 0;
    if (d)
        closedir(d);
    return n;
}

/* Expects `status` and, for an error, a message containing `needle`. */
static void expect(gw_test_reply r, int status, const char *needle, int line) {
    check_count++;
    const char *error = gw_json_string(&r, "error");
    if (r.status != status || (needle && !strstr(error, needle))) {
        check_failures++;
        fprintf(stderr, "gateway_api_test.c:%d: status %d (expected %d), body %s (expected to contain '%s')\n", line,
                r.status, status, r.body, needle ? needle : "");
    }
    gw_reply_free(&r);
}
#define EXPECT(reply, status, needle) expect((reply), (status), (needle), __LINE__)

static void sha_of(const void *data, size_t size, char hex[CV_SHA256_HEX_SIZE]) {
    uint8_t digest[CV_SHA256_SIZE];
    cv_sha256(data, size, digest);
    cv_sha256_hex(digest, hex);
}

static void test_root_and_routes(cv_gateway *g) {
    gw_test_reply r = gw_call(g, "GET", "/api/v1", NULL, 0);
    CHECK_EQ_INT(r.status, 200);
    CHECK_EQ_INT(gw_json_number(&r, "version"), 1);
    const cJSON *settings = cJSON_GetObjectItemCaseSensitive(r.json, "settings");
    bool has_ao = false;
    for (const cJSON *s = settings ? settings->child : NULL; s; s = s->next)
        has_ao = has_ao || strcmp(cJSON_GetObjectItemCaseSensitive(s, "name")->valuestring, "ao-samples") == 0;
    CHECK(has_ao);
    gw_reply_free(&r);
    EXPECT(gw_call(g, "POST", "/api/v1", NULL, 0), 405, "method not allowed");
    EXPECT(gw_call(g, "GET", "/api/v2/jobs", NULL, 0), 404, "/api/v1");
    EXPECT(gw_call(g, "GET", "/api/v1/colours", NULL, 0), 404, "no such endpoint");
    EXPECT(gw_call(g, "PATCH", "/api/v1/jobs", NULL, 0), 405, "GET, POST");
    EXPECT(gw_call(g, "PUT", "/api/v1/jobs/1/image.png", NULL, 0), 405, "(GET)");
    EXPECT(gw_call(g, "GET", "/api/v1/jobs//image.png", NULL, 0), 404, "no such endpoint");
    EXPECT(gw_call(g, "GET", "/api/v1/jobs/0", NULL, 0), 404, "whole numbers from 1");
    r = gw_call(g, "GET", "/index.html", NULL, 0);
    CHECK_EQ_INT(r.status, 0); /* not the API's: the server's */
    gw_reply_free(&r);

    r = gw_call(g, "GET", "/api/v1/nodes", NULL, 0);
    CHECK_EQ_INT(r.status, 200);
    CHECK(strcmp(gw_json_string(&r, "source"), "local") == 0);
    const cJSON *nodes = cJSON_GetObjectItemCaseSensitive(r.json, "nodes");
    const cJSON *local = cJSON_GetArrayItem(nodes, 0);
    CHECK(local && strcmp(cJSON_GetObjectItemCaseSensitive(local, "health")->valuestring, "up") == 0);
    CHECK_EQ_INT(cJSON_GetArraySize(cJSON_GetObjectItemCaseSensitive(local, "devices")), 1);
    gw_reply_free(&r);
}

static void test_scenes(cv_gateway *g, char sha[CV_SHA256_HEX_SIZE]) {
    size_t size = strlen(gw_test_gltf);
    sha_of(gw_test_gltf, size, sha);
    char path[160], other[160];
    snprintf(path, sizeof(path), "/api/v1/scenes/%s", sha);
    EXPECT(gw_call(g, "HEAD", path, NULL, 0), 404, NULL);
    EXPECT(gw_call(g, "GET", path, NULL, 0), 404, "upload it first");
    /* The path's hash must be the body's. */
    snprintf(other, sizeof(other), "/api/v1/scenes/%064d", 0);
    EXPECT(gw_call(g, "PUT", other, gw_test_gltf, size), 400, "SHA-256");
    EXPECT(gw_call(g, "PUT", "/api/v1/scenes/abc", gw_test_gltf, size), 400, "64 hex digits");
    gw_test_reply r = gw_call(g, "PUT", path, gw_test_gltf, size);
    CHECK_EQ_INT(r.status, 201);
    CHECK(strcmp(gw_json_string(&r, "scene"), sha) == 0);
    gw_reply_free(&r);
    r = gw_call(g, "PUT", path, gw_test_gltf, size); /* known: nothing new */
    CHECK_EQ_INT(r.status, 200);
    CHECK(cJSON_IsFalse(cJSON_GetObjectItemCaseSensitive(r.json, "created")));
    gw_reply_free(&r);
    EXPECT(gw_call(g, "HEAD", path, NULL, 0), 200, NULL);
    r = gw_call(g, "GET", path, NULL, 0);
    CHECK_EQ_INT(r.status, 200);
    CHECK_EQ_INT(gw_json_number(&r, "triangles"), 3);
    CHECK_EQ_INT(gw_json_number(&r, "bytes"), size);
    gw_reply_free(&r);
    /* POST: the hash computed here; a GLB. */
    size_t glb_size;
    uint8_t *glb = gw_test_glb(&glb_size);
    char glb_sha[CV_SHA256_HEX_SIZE];
    sha_of(glb, glb_size, glb_sha);
    r = gw_call(g, "POST", "/api/v1/scenes", glb, glb_size);
    CHECK_EQ_INT(r.status, 201);
    if (r.status != 201)
        fprintf(stderr, "  %s\n", r.body);
    CHECK(strcmp(gw_json_string(&r, "scene"), glb_sha) == 0);
    gw_reply_free(&r);
    /* A truncated GLB, a model the loader refuses, nothing, too much: refused, nothing stored or left behind. */
    EXPECT(gw_call(g, "POST", "/api/v1/scenes", glb, glb_size - 8), 400, "scene: ");
    EXPECT(gw_call(g, "POST", "/api/v1/scenes", "{\"asset\":", 9), 400, "scene: ");
    EXPECT(gw_call(g, "POST", "/api/v1/scenes", "", 0), 400, "empty");
    char *big = calloc(1, 64 * 1024 + 1);
    EXPECT(gw_call(g, "POST", "/api/v1/scenes", big, 64 * 1024 + 1), 413, "limit of 65536 bytes");
    free(big);
    char bad_sha[CV_SHA256_HEX_SIZE];
    sha_of("{\"asset\":", 9, bad_sha);
    snprintf(other, sizeof(other), "/api/v1/scenes/%s", bad_sha);
    EXPECT(gw_call(g, "HEAD", other, NULL, 0), 404, NULL);
    CHECK_EQ_INT(temp_entries(), 0);
    EXPECT(gw_call(g, "DELETE", path, NULL, 0), 405, NULL);
    free(glb);
}

static void test_job_refusals(cv_gateway *g) {
    const char *jobs = "/api/v1/jobs";
    EXPECT(gw_call_text(g, "POST", jobs, "{\"width\": 64,"), 400, "body: not valid JSON");
    EXPECT(gw_call_text(g, "POST", jobs, "{} {}"), 400, "body: more after");
    EXPECT(gw_call_text(g, "POST", jobs, "[64, 48]"), 400, "body: must be a JSON object");
    EXPECT(gw_call_text(g, "POST", jobs, "{\"colour\": \"red\"}"), 400, "unknown field 'colour'");
    EXPECT(gw_call_text(g, "POST", jobs, "{\"width\": 0}"), 400, "width: must be a whole number in");
    EXPECT(gw_call_text(g, "POST", jobs, "{\"height\": 4.5}"), 400, "height: ");
    EXPECT(gw_call_text(g, "POST", jobs, "{\"width\": 4000, \"height\": 4000}"), 400, "over the gateway's limit");
    EXPECT(gw_call_text(g, "POST", jobs, "{\"frames\": 5000}"), 400, "frames: '5000'");
    EXPECT(gw_call_text(g, "POST", jobs, "{\"frames\": [1]}"), 400, "frames: must be");
    EXPECT(gw_call_text(g, "POST", jobs, "{\"settings\": {\"ao-samples\": 40}}"), 400, "settings.ao-samples: '40'");
    EXPECT(gw_call_text(g, "POST", jobs, "{\"settings\": {\"shadow-samples\": 3}}"), 400, "settings.shadow-samples");
    EXPECT(gw_call_text(g, "POST", jobs, "{\"settings\": {\"reflections\": \"maybe\"}}"), 400,
           "settings.reflections");
    EXPECT(gw_call_text(g, "POST", jobs, "{\"settings\": {\"exposure\": 30}}"), 400, "settings.exposure");
    EXPECT(gw_call_text(g, "POST", jobs, "{\"settings\": {\"sparkle\": 1}}"), 400, "settings.sparkle: no such");
    EXPECT(gw_call_text(g, "POST", jobs, "{\"settings\": {\"frames\": 1}}"), 400, "settings.frames");
    EXPECT(gw_call_text(g, "POST", jobs, "{\"settings\": [1]}"), 400, "settings: must be an object");
    EXPECT(gw_call_text(g, "POST", jobs, "{\"camera\": {\"eye\": [0, 1, 5], \"target\": [0, 1, 0]}}"), 400,
           "camera.fov_degrees");
    EXPECT(gw_call_text(g, "POST", jobs, "{\"camera\": {\"eye\": [0, 1], \"target\": [0, 1, 0]}}"), 400,
           "camera.eye: must be an array of 3");
    EXPECT(gw_call_text(g, "POST", jobs,
                        "{\"camera\": {\"eye\": [0, 1, 5], \"target\": [0, 1, 5], \"fov_degrees\": 45}}"),
           400, "camera: ");
    EXPECT(gw_call_text(g, "POST", jobs,
                        "{\"camera\": {\"eye\": [0,1,5], \"target\": [0,1,0], \"fov_degrees\": 45, "
                        "\"roll\": 3}}"),
           400, "camera.roll: unknown field");
    EXPECT(gw_call_text(g, "POST", jobs, "{\"scene\": \"teapot\"}"), 400, "scene: must be");
    char body[200];
    snprintf(body, sizeof(body), "{\"scene\": \"%064d\"}", 7);
    EXPECT(gw_call_text(g, "POST", jobs, body), 404, "no stored model");
    EXPECT(gw_call(g, "GET", "/api/v1/jobs/999", NULL, 0), 404, "job 999: no such job");
    EXPECT(gw_call(g, "GET", "/api/v1/jobs/abc", NULL, 0), 404, "job ids are whole numbers");
    EXPECT(gw_call(g, "GET", "/api/v1/jobs/999/image.png", NULL, 0), 404, "no such job");
    EXPECT(gw_call(g, "DELETE", "/api/v1/jobs/999", NULL, 0), 404, "no such job");
    EXPECT(gw_call(g, "GET", "/api/v1/jobs/1/image.tiff", NULL, 0), 404, "no such endpoint");
    gw_test_reply r = gw_call(g, "GET", jobs, NULL, 0);
    CHECK_EQ_INT(r.status, 200);
    CHECK_EQ_INT(cJSON_GetArraySize(cJSON_GetObjectItemCaseSensitive(r.json, "jobs")), 0); /* none was made */
    gw_reply_free(&r);
}

static uint64_t submit(cv_gateway *g, const char *body) {
    gw_test_reply r = gw_call_text(g, "POST", "/api/v1/jobs", body);
    CHECK_EQ_INT(r.status, 201);
    if (r.status != 201)
        fprintf(stderr, "  %s\n", r.body);
    uint64_t id = (uint64_t)gw_json_number(&r, "id");
    gw_reply_free(&r);
    return id;
}

static void expect_state(cv_gateway *g, uint64_t id, const char *state) {
    char path[96];
    snprintf(path, sizeof(path), "/api/v1/jobs/%llu", (unsigned long long)id);
    gw_test_reply r = gw_call(g, "GET", path, NULL, 0);
    CHECK_EQ_INT(r.status, 200);
    check_count++;
    if (strcmp(gw_json_string(&r, "state"), state) != 0) {
        check_failures++;
        fprintf(stderr, "job %llu: %s, expected state %s\n", (unsigned long long)id, r.body, state);
    }
    gw_reply_free(&r);
}

/* A job's image through the API: the PNG's bytes and the EXR's beauty planes. */
static void fetch_images(cv_gateway *g, uint64_t id, gw_test_reply *png, cv_exr_image *exr) {
    char path[96], file[300];
    snprintf(path, sizeof(path), "/api/v1/jobs/%llu/image.png", (unsigned long long)id);
    *png = gw_call(g, "GET", path, NULL, 0);
    CHECK_EQ_INT(png->status, 200);
    CHECK(strcmp(png->content_type, "image/png") == 0);
    snprintf(path, sizeof(path), "/api/v1/jobs/%llu/image.exr", (unsigned long long)id);
    gw_test_reply e = gw_call(g, "GET", path, NULL, 0);
    CHECK_EQ_INT(e.status, 200);
    snprintf(file, sizeof(file), "%s-job.exr", temp_dir);
    FILE *f = fopen(file, "wb");
    fwrite(e.body, 1, e.body_size, f);
    fclose(f);
    CHECK_OK(cv_exr_read(file, exr));
    unlink(file);
    gw_reply_free(&e);
}

/* The renderer's own image of `settings` on `scene`: its radiance and the PNG corvid-render would write. */
static void direct_render(const cv_scene *scene, const cv_render_settings *settings, cv_render_output *out,
                          uint8_t **png, size_t *png_size) {
    cv_bvh *bvh = NULL;
    CHECK_OK(cv_bvh_build_flat(scene, NULL, &bvh));
    CHECK_OK(cv_test_render(1, scene, bvh, settings, out, NULL));
    cv_bvh_destroy(bvh);
    uint8_t *rgb = malloc((size_t)out->width * out->height * 3);
    CHECK_OK(cv_tonemap_to_srgb8(&(cv_tonemap_desc){ .exposure = settings->exposure }, out->radiance, 4, out->width,
                                 out->height, rgb, 3));
    char file[300];
    snprintf(file, sizeof(file), "%s-direct.png", temp_dir);
    CHECK_OK(cv_png_write(file, out->width, out->height, 3, rgb));
    free(rgb);
    FILE *f = fopen(file, "rb");
    fseek(f, 0, SEEK_END);
    *png_size = (size_t)ftell(f);
    fseek(f, 0, SEEK_SET);
    *png = malloc(*png_size);
    CHECK_EQ_INT(fread(*png, 1, *png_size, f), *png_size);
    fclose(f);
    unlink(file);
}

static void compare_with_direct(cv_gateway *g, uint64_t id, const cv_scene *scene, const cv_render_settings *s) {
    gw_test_reply png;
    cv_exr_image exr = { 0 };
    fetch_images(g, id, &png, &exr);
    cv_render_output direct = { 0 };
    uint8_t *direct_png = NULL;
    size_t direct_png_size = 0;
    direct_render(scene, s, &direct, &direct_png, &direct_png_size);
    CHECK_EQ_INT(exr.width, s->width);
    CHECK_EQ_INT(exr.height, s->height);
    static const char *const channels[4] = { "R", "G", "B", "A" };
    size_t n = (size_t)s->width * s->height, differ = 0;
    for (int c = 0; c < 4; c++) {
        const float *plane = cv_exr_image_find(&exr, channels[c]);
        CHECK(plane != NULL);
        for (size_t i = 0; plane && direct.radiance && i < n; i++)
            differ += memcmp(&plane[i], &direct.radiance[i * 4 + c], sizeof(float)) != 0;
    }
    CHECK_EQ_INT(differ, 0);
    CHECK(cv_exr_image_find(&exr, "depth.Z") != NULL);
    CHECK_EQ_INT(png.body_size, direct_png_size);
    CHECK(png.body_size == direct_png_size && memcmp(png.body, direct_png, direct_png_size) == 0);
    free(direct_png);
    cv_render_output_free(&direct);
    cv_exr_image_free(&exr);
    gw_reply_free(&png);
}

/* Two jobs at once (two workers), different scenes and settings: each gets its own image. */
static void test_concurrent_jobs(cv_gateway *g, const char *sha) {
    char body[512];
    snprintf(body, sizeof(body),
             "{\"scene\": \"%s\", \"width\": 64, \"height\": 48, \"frames\": 2, \"camera\": {\"eye\": [3, 2.5, 4], "
             "\"target\": [0, 0.5, 0], \"fov_degrees\": 50}, \"settings\": {\"ao-samples\": 2, \"exposure\": 0.5}}",
             sha);
    pthread_mutex_lock(&gate.lock);
    gate.armed = true;
    pthread_mutex_unlock(&gate.lock);
    uint64_t a = submit(g, body);
    uint64_t b = submit(g,
                        "{\"scene\": \"default\", \"width\": 64, \"height\": 48, \"frames\": 3, "
                        "\"settings\": {\"reflections\": \"off\", \"sun\": \"0.3,1,0.2,2\"}}");
    CHECK(a != b);
    CHECK_OK(cv_gateway_wait_job(g, a, UINT32_MAX, 120000));
    CHECK_OK(cv_gateway_wait_job(g, b, UINT32_MAX, 120000));
    expect_state(g, a, "done");
    expect_state(g, b, "done");
    pthread_mutex_lock(&gate.lock);
    CHECK_EQ_INT(gate.arrived, 2); /* both jobs were opening their devices at once */
    pthread_mutex_unlock(&gate.lock);
    gw_test_reply r = gw_call(g, "GET", "/api/v1/jobs", NULL, 0);
    CHECK_EQ_INT(cJSON_GetArraySize(cJSON_GetObjectItemCaseSensitive(r.json, "jobs")), 2);
    gw_reply_free(&r);

    cv_scene *model = NULL;
    char file[300];
    snprintf(file, sizeof(file), "%s-model.gltf", temp_dir);
    FILE *f = fopen(file, "wb");
    fputs(gw_test_gltf, f);
    fclose(f);
    CHECK_OK(cv_scene_import(file, &model));
    unlink(file);
    cv_render_settings sa = { .width = 64,
                              .height = 48,
                              .frames = 2,
                              .ao_samples = 2,
                              .exposure = 0.5f,
                              .camera_eye = { 3, 2.5f, 4 },
                              .camera_target = { 0, 0.5f, 0 },
                              .camera_fov_degrees = 50 };
    compare_with_direct(g, a, model, &sa);
    cv_scene_destroy(model);
    cv_scene *room = NULL;
    CHECK_OK(cv_scene_make_room(1, &room));
    cv_render_settings sb = { .width = 64,
                              .height = 48,
                              .frames = 3,
                              .reflections = -1,
                              .sun_toward = { 0.3f, 1, 0.2f },
                              .sun_cone_degrees = 2 };
    compare_with_direct(g, b, room, &sb);
    cv_scene_destroy(room);
    /* A done job cannot be cancelled. */
    char path[96];
    snprintf(path, sizeof(path), "/api/v1/jobs/%llu", (unsigned long long)a);
    EXPECT(gw_call(g, "DELETE", path, NULL, 0), 409, "has ended (done)");
}

/* Cancels: a running job (between frames), a queued one, each twice; their images never come. */
static void test_cancel(cv_gateway *g) {
    const char *long_job = "{\"width\": 64, \"height\": 48, \"frames\": 4096}";
    uint64_t run1 = submit(g, long_job), run2 = submit(g, long_job), queued = submit(g, long_job);
    CHECK_OK(cv_gateway_wait_job(g, run1, 1, 120000));
    CHECK_OK(cv_gateway_wait_job(g, run2, 1, 120000));
    expect_state(g, queued, "queued");
    char path[96], image[128];
    snprintf(path, sizeof(path), "/api/v1/jobs/%llu", (unsigned long long)queued);
    EXPECT(gw_call(g, "DELETE", path, NULL, 0), 200, NULL);
    expect_state(g, queued, "cancelled");
    EXPECT(gw_call(g, "DELETE", path, NULL, 0), 409, "has ended (cancelled)");
    snprintf(image, sizeof(image), "%s/image.png", path);
    EXPECT(gw_call(g, "GET", image, NULL, 0), 409, "is cancelled");
    for (uint64_t id = run1; id <= run2; id++) {
        snprintf(path, sizeof(path), "/api/v1/jobs/%llu", (unsigned long long)id);
        snprintf(image, sizeof(image), "%s/image.exr", path);
        EXPECT(gw_call(g, "GET", image, NULL, 0), 409, "is running");
        EXPECT(gw_call(g, "DELETE", path, NULL, 0), 200, NULL);
        gw_test_reply second = gw_call(g, "DELETE", path, NULL, 0);
        CHECK_EQ_INT(second.status, 409);
        gw_reply_free(&second);
        CHECK_OK(cv_gateway_wait_job(g, id, UINT32_MAX, 120000));
        expect_state(g, id, "cancelled");
        EXPECT(gw_call(g, "DELETE", path, NULL, 0), 409, "has ended (cancelled)");
    }
}

/* One worker, one waiting job at most: the next is 429; destroying the gateway cancels what runs. */
static void test_full_queue(void) {
    cv_gateway *g = NULL;
    CHECK_OK(cv_gateway_create(
        &(cv_gateway_desc){ .open_devices = gw_test_open_gpu, .workers = 1, .max_queued = 1, .temp_dir = temp_dir },
        &g));
    if (!g)
        return;
    const char *long_job = "{\"width\": 64, \"height\": 48, \"frames\": 4096}";
    uint64_t running = submit(g, long_job);
    CHECK_OK(cv_gateway_wait_job(g, running, 1, 120000));
    submit(g, long_job);
    EXPECT(gw_call_text(g, "POST", "/api/v1/jobs", long_job), 429, "wait already");
    cv_gateway_destroy(g);
}

static void test_bad_desc(void) {
    cv_gateway *g = NULL;
    CHECK_RESULT(cv_gateway_create(&(cv_gateway_desc){ 0 }, &g), CV_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(cv_gateway_create(&(cv_gateway_desc){ .open_devices = gw_test_open_gpu, .workers = 65 }, &g),
                 CV_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(cv_gateway_create(&(cv_gateway_desc){ .open_devices = gw_test_open_gpu, .nodes = "nohost" }, &g),
                 CV_ERROR_INVALID_ARGUMENT);
    CHECK(g == NULL);
}

int main(void) {
    snprintf(temp_dir, sizeof(temp_dir), "/tmp/corvid-gateway-test-XXXXXX");
    if (!mkdtemp(temp_dir))
        return 1;
    test_bad_desc();
    cv_gateway *g = NULL;
    CHECK_OK(cv_gateway_create(&(cv_gateway_desc){ .open_devices = open_gated_gpu,
                                                   .workers = 2,
                                                   .max_scene_bytes = 64 * 1024,
                                                   .max_pixels = 1920 * 1080,
                                                   .temp_dir = temp_dir },
                               &g));
    if (g) {
        char sha[CV_SHA256_HEX_SIZE];
        test_root_and_routes(g);
        test_scenes(g, sha);
        test_job_refusals(g);
        test_concurrent_jobs(g, sha);
        test_cancel(g);
        cv_gateway_destroy(g);
    }
    test_full_queue();
    CHECK_EQ_INT(temp_entries(), 0); /* nothing half-written left */
    rmdir(temp_dir);
    CHECK_NOTHING_LIVE();
    return check_report("gateway_api");
}
