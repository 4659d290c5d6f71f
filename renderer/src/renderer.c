/* One hybrid frame across N devices (see renderer.h). The passes are recorded
 * as command lists each frame (recording is cheap and lists are stateless);
 * multi-GPU data movement uses the partition copy plans and cross-device
 * transfers. */
#include "corvid/renderer.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "camera.h"
#include "corvid/transfer.h"
#include "scene_upload.h"

enum { PIPE_GBUFFER, PIPE_RAYGEN, PIPE_RESOLVE, PIPE_ACCUMULATE, PIPE_FILTER, PIPE_COMPOSITE, PIPE_COUNT };
static const char *pipeline_names[PIPE_COUNT] = {
    "render.gbuffer", "render.raygen", "render.resolve", "render.accumulate", "render.filter", "render.composite",
};

/* Size-dependent textures; `everywhere` ones are loaded on every device. */
enum { TEX_POSITION, TEX_NORMAL, TEX_VISIBILITY, TEX_DEPTH, TEX_HISTORY, TEX_PING, TEX_PONG, TEX_RADIANCE,
       TEX_ALBEDO, TEX_COUNT };
static const struct { cv_format format; uint32_t usage; bool everywhere; const char *label; } texture_info[TEX_COUNT] = {
    [TEX_POSITION] = { CV_FORMAT_RGBA32F, CV_TEXTURE_USAGE_COLOR_TARGET | CV_TEXTURE_USAGE_STORAGE, true, "gbuffer position" },
    [TEX_NORMAL] = { CV_FORMAT_RGBA32F, CV_TEXTURE_USAGE_COLOR_TARGET | CV_TEXTURE_USAGE_STORAGE, true, "gbuffer normal" },
    [TEX_VISIBILITY] = { CV_FORMAT_RGBA16F, CV_TEXTURE_USAGE_STORAGE, true, "visibility" },
    [TEX_DEPTH] = { CV_FORMAT_D32F, CV_TEXTURE_USAGE_DEPTH_TARGET, false, "depth" },
    [TEX_HISTORY] = { CV_FORMAT_RGBA32F, CV_TEXTURE_USAGE_STORAGE, false, "visibility history" },
    [TEX_PING] = { CV_FORMAT_RGBA32F, CV_TEXTURE_USAGE_STORAGE, false, "filter ping" },
    [TEX_PONG] = { CV_FORMAT_RGBA32F, CV_TEXTURE_USAGE_STORAGE, false, "filter pong" },
    [TEX_RADIANCE] = { CV_FORMAT_RGBA32F, CV_TEXTURE_USAGE_STORAGE, false, "radiance" },
    [TEX_ALBEDO] = { CV_FORMAT_RGBA32F, CV_TEXTURE_USAGE_STORAGE, false, "albedo" },
};

struct cv_renderer {
    cv_context *ctx;
    cv_device *devices[CV_RENDER_MAX_DEVICES];
    uint32_t count;
    const cv_scene *scene;
    render_scene_data data;
    cv_buffer vertices, materials, lights;
    cv_accel accel;
    cv_pipeline pipelines[PIPE_COUNT];
    cv_cmdlist lists[CV_RENDER_MAX_DEVICES];   /* per device: G-buffer, then each frame's trace */
    cv_cmdlist accumulate;                      /* the primary's accumulate (+ filter, composite) */
    uint32_t width, height;                 /* of the textures below; 0 = none yet */
    cv_texture textures[TEX_COUNT];
    cv_buffer rays[CV_RENDER_MAX_DEVICES], hits[CV_RENDER_MAX_DEVICES];
    uint64_t ray_capacity[CV_RENDER_MAX_DEVICES];   /* rays the buffers hold */
    double upload_ms;
};

/* Frames a single-device render keeps submitted ahead of the one it waits for:
 * enough to cover a round trip of tens of milliseconds to a remote device at
 * GPU frame times of a few milliseconds (an H200 renders 1280x720 in 2.9 ms;
 * 20 ms of latency needs 7 frames in flight). */
#define IN_FLIGHT_FRAMES 16u

static double now_ms(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec * 1e3 + ts.tv_nsec / 1e6;
}

static cv_result load_everywhere(cv_renderer *r, cv_handle h) {
    for (uint32_t d = 0; d < r->count; d++) {
        cv_result res = cv_device_load(r->devices[d], h);
        if (res != CV_OK)
            return res;
    }
    return CV_OK;
}

static cv_result upload_buffer(cv_renderer *r, const void *data, uint64_t size, const char *label, cv_buffer *out) {
    cv_buffer_desc desc = { .size = size, .usage = CV_BUFFER_USAGE_STORAGE };
    strncpy(desc.label, label, sizeof(desc.label) - 1);
    cv_result res = cv_buffer_create(r->ctx, &desc, out);
    if (res == CV_OK)
        res = load_everywhere(r, cv_any(*out));
    for (uint32_t d = 0; d < r->count && res == CV_OK; d++)
        res = cv_device_write_buffer(r->devices[d], *out, 0, size, data);
    return res;
}

cv_result cv_renderer_create(cv_device *const *devices, uint32_t device_count, const cv_scene *scene,
                             const cv_bvh *bvh, cv_renderer **out) {
    if (!devices || !scene || !bvh || !out || device_count == 0 || device_count > CV_RENDER_MAX_DEVICES)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "renderer: need 1..%u devices, a scene and its BVH",
                        CV_RENDER_MAX_DEVICES);
    cv_renderer *r = calloc(1, sizeof(*r));
    if (!r)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "renderer");
    r->ctx = cv_device_context(devices[0]);
    r->count = device_count;
    r->scene = scene;
    memcpy(r->devices, devices, device_count * sizeof(*devices));
    for (uint32_t d = 1; d < device_count; d++)
        if (cv_device_context(devices[d]) != r->ctx) {
            free(r);
            return cv_error(CV_ERROR_INVALID_ARGUMENT, "renderer: device %u belongs to another context", d);
        }
    double t0 = now_ms();
    cv_result res = render_scene_data_build(scene, &r->data);
    uint64_t vertex_bytes = r->data.vertex_count * sizeof(render_vertex);
    for (uint32_t d = 0; d < device_count && res == CV_OK; d++)
        if (vertex_bytes > cv_device_get_info(devices[d])->max_storage_buffer_range)
            res = cv_error(CV_ERROR_LIMIT_EXCEEDED, "renderer: %llu bytes of vertices exceed device '%s''s storage "
                           "buffer range of %llu bytes; use a smaller scene", (unsigned long long)vertex_bytes,
                           cv_device_label(devices[d]),
                           (unsigned long long)cv_device_get_info(devices[d])->max_storage_buffer_range);
    if (res == CV_OK)
        res = upload_buffer(r, r->data.vertices, vertex_bytes, "scene vertices", &r->vertices);
    if (res == CV_OK)
        res = upload_buffer(r, r->data.materials, r->data.material_count * sizeof(render_material), "materials",
                            &r->materials);
    if (res == CV_OK)
        res = upload_buffer(r, r->data.lights, (r->data.light_count + 1) * sizeof(render_light), "point lights",
                            &r->lights);
    /* Immutable scene data goes to every device once (the multicast rule). */
    if (res == CV_OK)
        res = cv_accel_create(r->ctx, &(cv_accel_desc){ .triangle_count = bvh->tri_count,
                                                         .node_count = bvh->node2_count, .label = "scene" },
                              &r->accel);
    if (res == CV_OK)
        res = load_everywhere(r, cv_any(r->accel));
    for (uint32_t d = 0; d < device_count && res == CV_OK; d++)
        res = cv_device_write_accel(devices[d], r->accel, bvh->nodes2, bvh->tris);
    for (int p = 0; p < PIPE_COUNT && res == CV_OK; p++) {
        res = cv_pipeline_create(r->ctx, pipeline_names[p], &r->pipelines[p]);
        if (res == CV_OK)
            res = load_everywhere(r, cv_any(r->pipelines[p]));
    }
    for (uint32_t d = 0; d < device_count && res == CV_OK; d++)
        res = cv_cmdlist_create(r->ctx, &r->lists[d]);
    if (res == CV_OK)
        res = cv_cmdlist_create(r->ctx, &r->accumulate);
    r->upload_ms = now_ms() - t0;
    if (res != CV_OK) {
        cv_renderer_destroy(r);
        return res;
    }
    *out = r;
    return CV_OK;
}

static void destroy_handle(cv_renderer *r, uint64_t id) {
    if (id)
        cv_destroy(r->ctx, (cv_handle){ id });
}

static void destroy_targets(cv_renderer *r) {
    for (int t = 0; t < TEX_COUNT; t++)
        destroy_handle(r, r->textures[t].id);
    for (uint32_t d = 0; d < r->count; d++) {
        destroy_handle(r, r->rays[d].id);
        destroy_handle(r, r->hits[d].id);
        r->rays[d].id = r->hits[d].id = 0;
        r->ray_capacity[d] = 0;
    }
    memset(r->textures, 0, sizeof(r->textures));
    r->width = r->height = 0;
}

void cv_renderer_destroy(cv_renderer *r) {
    if (!r)
        return;
    for (uint32_t d = 0; d < r->count; d++)
        cv_device_wait_idle(r->devices[d]);
    destroy_targets(r);
    destroy_handle(r, r->vertices.id);
    destroy_handle(r, r->materials.id);
    destroy_handle(r, r->lights.id);
    destroy_handle(r, r->accel.id);
    for (int p = 0; p < PIPE_COUNT; p++)
        destroy_handle(r, r->pipelines[p].id);
    for (uint32_t d = 0; d < r->count; d++)
        destroy_handle(r, r->lists[d].id);
    destroy_handle(r, r->accumulate.id);
    render_scene_data_free(&r->data);
    free(r);
}

static cv_result ensure_targets(cv_renderer *r, uint32_t width, uint32_t height) {
    if (r->width == width && r->height == height)
        return CV_OK;
    destroy_targets(r);
    cv_result res = CV_OK;
    for (int t = 0; t < TEX_COUNT && res == CV_OK; t++) {
        cv_texture_desc desc = { .width = width, .height = height, .format = texture_info[t].format,
                                 .usage = texture_info[t].usage };
        strncpy(desc.label, texture_info[t].label, sizeof(desc.label) - 1);
        res = cv_texture_create(r->ctx, &desc, &r->textures[t]);
        if (res == CV_OK)
            res = texture_info[t].everywhere ? load_everywhere(r, cv_any(r->textures[t]))
                                             : cv_device_load(r->devices[0], cv_any(r->textures[t]));
    }
    if (res == CV_OK) {
        r->width = width;
        r->height = height;
    }
    return res;
}

/* Grows a device's ray and hit buffers to hold `rays` rays. */
static cv_result ensure_ray_buffers(cv_renderer *r, uint32_t d, uint64_t rays) {
    if (rays <= r->ray_capacity[d])
        return CV_OK;
    destroy_handle(r, r->rays[d].id);
    destroy_handle(r, r->hits[d].id);
    r->rays[d].id = r->hits[d].id = 0;
    r->ray_capacity[d] = 0;
    uint64_t limit = cv_device_get_info(r->devices[d])->max_storage_buffer_range;
    if (rays * CV_RAY_BYTES > limit)
        return cv_error(CV_ERROR_LIMIT_EXCEEDED, "renderer: %llu rays (%llu bytes) exceed device '%s''s storage "
                        "buffer range; use fewer AO samples, a smaller image or more devices",
                        (unsigned long long)rays, (unsigned long long)(rays * CV_RAY_BYTES),
                        cv_device_label(r->devices[d]));
    cv_result res = cv_buffer_create(r->ctx, &(cv_buffer_desc){ .size = rays * CV_RAY_BYTES, .label = "rays" },
                                     &r->rays[d]);
    if (res == CV_OK)
        res = cv_device_load(r->devices[d], cv_any(r->rays[d]));
    if (res == CV_OK)
        res = cv_buffer_create(r->ctx, &(cv_buffer_desc){ .size = rays * CV_HIT_BYTES, .label = "hits" }, &r->hits[d]);
    if (res == CV_OK)
        res = cv_device_load(r->devices[d], cv_any(r->hits[d]));
    if (res == CV_OK)
        r->ray_capacity[d] = rays;
    return res;
}

static cv_binding bind_texture(cv_texture t) { return (cv_binding){ .resource = cv_any(t) }; }
static cv_binding bind_buffer(cv_buffer b) { return (cv_binding){ .resource = cv_any(b) }; }
static uint32_t groups(uint32_t n, uint32_t size) { return (n + size - 1) / size; }

static cv_result run_list(cv_device *dev, cv_cmdlist list, uint64_t *ticket) {
    cv_command_list *l;
    cv_result res = cv_cmdlist_get(cv_device_context(dev), list, &l);
    if (res == CV_OK)
        res = cv_command_list_end(l);
    if (res == CV_OK)
        res = cv_device_submit(dev, list, ticket);
    return res;
}

/* Primary: the G-buffer (position, normal) by rasterization. */
static cv_result record_gbuffer(cv_renderer *r, const cv_camera *camera, cv_command_list *l) {
    struct { float view_proj[16]; float camera[4]; } push;
    float near_plane = r->data.diagonal * 1e-4f, far_plane = r->data.diagonal * 4.0f;
    render_camera_view_proj(camera, (float)r->width / (float)r->height, near_plane, far_plane, push.view_proj);
    memcpy(push.camera, camera->position, sizeof(camera->position));
    push.camera[3] = 1.0f / far_plane;   /* render.gbuffer writes depth = view depth / far */
    cv_binding b = bind_buffer(r->vertices);
    cv_cmd_begin_marker(l, CV_QUEUE_GRAPHICS, &(cv_begin_marker_args){ .label = "gbuffer" });
    cv_cmd_begin_render_pass(l, CV_QUEUE_GRAPHICS, &(cv_begin_render_pass_args){
        .color0 = r->textures[TEX_POSITION], .color1 = r->textures[TEX_NORMAL], .depth = r->textures[TEX_DEPTH],
        .clear = 1, .clear_depth = 1.0f });
    cv_cmd_draw(l, CV_QUEUE_GRAPHICS, &(cv_draw_args){ .pipeline = r->pipelines[PIPE_GBUFFER], .bindings = &b,
                                                     .bindings_count = 1, .push = &push, .push_size = sizeof(push),
                                                     .vertex_count = (uint32_t)r->data.vertex_count,
                                                     .instance_count = 1 });
    cv_cmd_end_render_pass(l, CV_QUEUE_GRAPHICS, &(cv_end_render_pass_args){ 0 });
    return cv_cmd_end_marker(l, CV_QUEUE_GRAPHICS, &(cv_end_marker_args){ 0 });
}

/* Rays traced per band: the ray and hit buffers hold one band, so a partition
 * of any size fits the device's storage buffer range. */
static uint64_t band_rays(const cv_renderer *r, uint32_t d, const cv_render_settings *s) {
    uint64_t limit = cv_device_get_info(r->devices[d])->max_storage_buffer_range / CV_RAY_BYTES;
    return limit < s->band_rays ? limit : s->band_rays;
}

/* Rows per band for a partition `width` columns wide. */
static uint32_t band_rows(const cv_renderer *r, uint32_t d, const cv_render_settings *s, uint32_t width) {
    uint64_t rows = band_rays(r, d, s) / ((uint64_t)width * (1 + s->ao_samples));
    if (rows == 0)
        rows = 1;
    return rows < r->height ? (uint32_t)rows : r->height;
}

/* Any device: for each band of rows of its columns, ray generation, trace,
 * resolve into visibility. */
static cv_result record_trace(cv_renderer *r, uint32_t d, cv_column_range cols, const cv_render_settings *s,
                              uint32_t frame, cv_command_list *l) {
    uint32_t per_pixel = 1 + s->ao_samples;
    uint32_t rows = band_rows(r, d, s, cols.width);
    cv_binding gen[3] = { bind_texture(r->textures[TEX_POSITION]), bind_texture(r->textures[TEX_NORMAL]),
                          bind_buffer(r->rays[d]) };
    cv_binding res_b[3] = { bind_buffer(r->hits[d]), bind_buffer(r->rays[d]),
                            bind_texture(r->textures[TEX_VISIBILITY]) };
    cv_cmd_begin_marker(l, CV_QUEUE_COMPUTE, &(cv_begin_marker_args){ .label = "trace" });
    for (uint32_t y0 = 0; y0 < r->height; y0 += rows) {
        uint32_t h = r->height - y0 < rows ? r->height - y0 : rows;
        uint64_t count = (uint64_t)cols.width * h * per_pixel;
        struct {
            uint32_t x0, width, height, ao_samples;
            float sun[4];
            uint32_t frame;
            float ao_radius, bias;
            uint32_t y0;
        } raygen = { cols.x, cols.width, h, s->ao_samples,
                     { r->data.sun_direction[0], r->data.sun_direction[1], r->data.sun_direction[2],
                       s->sun_cone_degrees * 3.14159265f / 180.0f },
                     s->first_frame + frame, s->ao_radius, r->data.diagonal * 2e-5f, y0 };
        struct { uint32_t x0, width, height, ao_samples, y0, pad[3]; } resolve = { cols.x, cols.width, h,
                                                                                  s->ao_samples, y0, { 0 } };
        cv_cmd_dispatch(l, CV_QUEUE_COMPUTE, &(cv_dispatch_args){
            .pipeline = r->pipelines[PIPE_RAYGEN], .bindings = gen, .bindings_count = 3, .push = &raygen,
            .push_size = sizeof(raygen), .groups_x = groups(cols.width, 8), .groups_y = groups(h, 8),
            .groups_z = 1 });
        cv_cmd_trace_rays(l, CV_QUEUE_COMPUTE, &(cv_trace_rays_args){ .accel = r->accel, .rays = r->rays[d],
                                                                    .hits = r->hits[d], .count = (uint32_t)count,
                                                                    .flags = CV_TRACE_ANY_HIT });
        cv_cmd_dispatch(l, CV_QUEUE_COMPUTE, &(cv_dispatch_args){
            .pipeline = r->pipelines[PIPE_RESOLVE], .bindings = res_b, .bindings_count = 3, .push = &resolve,
            .push_size = sizeof(resolve), .groups_x = groups(cols.width, 8), .groups_y = groups(h, 8),
            .groups_z = 1 });
    }
    return cv_cmd_end_marker(l, CV_QUEUE_COMPUTE, &(cv_end_marker_args){ 0 });
}

static void record_accumulate(cv_renderer *r, uint32_t frame, cv_command_list *l) {
    struct { uint32_t width, height, frame, pad; } push = { r->width, r->height, frame, 0 };
    cv_binding b[2] = { bind_texture(r->textures[TEX_VISIBILITY]), bind_texture(r->textures[TEX_HISTORY]) };
    cv_cmd_dispatch(l, CV_QUEUE_COMPUTE, &(cv_dispatch_args){
        .pipeline = r->pipelines[PIPE_ACCUMULATE], .bindings = b, .bindings_count = 2, .push = &push,
        .push_size = sizeof(push), .groups_x = groups(r->width, 8), .groups_y = groups(r->height, 8), .groups_z = 1 });
}

/* The texture holding the final visibility after `iterations` filter steps. */
static int filtered_texture(uint32_t iterations) {
    return iterations == 0 ? TEX_HISTORY : (iterations % 2 ? TEX_PING : TEX_PONG);
}

/* Variance-guided a-trous iterations (steps 1, 2, 4, ...; render_filter.comp)
 * history -> ping -> pong -> ping ..., then composite. sigma_l: SVGF's 4.
 * Converged: a channel whose variance of the mean is below FILTER_CONVERGED_STD^2
 * (standard error 0.02; a binary shadow ray gets there by 625 frames) is left
 * unfiltered. */
#define FILTER_SIGMA_L 4.0f
#define FILTER_CONVERGED_STD 0.02f
static void record_filter_composite(cv_renderer *r, uint32_t iterations, uint32_t frames, cv_command_list *l) {
    cv_cmd_begin_marker(l, CV_QUEUE_COMPUTE, &(cv_begin_marker_args){ .label = "filter" });
    for (uint32_t i = 0; i < iterations; i++) {
        int src = i == 0 ? TEX_HISTORY : filtered_texture(i), dst = filtered_texture(i + 1);
        struct {
            uint32_t width, height, step, frames;
            float position_sigma, sigma_l, converged_variance;
            uint32_t flags;
        } push = { r->width, r->height, 1u << i, frames, r->data.diagonal * 0.01f, FILTER_SIGMA_L,
                   FILTER_CONVERGED_STD * FILTER_CONVERGED_STD, (i == 0 ? 1u : 0u) | (i + 1 == iterations ? 2u : 0u) };
        cv_binding b[5] = { bind_texture(r->textures[TEX_POSITION]), bind_texture(r->textures[TEX_NORMAL]),
                            bind_texture(r->textures[src]), bind_texture(r->textures[dst]),
                            bind_texture(r->textures[TEX_HISTORY]) };
        cv_cmd_dispatch(l, CV_QUEUE_COMPUTE, &(cv_dispatch_args){
            .pipeline = r->pipelines[PIPE_FILTER], .bindings = b, .bindings_count = 5, .push = &push,
            .push_size = sizeof(push), .groups_x = groups(r->width, 8), .groups_y = groups(r->height, 8),
            .groups_z = 1 });
    }
    cv_cmd_end_marker(l, CV_QUEUE_COMPUTE, &(cv_end_marker_args){ 0 });
    struct {
        float sun[4], sun_color[4], sky[4];
        uint32_t width, height, material_count, light_count;
    } push = { { r->data.sun_direction[0], r->data.sun_direction[1], r->data.sun_direction[2], r->data.sun_irradiance },
               { r->data.sun_color[0], r->data.sun_color[1], r->data.sun_color[2], 0.0f },
               { 0.12f, 0.15f, 0.2f, 0.0f },
               r->width, r->height, r->data.material_count, r->data.light_count };
    cv_binding b[7] = { bind_texture(r->textures[TEX_POSITION]), bind_texture(r->textures[TEX_NORMAL]),
                        bind_texture(r->textures[filtered_texture(iterations)]), bind_buffer(r->materials),
                        bind_texture(r->textures[TEX_RADIANCE]), bind_texture(r->textures[TEX_ALBEDO]),
                        bind_buffer(r->lights) };
    cv_cmd_begin_marker(l, CV_QUEUE_COMPUTE, &(cv_begin_marker_args){ .label = "composite" });
    cv_cmd_dispatch(l, CV_QUEUE_COMPUTE, &(cv_dispatch_args){
        .pipeline = r->pipelines[PIPE_COMPOSITE], .bindings = b, .bindings_count = 7, .push = &push,
        .push_size = sizeof(push), .groups_x = groups(r->width, 8), .groups_y = groups(r->height, 8), .groups_z = 1 });
    cv_cmd_end_marker(l, CV_QUEUE_COMPUTE, &(cv_end_marker_args){ 0 });
}

static double pass_ms(cv_device *dev, uint64_t ticket, const char *label) {
    cv_pass_timing t[16];
    uint32_t n = 0;
    if (cv_device_timings(dev, ticket, t, 16, &n) != CV_OK)
        return -1.0;
    for (uint32_t i = 0; i < n && i < 16; i++)
        if (strcmp(t[i].label, label) == 0)
            return t[i].duration_ms;
    return -1.0;
}

/* A finished trace submission's time: the GPU's measure of the "trace" pass,
 * else the wall time since it was submitted. */
static double trace_ms(cv_device *dev, uint64_t ticket, double submitted_ms) {
    double gpu = pass_ms(dev, ticket, "trace");
    return gpu > 0.0 ? gpu : now_ms() - submitted_ms;
}

cv_render_settings cv_render_settings_resolve(const cv_render_settings *in, const cv_scene *scene) {
    cv_render_settings s = in ? *in : (cv_render_settings){ 0 };
    if (!s.width) s.width = 640;
    if (!s.height) s.height = 360;
    if (!s.frames) s.frames = 4;
    if (!s.ao_samples) s.ao_samples = 4;
    if (s.ao_radius <= 0.0f) {
        float lo[3], hi[3];
        cv_scene_bounds(scene, lo, hi);
        float d = sqrtf((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                        (hi[2] - lo[2]) * (hi[2] - lo[2]));
        s.ao_radius = d * 0.02f;
    }
    if (s.sun_cone_degrees == 0.0f) s.sun_cone_degrees = 1.5f;
    if (s.sun_cone_degrees < 0.0f) s.sun_cone_degrees = 0.0f;
    if (!s.tile) s.tile = 8;
    if (s.filter_iterations == 0) s.filter_iterations = 3;
    if (s.filter_iterations < 0) s.filter_iterations = 0;
    if (!s.band_rays) s.band_rays = CV_RENDER_BAND_RAYS;
    return s;
}

static cv_result read_output(cv_renderer *r, uint32_t iterations, cv_render_output *out) {
    size_t n = (size_t)r->width * r->height * 4;
    memset(out, 0, sizeof(*out));
    out->width = r->width;
    out->height = r->height;
    float **planes[5] = { &out->radiance, &out->albedo, &out->normal, &out->position, &out->visibility };
    for (int i = 0; i < 5; i++)
        if (!(*planes[i] = malloc(n * sizeof(float)))) {
            cv_render_output_free(out);
            return cv_error(CV_ERROR_OUT_OF_MEMORY, "renderer: output planes");
        }
    cv_device *p = r->devices[0];
    cv_rect all = { 0, 0, r->width, r->height };
    cv_result res = cv_device_read_texture(p, r->textures[TEX_RADIANCE], all, out->radiance);
    if (res == CV_OK) res = cv_device_read_texture(p, r->textures[TEX_ALBEDO], all, out->albedo);
    if (res == CV_OK) res = cv_device_read_texture(p, r->textures[TEX_NORMAL], all, out->normal);
    if (res == CV_OK) res = cv_device_read_texture(p, r->textures[TEX_POSITION], all, out->position);
    /* The G-buffer's w packs the geometric normal (render_gbuffer.frag); the output says 1. */
    for (size_t i = 3; res == CV_OK && i < n; i += 4)
        out->position[i] = out->position[i] != 0.0f ? 1.0f : 0.0f;
    if (res == CV_OK)
        res = cv_device_read_texture(p, r->textures[filtered_texture(iterations)], all, out->visibility);
    if (res != CV_OK)
        cv_render_output_free(out);
    return res;
}

void cv_render_output_free(cv_render_output *out) {
    free(out->radiance);
    free(out->albedo);
    free(out->normal);
    free(out->position);
    free(out->visibility);
    memset(out, 0, sizeof(*out));
}

static cv_result begin(cv_renderer *r, uint32_t d, cv_command_list **l) {
    return cv_cmdlist_begin(r->ctx, r->lists[d], l);
}

cv_result cv_renderer_render(cv_renderer *r, const cv_render_settings *settings, cv_render_output *out,
                             cv_render_stats *stats, void (*progress)(uint32_t, uint32_t, void *), void *user) {
    if (!r || !out)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_renderer_render: NULL argument");
    cv_render_settings s = cv_render_settings_resolve(settings, r->scene);
    if (s.width > CV_MAX_TEXTURE_DIM || s.height > CV_MAX_TEXTURE_DIM || s.ao_samples > 32 || s.frames > 4096 ||
        s.filter_iterations > 8 || s.first_frame > (1u << 24))
        return cv_error(CV_ERROR_OUT_OF_RANGE, "renderer: %ux%u, %u AO samples, %u frames, %d filter iterations, "
                        "first frame %u (limits %u, 32, 4096, 8, 2^24)", s.width, s.height, s.ao_samples, s.frames,
                        s.filter_iterations, s.first_frame, CV_MAX_TEXTURE_DIM);
    cv_camera camera = s.camera < cv_scene_camera_count(r->scene) ? *cv_scene_camera(r->scene, s.camera)
                                                                   : cv_scene_framing_camera(r->scene);
    cv_result res = ensure_targets(r, s.width, s.height);
    if (res != CV_OK)
        return res;
    cv_render_stats st = { .device_count = r->count, .frames = s.frames, .upload_ms = r->upload_ms };
    cv_device *primary = r->devices[0];
    cv_command_list *l;
    uint64_t ticket = 0;
    cv_transfer_stats ts;

    /* The G-buffer once (the camera is still), then multicast to the secondaries. */
    res = begin(r, 0, &l);
    if (res == CV_OK) res = record_gbuffer(r, &camera, l);
    if (res == CV_OK) res = run_list(primary, r->lists[0], &ticket);
    if (res == CV_OK) res = cv_device_wait(primary, ticket, UINT64_MAX);
    cv_rect all = { 0, 0, r->width, r->height };
    for (uint32_t d = 1; d < r->count && res == CV_OK; d++) {
        for (int t = TEX_POSITION; t <= TEX_NORMAL && res == CV_OK; t++) {
            res = cv_transfer_texture(primary, r->textures[t], all, r->devices[d], r->textures[t], 0, 0, &ts);
            st.transfer_bytes += ts.bytes;
            st.transfer_ms += ts.total_ms;
        }
    }

    cv_balancer balancer;
    if (res == CV_OK)
        res = cv_balancer_init(&balancer, &(cv_balancer_desc){ .device_count = r->count });
    double frames_start = now_ms();
    uint64_t accumulated[IN_FLIGHT_FRAMES] = { 0 };   /* the primary's accumulate ticket of recent frames */
    for (uint32_t f = 0; f < s.frames && res == CV_OK; f++) {
        cv_partition part;
        res = cv_balancer_split(&balancer, r->width, s.tile, &part);
        uint64_t tickets[CV_RENDER_MAX_DEVICES] = { 0 };
        double submit_ms[CV_RENDER_MAX_DEVICES] = { 0 };
        /* Every device traces its columns; submissions run concurrently. */
        for (uint32_t d = 0; d < r->count && res == CV_OK; d++) {
            cv_column_range cols = part.ranges[d];
            if (cols.width == 0)
                continue;
            uint32_t rows = band_rows(r, d, &s, cols.width);
            res = ensure_ray_buffers(r, d, (uint64_t)cols.width * rows * (1 + s.ao_samples));
            if (res == CV_OK) res = begin(r, d, &l);
            if (res == CV_OK) res = record_trace(r, d, cols, &s, f, l);
            submit_ms[d] = now_ms();
            if (res == CV_OK) res = run_list(r->devices[d], r->lists[d], &tickets[d]);
        }
        /* Isolated to isolated: each secondary's visibility columns go back to the
         * primary as soon as that secondary finishes, while the others still trace. */
        cv_mgpu_copy_plan plan = { 0 };
        if (res == CV_OK)
            res = cv_mgpu_plan_copies(&part, 0, CV_MGPU_ALL_DEVICES, CV_MGPU_ISOLATED_TO_ISOLATED, &plan);
        /* The primary's own trace needs no wait: its accumulate is submitted to
         * the same device, which runs submissions in order, so waiting for the
         * accumulate covers both (one round trip less per frame on a remote
         * primary). Its trace time is read once the accumulate is done. */
        double ms[CV_PARTITION_MAX_DEVICES] = { 0 };
        for (uint32_t d = 1; d < r->count && res == CV_OK; d++) {
            if (!tickets[d])
                continue;
            res = cv_device_wait(r->devices[d], tickets[d], UINT64_MAX);
            ms[d] = trace_ms(r->devices[d], tickets[d], submit_ms[d]);
            for (uint32_t c = 0; c < plan.count && res == CV_OK; c++) {
                const cv_mgpu_copy *cp = &plan.copies[c];
                if (cp->src_device != d)
                    continue;
                cv_rect cols = { cp->columns.x, 0, cp->columns.width, r->height };
                res = cv_transfer_texture(r->devices[d], r->textures[TEX_VISIBILITY], cols,
                                          r->devices[cp->dst_device], r->textures[TEX_VISIBILITY], cols.x, 0, &ts);
                st.transfer_bytes += ts.bytes;
                st.transfer_ms += ts.total_ms;
            }
        }
        if (res == CV_OK) res = cv_cmdlist_begin(r->ctx, r->accumulate, &l);
        if (res == CV_OK) {
            record_accumulate(r, f, l);
            if (f + 1 == s.frames)
                record_filter_composite(r, (uint32_t)s.filter_iterations, s.frames, l);
            res = run_list(primary, r->accumulate, &ticket);
        }
        /* Several devices: the balancer wants this frame's times before it splits
         * the next one, so the frame ends here. One device: frames are pipelined,
         * up to IN_FLIGHT_FRAMES submitted ahead, so a remote device's latency
         * hides behind the work of the frames before (nothing to balance). */
        accumulated[f % IN_FLIGHT_FRAMES] = ticket;
        bool last = f + 1 == s.frames, wait_now = last || r->count > 1;
        if (res == CV_OK && wait_now)
            res = cv_device_wait(primary, ticket, UINT64_MAX);
        else if (res == CV_OK && f + 1 >= IN_FLIGHT_FRAMES)
            res = cv_device_wait(primary, accumulated[(f + 1) % IN_FLIGHT_FRAMES], UINT64_MAX);
        if (res == CV_OK && tickets[0] && wait_now)
            ms[0] = trace_ms(primary, tickets[0], submit_ms[0]);
        for (uint32_t d = 0; d < r->count && res == CV_OK; d++) {
            if (!tickets[d])
                continue;
            uint64_t rays = (uint64_t)part.ranges[d].width * r->height * (1 + s.ao_samples);
            if (wait_now)
                st.devices[d] = (cv_render_device_stats){ .columns = part.ranges[d], .rays = rays, .trace_ms = ms[d],
                                                          .ms_per_column = ms[d] / part.ranges[d].width };
            st.rays_total += rays;
        }
        if (res == CV_OK && r->count > 1)
            res = cv_balancer_update(&balancer, &part, ms);
        if (res == CV_OK && progress)
            progress(f + 1, s.frames, user);
    }
    st.frame_ms = (now_ms() - frames_start) / s.frames;
    if (res == CV_OK)
        res = read_output(r, (uint32_t)s.filter_iterations, out);
    if (res == CV_OK && stats)
        *stats = st;
    return res;
}
