/* One hybrid frame across N devices (see renderer.h), declared as a render
 * graph (corvid/graph.h): passes 'gbuffer' (primary, first frame; every frame
 * for a moving camera), 'trace' (every device, over its column window; in
 * a scene with alpha-masked materials the alpha-mask rule's re-traces run
 * inside it and inside 'reflect', renderer.h), with
 * reflections 'reflect' (every device, its window), 'reflect_reproject'
 * (primary, moving camera only) and 'reflect_filter' (primary), 'reproject'
 * (primary, moving camera only), 'accumulate' (primary), 'filter' and
 * 'composite' (primary, last frame). The graph multicasts the G-buffer (a
 * moving camera's: each device's window of it), copies the secondaries'
 * visibility and reflection windows back, places
 * barriers and balances the columns from the trace times; no pass sees the
 * device count. */
#include "corvid/renderer.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "camera.h"
#include "corvid/blue_noise.h"
#include "corvid/graph.h"
#include "corvid/transfer.h"
#include "frame_observer.h"
#include "output_derive.h"
#include "scene_upload.h"

enum {
    PIPE_GBUFFER,
    PIPE_RAYGEN,
    PIPE_RESOLVE,
    PIPE_ACCUMULATE,
    PIPE_FILTER,
    PIPE_COMPOSITE,
    PIPE_REPROJECT,
    PIPE_REFLECT_RAYGEN,
    PIPE_REFLECT_SHADOW,
    PIPE_REFLECT_SHADE,
    PIPE_REFLECT_FILTER,
    PIPE_REFLECT_REPROJECT,
    PIPE_REFLECT_DENOISE,
    PIPE_ALPHA_CONTINUE, /* scenes with alpha-masked materials only */
    PIPE_COUNT
};
static const char *pipeline_names[PIPE_COUNT] = {
    "render.gbuffer",         "render.raygen",         "render.resolve",        "render.accumulate",
    "render.filter",          "render.composite",      "render.reproject",      "render.reflect_raygen",
    "render.reflect_shadow",  "render.reflect_shade",  "render.reflect_filter", "render.reflect_reproject",
    "render.reflect_denoise", "render.alpha_continue",
};

/* Size-dependent textures; `everywhere` ones are loaded on every device. */
enum {
    TEX_POSITION,
    TEX_NORMAL,
    TEX_VISIBILITY,
    TEX_DEPTH,
    TEX_HISTORY,
    TEX_PING,
    TEX_PONG,
    TEX_RADIANCE,
    TEX_ALBEDO,
    TEX_MOTION,           /* moving camera: render.reproject's motion and history length */
    TEX_REPROJECTED,      /* moving camera: the history brought to this frame's pixels */
    TEX_HISTORY_POSITION, /* moving camera: the G-buffer the history was accumulated on */
    TEX_HISTORY_NORMAL,
    TEX_REFLECT,
    TEX_REFLECT_HISTORY,
    TEX_REFLECT_OWN,
    TEX_REFLECT_OUT,
    TEX_MATERIAL,            /* G-buffer: the material at the pixel (textures evaluated): base color rgb, roughness */
    TEX_EMISSION,            /* G-buffer: emission rgb, metalness */
    TEX_REFLECT_STATE,       /* moving camera: render.reflect_filter's per-pixel history state */
    TEX_REFLECT_REPROJECTED, /* moving camera: the reflection histories and state brought to */
    TEX_REFLECT_OWN_REPROJECTED, /* this frame's pixels (render.reflect_reproject) */
    TEX_REFLECT_STATE_REPROJECTED,
    TEX_REFLECT_DENOISE_PING, /* render.reflect_denoise's iterations (the last one is the reflection shown) */
    TEX_REFLECT_DENOISE_PONG,
    TEX_COUNT
};
static const struct {
    cv_format format;
    uint32_t usage;
    bool everywhere;
    const char *label;
} texture_info[TEX_COUNT] = {
    [TEX_POSITION] = { CV_FORMAT_RGBA32F, CV_TEXTURE_USAGE_COLOR_TARGET | CV_TEXTURE_USAGE_STORAGE, true,
                       "gbuffer position" },
    [TEX_NORMAL] = { CV_FORMAT_RGBA32F, CV_TEXTURE_USAGE_COLOR_TARGET | CV_TEXTURE_USAGE_STORAGE, true,
                     "gbuffer normal" },
    /* SHARED: with zero-copy gathers (graph.h) every device of one adapter
     * traces its window straight into the primary's texels. */
    [TEX_VISIBILITY] = { CV_FORMAT_R32_UINT, CV_TEXTURE_USAGE_STORAGE | CV_TEXTURE_USAGE_SHARED, true, "visibility" },
    [TEX_DEPTH] = { CV_FORMAT_D32F, CV_TEXTURE_USAGE_DEPTH_TARGET, false, "depth" },
    [TEX_HISTORY] = { CV_FORMAT_RGBA32F, CV_TEXTURE_USAGE_STORAGE, false, "visibility history" },
    [TEX_PING] = { CV_FORMAT_RGBA32F, CV_TEXTURE_USAGE_STORAGE, false, "filter ping" },
    [TEX_PONG] = { CV_FORMAT_RGBA32F, CV_TEXTURE_USAGE_STORAGE, false, "filter pong" },
    [TEX_RADIANCE] = { CV_FORMAT_RGBA32F, CV_TEXTURE_USAGE_STORAGE, false, "radiance" },
    [TEX_ALBEDO] = { CV_FORMAT_RGBA32F, CV_TEXTURE_USAGE_STORAGE, false, "albedo" },
    [TEX_MOTION] = { CV_FORMAT_RGBA32F, CV_TEXTURE_USAGE_STORAGE, false, "motion" },
    [TEX_REPROJECTED] = { CV_FORMAT_RGBA32F, CV_TEXTURE_USAGE_STORAGE, false, "reprojected history" },
    [TEX_HISTORY_POSITION] = { CV_FORMAT_RGBA32F, CV_TEXTURE_USAGE_STORAGE, false, "history position" },
    [TEX_HISTORY_NORMAL] = { CV_FORMAT_RGBA32F, CV_TEXTURE_USAGE_STORAGE, false, "history normal" },
    /* RGBA16F: the largest per-frame copy back to the primary (8 bytes a
     * pixel, not 16); a = the inverse hit distance (render_reflect_shade.comp). */
    [TEX_REFLECT] = { CV_FORMAT_RGBA16F, CV_TEXTURE_USAGE_STORAGE | CV_TEXTURE_USAGE_SHARED, true,
                      "reflection samples" },
    [TEX_REFLECT_HISTORY] = { CV_FORMAT_RGBA32F, CV_TEXTURE_USAGE_STORAGE, false, "reflection history" },
    [TEX_REFLECT_OWN] = { CV_FORMAT_RGBA32F, CV_TEXTURE_USAGE_STORAGE, false, "reflection own history" },
    [TEX_REFLECT_OUT] = { CV_FORMAT_RGBA32F, CV_TEXTURE_USAGE_STORAGE, false, "reflection" },
    /* RGBA32F, not 16F: an untextured material's factors reach the composite
     * unrounded, so its image is the one the material table gave before
     * (16F would round 0.8 to 0.7998). */
    [TEX_MATERIAL] = { CV_FORMAT_RGBA32F, CV_TEXTURE_USAGE_COLOR_TARGET | CV_TEXTURE_USAGE_STORAGE, true,
                       "gbuffer material" },
    [TEX_EMISSION] = { CV_FORMAT_RGBA32F, CV_TEXTURE_USAGE_COLOR_TARGET | CV_TEXTURE_USAGE_STORAGE, false,
                       "gbuffer emission" },
    [TEX_REFLECT_STATE] = { CV_FORMAT_RGBA32F, CV_TEXTURE_USAGE_STORAGE, false, "reflection state" },
    [TEX_REFLECT_REPROJECTED] = { CV_FORMAT_RGBA32F, CV_TEXTURE_USAGE_STORAGE, false, "reflection reprojected" },
    [TEX_REFLECT_OWN_REPROJECTED] = { CV_FORMAT_RGBA32F, CV_TEXTURE_USAGE_STORAGE, false,
                                      "reflection own reprojected" },
    [TEX_REFLECT_STATE_REPROJECTED] = { CV_FORMAT_RGBA32F, CV_TEXTURE_USAGE_STORAGE, false,
                                        "reflection state reprojected" },
    [TEX_REFLECT_DENOISE_PING] = { CV_FORMAT_RGBA32F, CV_TEXTURE_USAGE_STORAGE, false, "reflection denoise ping" },
    [TEX_REFLECT_DENOISE_PONG] = { CV_FORMAT_RGBA32F, CV_TEXTURE_USAGE_STORAGE, false, "reflection denoise pong" },
};

/* Resources the frame graph names: the textures above (imported: the
 * renderer keeps them from call to call), the scene buffers (imported) and
 * each device's ray and hit buffers (transients, one band of its window). */
enum {
    BUF_VERTICES,
    BUF_MATERIALS,
    BUF_LIGHTS,
    BUF_RAYS,
    BUF_HITS,
    BUF_INSTANCES,    /* instance -> its first triangle in the vertex list (reflection hits) */
    BUF_REFLECT_RAYS, /* transients of pass 'reflect', one band each: reflection rays, */
    BUF_REFLECT_HITS, /* their closest hits, */
    BUF_SHADOW_RAYS,  /* shadow rays from those hits */
    BUF_SHADOW_HITS,  /* and their any hits */
    BUF_UVS,          /* per flat vertex uv */
    BUF_IMAGE_TABLE,  /* texture images: where each lies in the pool (scene_upload.h) */
    BUF_IMAGE_POOL,   /* and their texels */
    BUF_BLUE_NOISE,   /* the blue-noise rank mask (corvid/blue_noise.h): render.raygen, the reflection samples */
    /* Masked scenes: the hits of the alpha-mask re-traces of passes 'trace' and 'reflect' (renderer.h). */
    BUF_ALPHA_HITS,
    BUF_REFLECT_ALPHA_HITS,
    BUF_COUNT
};

struct cv_renderer {
    cv_context *ctx;
    cv_device *devices[CV_MAX_DEVICES];
    uint32_t count;
    const cv_scene *scene;
    const cv_bvh *bvh; /* for devices added later (cv_renderer_add_device) */
    render_scene_data data;
    cv_buffer vertices, materials, lights, instances;
    cv_buffer uvs, image_table, image_pool; /* textured materials (scene_upload.h) */
    /* The blue-noise mask as render.raygen reads it: ranks[y * 64 + x], two a
     * 32-bit word (the even x in the low half: the bytes of a little-endian
     * uint16 array). A buffer, not a constant in the shader: lavapipe took
     * 1.4 s to make a pipeline with a 2048-word constant array. */
    uint16_t blue_noise_ranks[CV_BLUE_NOISE_CELLS];
    cv_buffer blue_noise;
    cv_accel accel;
    bool alpha_mask; /* some material is alpha-masked: secondary rays follow the alpha-mask rule */
    cv_pipeline pipelines[PIPE_COUNT];
    uint32_t width, height;  /* of the textures below; 0 = none yet */
    uint32_t reflect_layers; /* images in TEX_REFLECT, one a reflection sample (reflection_samples) */
    cv_texture textures[TEX_COUNT];
    double upload_ms;
    /* The frame as a render graph (rebuilt when the size, the filter
     * iterations or the ray buffers' size change). */
    cv_graph *graph;
    uint32_t graph_iterations;
    bool graph_moving;     /* built for a moving camera: G-buffer every frame, reprojection */
    bool graph_prebaked;   /* the graph was baked once before a render's clock (its transfer rings exist) */
    uint32_t graph_frames; /* frames of this render call: the filter's history length */
    uint64_t graph_rays;   /* rays the ray and hit buffers hold */
    cv_graph_resource tex[TEX_COUNT], buf[BUF_COUNT];
    cv_graph_pass gbuffer_pass, filter_pass, composite_pass, reproject_pass, reflect_denoise_pass;
    /* What the passes record this frame (set before each bake, read by the
     * record callbacks on the graph's worker threads). */
    cv_render_settings settings;
    cv_camera camera, previous_camera; /* this frame's and the previous frame's */
    float sun_direction[3];            /* unit, the way the light travels: the scene's or settings.sun_toward */
    uint32_t frame;
    uint64_t band_limit; /* most rays per band on every device */

    /* Reflections in the graph (built again when these change). */
    uint32_t graph_generation;   /* counts graphs built: a frame loop sees a device added (or dropped) */
    bool graph_reflect;          /* the graph has passes 'reflect' and 'reflect_filter' */
    uint64_t graph_reflect_rays; /* rays each of the reflect pass's buffers holds */
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
    if (!devices || !scene || !bvh || !out || device_count == 0 || device_count > CV_MAX_DEVICES)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "renderer: need 1..%u devices, a scene and its BVH",
                        CV_MAX_DEVICES);
    cv_renderer *r = calloc(1, sizeof(*r));
    if (!r)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "renderer");
    r->ctx = cv_device_context(devices[0]);
    r->count = device_count;
    r->scene = scene;
    r->bvh = bvh;
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
            res = cv_error(CV_ERROR_LIMIT_EXCEEDED,
                           "renderer: %llu bytes of vertices exceed device '%s''s storage "
                           "buffer range of %llu bytes; use a smaller scene",
                           (unsigned long long)vertex_bytes, cv_device_label(devices[d]),
                           (unsigned long long)cv_device_get_info(devices[d])->max_storage_buffer_range);
    if (res == CV_OK)
        res = upload_buffer(r, r->data.vertices, vertex_bytes, "scene vertices", &r->vertices);
    if (res == CV_OK)
        res = upload_buffer(r, r->data.materials, r->data.material_count * sizeof(render_material), "materials",
                            &r->materials);
    if (res == CV_OK)
        res = upload_buffer(r, r->data.lights, (r->data.light_count + 1) * sizeof(render_light), "point lights",
                            &r->lights);
    uint64_t pool_bytes = r->data.image_texels * sizeof(uint32_t);
    for (uint32_t d = 0; d < device_count && res == CV_OK; d++)
        if (pool_bytes > cv_device_get_info(devices[d])->max_storage_buffer_range)
            res = cv_error(CV_ERROR_LIMIT_EXCEEDED,
                           "renderer: %llu bytes of texture images exceed device '%s''s storage buffer range of "
                           "%llu bytes",
                           (unsigned long long)pool_bytes, cv_device_label(devices[d]),
                           (unsigned long long)cv_device_get_info(devices[d])->max_storage_buffer_range);
    if (res == CV_OK)
        res = upload_buffer(r, r->data.uvs, r->data.vertex_count * 2 * sizeof(float), "scene uvs", &r->uvs);
    if (res == CV_OK)
        res = upload_buffer(r, r->data.image_table, r->data.image_table_bytes, "image table", &r->image_table);
    if (res == CV_OK)
        res = upload_buffer(r, r->data.image_pool, pool_bytes, "image pool", &r->image_pool);
    if (res == CV_OK)
        res = upload_buffer(r, r->data.instance_first, (r->data.instance_count + 1) * sizeof(uint32_t),
                            "instance first triangles", &r->instances);
    if (res == CV_OK) {
        cv_blue_noise_ranks(r->blue_noise_ranks);
        res = upload_buffer(r, r->blue_noise_ranks, sizeof(r->blue_noise_ranks), "blue noise", &r->blue_noise);
    }
    /* Immutable scene data goes to every device once (the multicast rule). */
    if (res == CV_OK)
        res = cv_accel_create(r->ctx,
                              &(cv_accel_desc){ .triangle_count = bvh->tri_count,
                                                .node_count = bvh->node2_count,
                                                .label = "scene" },
                              &r->accel);
    if (res == CV_OK)
        res = load_everywhere(r, cv_any(r->accel));
    for (uint32_t d = 0; d < device_count && res == CV_OK; d++)
        res = cv_device_write_accel(devices[d], r->accel, bvh->nodes2, bvh->tris);
    r->alpha_mask = render_scene_alpha_masked(&r->data);
    for (int p = 0; p < PIPE_COUNT && res == CV_OK; p++) {
        if (p == PIPE_ALPHA_CONTINUE && !r->alpha_mask)
            continue;
        res = cv_pipeline_create(r->ctx, pipeline_names[p], &r->pipelines[p]);
        if (res == CV_OK)
            res = load_everywhere(r, cv_any(r->pipelines[p]));
    }
    uint64_t limit = UINT64_MAX;
    for (uint32_t d = 0; d < device_count; d++)
        if (cv_device_get_info(devices[d])->max_storage_buffer_range < limit)
            limit = cv_device_get_info(devices[d])->max_storage_buffer_range;
    r->band_limit = limit / CV_RAY_BYTES;
    r->upload_ms = now_ms() - t0;
    if (res != CV_OK) {
        cv_renderer_destroy(r);
        return res;
    }
    *out = r;
    return CV_OK;
}

/* The scene's handles every device holds: its buffers and the accel. */
enum { SCENE_HANDLES = 9 };
static void scene_handles(const cv_renderer *r, cv_handle out[SCENE_HANDLES]) {
    const cv_handle all[SCENE_HANDLES] = { cv_any(r->vertices),    cv_any(r->materials),  cv_any(r->lights),
                                           cv_any(r->accel),       cv_any(r->instances),  cv_any(r->uvs),
                                           cv_any(r->image_table), cv_any(r->image_pool), cv_any(r->blue_noise) };
    memcpy(out, all, sizeof(all));
}

static void destroy_handle(cv_renderer *r, uint64_t id) {
    if (id)
        cv_destroy(r->ctx, (cv_handle){ id });
}

static void destroy_graph(cv_renderer *r) {
    cv_graph_destroy(r->graph);
    r->graph = NULL;
    r->graph_prebaked = false;
}

static void destroy_targets(cv_renderer *r) {
    destroy_graph(r);
    for (int t = 0; t < TEX_COUNT; t++)
        destroy_handle(r, r->textures[t].id);
    memset(r->textures, 0, sizeof(r->textures));
    r->width = r->height = r->reflect_layers = 0;
}

void cv_renderer_destroy(cv_renderer *r) {
    if (!r)
        return;
    for (uint32_t d = 0; d < r->count; d++)
        cv_device_wait_idle(r->devices[d]);
    destroy_targets(r);
    cv_handle scene[SCENE_HANDLES];
    scene_handles(r, scene);
    for (int i = 0; i < SCENE_HANDLES; i++)
        destroy_handle(r, scene[i].id);
    for (int p = 0; p < PIPE_COUNT; p++)
        destroy_handle(r, r->pipelines[p].id);
    render_scene_data_free(&r->data);
    free(r);
}

/* The textures for width x height images; the reflection samples' holds
 * `layers` images, one above the other (render.reflect_shade). */
static cv_result ensure_targets(cv_renderer *r, uint32_t width, uint32_t height, uint32_t layers) {
    if (r->width == width && r->height == height && r->reflect_layers == layers)
        return CV_OK;
    destroy_targets(r);
    cv_result res = CV_OK;
    for (int t = 0; t < TEX_COUNT && res == CV_OK; t++) {
        cv_texture_desc desc = { .width = width,
                                 .height = t == TEX_REFLECT ? height * layers : height,
                                 .format = texture_info[t].format,
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
        r->reflect_layers = layers;
    }
    return res;
}

static cv_binding bind_texture(cv_texture t) { return (cv_binding){ .resource = cv_any(t) }; }
static cv_binding bind_buffer(cv_buffer b) { return (cv_binding){ .resource = cv_any(b) }; }
static uint32_t groups(uint32_t n, uint32_t size) { return (n + size - 1) / size; }

/* One dispatch of 8x8 groups over width x height pixels (a band of a
 * partition's columns: the trace and reflect passes' per-ray shaders). */
static void dispatch_pixels(const cv_renderer *r, cv_command_list *l, cv_queue_type queue, int pipeline,
                            const cv_binding *b, uint32_t count, const void *push, uint32_t push_size, uint32_t width,
                            uint32_t height) {
    cv_cmd_dispatch(l, queue,
                    &(cv_dispatch_args){ .pipeline = r->pipelines[pipeline],
                                         .bindings = b,
                                         .bindings_count = count,
                                         .push = push,
                                         .push_size = push_size,
                                         .groups_x = groups(width, 8),
                                         .groups_y = groups(height, 8),
                                         .groups_z = 1 });
}

/* The same over the whole image: the primary's per-pixel passes. */
static void dispatch_image(const cv_renderer *r, cv_command_list *l, cv_queue_type queue, int pipeline,
                           const cv_binding *b, uint32_t count, const void *push, uint32_t push_size) {
    dispatch_pixels(r, l, queue, pipeline, b, count, push, push_size, r->width, r->height);
}

/* The view-projection of `camera` for the G-buffer (and the reprojection). */
static void view_proj(const cv_renderer *r, const cv_camera *camera, float out[16], float *far_plane) {
    float near_plane = r->data.diagonal * 1e-4f;
    *far_plane = r->data.diagonal * 4.0f;
    render_camera_view_proj(camera, (float)r->width / (float)r->height, near_plane, *far_plane, out);
}

/* Pass 'gbuffer' (primary; the first frame, every frame for a moving camera):
 * position and normal by rasterization, then the material at each pixel
 * (base color, roughness, emission, metalness, textures evaluated) by a
 * second draw of the same geometry into the material and emission targets:
 * the registry's render passes have two color targets. Both draws compute
 * the same depth and discard the same fragments (render_gbuffer.frag), so
 * each pixel's material is that of the surface in the position target. */
static void record_gbuffer(const cv_graph_pass_context *pc, cv_command_list *l, void *user) {
    cv_renderer *r = user;
    const cv_camera *camera = &r->camera;
    struct {
        float view_proj[16];
        float camera[4];
        uint32_t mode[4];
    } push = { .mode = { 0 } };
    float far_plane;
    view_proj(r, camera, push.view_proj, &far_plane);
    memcpy(push.camera, camera->position, sizeof(camera->position));
    push.camera[3] = 1.0f / far_plane; /* render.gbuffer writes depth = view depth / far */
    cv_binding b[5] = { bind_buffer(cv_graph_buffer(pc, r->buf[BUF_VERTICES])),
                        bind_buffer(cv_graph_buffer(pc, r->buf[BUF_UVS])),
                        bind_buffer(cv_graph_buffer(pc, r->buf[BUF_MATERIALS])),
                        bind_buffer(cv_graph_buffer(pc, r->buf[BUF_IMAGE_TABLE])),
                        bind_buffer(cv_graph_buffer(pc, r->buf[BUF_IMAGE_POOL])) };
    const int targets[2][2] = { { TEX_POSITION, TEX_NORMAL }, { TEX_MATERIAL, TEX_EMISSION } };
    for (uint32_t mode = 0; mode < 2; mode++) {
        push.mode[0] = mode;
        cv_cmd_begin_render_pass(l, pc->queue,
                                 &(cv_begin_render_pass_args){
                                     .color0 = cv_graph_texture(pc, r->tex[targets[mode][0]]),
                                     .color1 = cv_graph_texture(pc, r->tex[targets[mode][1]]),
                                     .depth = cv_graph_texture(pc, r->tex[TEX_DEPTH]),
                                     .clear = 1,
                                     .clear_depth = 1.0f });
        cv_cmd_draw(l, pc->queue,
                    &(cv_draw_args){ .pipeline = r->pipelines[PIPE_GBUFFER],
                                     .bindings = b,
                                     .bindings_count = 5,
                                     .push = &push,
                                     .push_size = sizeof(push),
                                     .vertex_count = (uint32_t)r->data.vertex_count,
                                     .instance_count = 1 });
        cv_cmd_end_render_pass(l, pc->queue, &(cv_end_render_pass_args){ 0 });
    }
}

/* Rays traced per band: the ray and hit buffers hold one band, so a window of
 * any size fits every device's storage buffer range. */
static uint64_t band_rays(const cv_renderer *r, const cv_render_settings *s) {
    return r->band_limit < s->band_rays ? r->band_limit : s->band_rays;
}

/* Rows per band for a window `width` columns wide. */
static uint32_t band_rows(const cv_renderer *r, const cv_render_settings *s, uint32_t width) {
    uint64_t rows = band_rays(r, s) / ((uint64_t)width * cv_render_rays_per_pixel(s));
    if (rows == 0)
        rows = 1;
    return rows < r->height ? (uint32_t)rows : r->height;
}

/* Rays the ray and hit buffers must hold for a band of any window of the
 * image: a band of a narrower window is never larger (at least a row). */
static uint64_t band_capacity(const cv_renderer *r, const cv_render_settings *s) {
    uint64_t per_pixel = cv_render_rays_per_pixel(s), row = (uint64_t)r->width * per_pixel;
    uint64_t image = row * r->height, band = band_rays(r, s);
    return row > band ? row : band < image ? band : image;
}

/* Re-traces of the alpha-mask rule (renderer.h) after a trace with or without CV_TRACE_ANY_HIT. */
static uint32_t alpha_retraces(bool any_hit) { return CV_RENDER_ALPHA_LAYERS + (any_hit ? 1u : 0u); }

/* The alpha-mask rule for the `count` rays of a band just traced into `hits`
 * (any_hit: with CV_TRACE_ANY_HIT): render.alpha_continue (round 0 on `hits`),
 * then alpha_retraces() times a closest-hit re-trace into `scratch` and the
 * next round; the hits that stand end in `hits`, and the rays' tmin is spent
 * (render_alpha_continue.comp). Recorded only for a masked scene. */
static void record_alpha_rounds(const cv_renderer *r, const cv_graph_pass_context *pc, cv_command_list *l,
                                cv_buffer rays, cv_buffer hits, cv_buffer scratch, uint32_t count, bool any_hit) {
    cv_binding b[9] = { bind_buffer(rays),
                        bind_buffer(hits),
                        bind_buffer(scratch),
                        bind_buffer(cv_graph_buffer(pc, r->buf[BUF_VERTICES])),
                        bind_buffer(cv_graph_buffer(pc, r->buf[BUF_INSTANCES])),
                        bind_buffer(cv_graph_buffer(pc, r->buf[BUF_UVS])),
                        bind_buffer(cv_graph_buffer(pc, r->buf[BUF_MATERIALS])),
                        bind_buffer(cv_graph_buffer(pc, r->buf[BUF_IMAGE_TABLE])),
                        bind_buffer(cv_graph_buffer(pc, r->buf[BUF_IMAGE_POOL])) };
    uint32_t g = groups(count, 64), gx = g < 32768 ? g : 32768, rounds = alpha_retraces(any_hit);
    for (uint32_t k = 0; k <= rounds; k++) {
        struct {
            uint32_t count, round, any_hit;
            float bias;
            uint32_t material_count, layers, pad[2];
        } push = { count,
                   k,
                   any_hit ? 1u : 0u,
                   render_ray_offset(&r->data),
                   r->data.material_count,
                   CV_RENDER_ALPHA_LAYERS,
                   { 0, 0 } };
        cv_cmd_dispatch(l, pc->queue,
                        &(cv_dispatch_args){ .pipeline = r->pipelines[PIPE_ALPHA_CONTINUE],
                                             .bindings = b,
                                             .bindings_count = 9,
                                             .push = &push,
                                             .push_size = sizeof(push),
                                             .groups_x = gx,
                                             .groups_y = groups(g, gx),
                                             .groups_z = 1 });
        if (k < rounds)
            cv_cmd_trace_rays(l, pc->queue,
                              &(cv_trace_rays_args){
                                  .accel = r->accel, .rays = rays, .hits = scratch, .count = count });
    }
}

/* Pass 'trace' (every device, its window): for each band of rows of the
 * window, ray generation, trace (the alpha-mask rule's rounds in a masked
 * scene), resolve into visibility. */
static void record_trace(const cv_graph_pass_context *pc, cv_command_list *l, void *user) {
    cv_renderer *r = user;
    const cv_render_settings *s = &r->settings;
    cv_column_range cols = { pc->x, pc->width };
    cv_buffer rays = cv_graph_buffer(pc, r->buf[BUF_RAYS]), hits = cv_graph_buffer(pc, r->buf[BUF_HITS]);
    cv_texture visibility = cv_graph_texture(pc, r->tex[TEX_VISIBILITY]);
    uint32_t per_pixel = cv_render_rays_per_pixel(s);
    uint32_t rows = band_rows(r, s, cols.width);
    cv_binding gen[4] = { bind_texture(cv_graph_texture(pc, r->tex[TEX_POSITION])),
                          bind_texture(cv_graph_texture(pc, r->tex[TEX_NORMAL])), bind_buffer(rays),
                          bind_buffer(cv_graph_buffer(pc, r->buf[BUF_BLUE_NOISE])) };
    cv_binding res_b[3] = { bind_buffer(hits), bind_buffer(rays), bind_texture(visibility) };
    for (uint32_t y0 = 0; y0 < r->height; y0 += rows) {
        uint32_t h = r->height - y0 < rows ? r->height - y0 : rows;
        uint64_t count = (uint64_t)cols.width * h * per_pixel;
        struct {
            uint32_t x0, width, height, ao_samples;
            float sun[4];
            uint32_t frame;
            float ao_radius, bias;
            uint32_t y0, shadow_samples;
        } raygen = { cols.x,
                     cols.width,
                     h,
                     s->ao_samples,
                     { r->sun_direction[0], r->sun_direction[1], r->sun_direction[2],
                       s->sun_cone_degrees * 3.14159265f / 180.0f },
                     s->first_frame + r->frame,
                     s->ao_radius,
                     render_ray_offset(&r->data),
                     y0,
                     s->shadow_samples };
        struct {
            uint32_t x0, width, height, ao_samples, y0, shadow_samples, pad[2];
        } resolve = { cols.x, cols.width, h, s->ao_samples, y0, s->shadow_samples, { 0 } };
        dispatch_pixels(r, l, pc->queue, PIPE_RAYGEN, gen, 4, &raygen, sizeof(raygen), cols.width, h);
        cv_cmd_trace_rays(
            l, pc->queue,
            &(cv_trace_rays_args){
                .accel = r->accel, .rays = rays, .hits = hits, .count = (uint32_t)count, .flags = CV_TRACE_ANY_HIT });
        if (r->alpha_mask)
            record_alpha_rounds(r, pc, l, rays, hits, cv_graph_buffer(pc, r->buf[BUF_ALPHA_HITS]), (uint32_t)count,
                                true);
        dispatch_pixels(r, l, pc->queue, PIPE_RESOLVE, res_b, 3, &resolve, sizeof(resolve), cols.width, h);
    }
}

/* Moving camera: how far a previous frame's surface may lie from this
 * frame's plane and still be the same surface, per unit of distance from the
 * eye (render_reproject.comp); and the longest history kept. The error of the
 * reprojected history grows with its length (room 160x90, 16 frames of an
 * orbit of 0.05, 0.3 and 1 degree a frame, unfiltered, against 1024 / 4096
 * samples at the last frame: shadow RMSE 0.0101, 0.0230, 0.0256 with at most
 * 4 frames; 0.0119, 0.0289, 0.0335 with 8; 0.0148, 0.0337, 0.0384 with 32;
 * AO alike but at 0.05 degrees, docs/renderer-quality.md), so 4. */
#define REPROJECT_PLANE_TOLERANCE 0.01f
#define REPROJECT_MAX_HISTORY 4.0f

/* Pass 'reproject' (primary, moving camera): motion vectors and the history
 * brought to this frame's pixels (render_reproject.comp). */
static void record_reproject(const cv_graph_pass_context *pc, cv_command_list *l, void *user) {
    cv_renderer *r = user;
    struct {
        float prev_view_proj[16];
        float eye[4];
        uint32_t width, height, has_history;
        float max_history;
    } push = { .eye = { r->camera.position[0], r->camera.position[1], r->camera.position[2],
                        REPROJECT_PLANE_TOLERANCE },
               .width = r->width,
               .height = r->height,
               .has_history = r->frame > 0,
               .max_history = REPROJECT_MAX_HISTORY };
    float far_plane;
    view_proj(r, &r->previous_camera, push.prev_view_proj, &far_plane);
    int tex[7] = { TEX_POSITION, TEX_NORMAL, TEX_HISTORY_POSITION, TEX_HISTORY_NORMAL,
                   TEX_HISTORY,  TEX_MOTION, TEX_REPROJECTED };
    cv_binding b[7];
    for (int i = 0; i < 7; i++)
        b[i] = bind_texture(cv_graph_texture(pc, r->tex[tex[i]]));
    dispatch_image(r, l, pc->queue, PIPE_REPROJECT, b, 7, &push, sizeof(push));
}

/* Pass 'accumulate' (primary): this frame's visibility into the running mean;
 * for a moving camera, into the reprojected history (render_accumulate.comp).
 * A still camera's pass reads and writes only the visibility and the history:
 * the slots it does not use get the history again. */
static void record_accumulate(const cv_graph_pass_context *pc, cv_command_list *l, void *user) {
    cv_renderer *r = user;
    bool moving = r->graph_moving;
    struct {
        uint32_t width, height, frame, flags;
    } push = { r->width, r->height, r->frame, moving ? 1u : 0u };
    int tex[8] = { TEX_VISIBILITY, TEX_HISTORY, TEX_MOTION,           TEX_REPROJECTED,
                   TEX_POSITION,   TEX_NORMAL,  TEX_HISTORY_POSITION, TEX_HISTORY_NORMAL };
    cv_binding b[8];
    for (int i = 0; i < 8; i++)
        b[i] = bind_texture(cv_graph_texture(pc, r->tex[moving || i < 2 ? tex[i] : TEX_HISTORY]));
    dispatch_image(r, l, pc->queue, PIPE_ACCUMULATE, b, 8, &push, sizeof(push));
}

/* Reflections (seed 000: reflections from the G-buffer, ray-traced shadows at
 * their hits, reconstruction, temporal accumulation). */

/* Rays of one band of pass 'reflect' (one per pixel): each of its four
 * buffers holds a band of any window (at least a row; half the trace pass's
 * band, as two buffers of rays are live at once). */
static uint64_t reflect_capacity(const cv_renderer *r, const cv_render_settings *s) {
    uint64_t band = band_rays(r, s) / 2, image = (uint64_t)r->width * r->height;
    if (band < r->width)
        band = r->width;
    return band < image ? band : image;
}

/* Pixels whose reflection ray sample index `frame` traces: all, or at half
 * resolution those of the frame's slot of each 2x2 quad (render.reflect_raygen:
 * slot (x & 1) + 2 (y & 1) == frame % 4). */
static uint64_t reflect_traced_pixels(const cv_renderer *r, const cv_render_settings *s, uint32_t frame) {
    if (s->reflection_scale >= 1.0f)
        return (uint64_t)r->width * r->height;
    uint32_t x0 = frame % 4 & 1, y0 = frame % 4 >> 1;
    return (uint64_t)((r->width - x0 + 1) / 2) * ((r->height - y0 + 1) / 2);
}

/* Pass 'reflect' (every device, its window): for each band of rows and each
 * of the reflection_samples samples, one GGX reflection ray per pixel
 * (render.reflect_raygen), closest hit, a shadow ray from each hit toward the
 * sun (render.reflect_shadow), any hit, and the radiance each reflection ray
 * brings back (render.reflect_shade) into the window of the sample's image
 * of the reflection samples. */
static void record_reflect(const cv_graph_pass_context *pc, cv_command_list *l, void *user) {
    cv_renderer *r = user;
    const cv_render_settings *s = &r->settings;
    cv_column_range cols = { pc->x, pc->width };
    cv_buffer rays = cv_graph_buffer(pc, r->buf[BUF_REFLECT_RAYS]),
              hits = cv_graph_buffer(pc, r->buf[BUF_REFLECT_HITS]),
              shadow_rays = cv_graph_buffer(pc, r->buf[BUF_SHADOW_RAYS]),
              shadow_hits = cv_graph_buffer(pc, r->buf[BUF_SHADOW_HITS]);
    cv_binding positions = bind_texture(cv_graph_texture(pc, r->tex[TEX_POSITION])),
               normals = bind_texture(cv_graph_texture(pc, r->tex[TEX_NORMAL])),
               vertices = bind_buffer(cv_graph_buffer(pc, r->buf[BUF_VERTICES])),
               materials = bind_buffer(cv_graph_buffer(pc, r->buf[BUF_MATERIALS])),
               instances = bind_buffer(cv_graph_buffer(pc, r->buf[BUF_INSTANCES]));
    uint64_t rows64 = reflect_capacity(r, s) / cols.width;
    uint32_t rows = rows64 == 0 ? 1 : rows64 < r->height ? (uint32_t)rows64 : r->height;
    float bias = render_ray_offset(&r->data);
    for (uint32_t y0 = 0; y0 < r->height; y0 += rows) {
        uint32_t h = r->height - y0 < rows ? r->height - y0 : rows, count = cols.width * h;
        struct {
            uint32_t x0, width, height, y0;
            float camera[4];
            uint32_t frame, material_count, quarter, samples, sample, pad[3];
        } gen = { cols.x,
                  cols.width,
                  h,
                  y0,
                  { r->camera.position[0], r->camera.position[1], r->camera.position[2], bias },
                  s->first_frame + r->frame,
                  r->data.material_count,
                  s->reflection_scale < 1.0f ? 1u : 0u,
                  s->reflection_samples,
                  0,
                  { 0, 0, 0 } };
        struct {
            uint32_t width, height;
            float bias;
            uint32_t pad;
            float sun[4];
        } shadow = { cols.width,
                     h,
                     bias,
                     0,
                     { r->data.sun_direction[0], r->data.sun_direction[1], r->data.sun_direction[2], 0.0f } };
        struct {
            uint32_t x0, width, height, y0;
            float sun[4], sun_color[4], sky[4];
            uint32_t material_count, row_offset, pad[2];
        } shade = { cols.x,
                    cols.width,
                    h,
                    y0,
                    { r->data.sun_direction[0], r->data.sun_direction[1], r->data.sun_direction[2],
                      r->data.sun_irradiance },
                    { r->data.sun_color[0], r->data.sun_color[1], r->data.sun_color[2], 0.0f },
                    { 0.12f, 0.15f, 0.2f, 0.0f },
                    r->data.material_count,
                    0,
                    { 0, 0 } };
        cv_binding gen_b[5] = { positions, normals, bind_texture(cv_graph_texture(pc, r->tex[TEX_MATERIAL])),
                                bind_buffer(rays), bind_buffer(cv_graph_buffer(pc, r->buf[BUF_BLUE_NOISE])) };
        cv_binding shadow_b[5] = { bind_buffer(rays), bind_buffer(hits), vertices, instances,
                                   bind_buffer(shadow_rays) };
        cv_binding shade_b[12] = { positions,
                                   bind_buffer(rays),
                                   bind_buffer(hits),
                                   bind_buffer(shadow_rays),
                                   bind_buffer(shadow_hits),
                                   vertices,
                                   instances,
                                   materials,
                                   bind_texture(cv_graph_texture(pc, r->tex[TEX_REFLECT])),
                                   bind_buffer(cv_graph_buffer(pc, r->buf[BUF_UVS])),
                                   bind_buffer(cv_graph_buffer(pc, r->buf[BUF_IMAGE_TABLE])),
                                   bind_buffer(cv_graph_buffer(pc, r->buf[BUF_IMAGE_POOL])) };
        for (uint32_t k = 0; k < s->reflection_samples; k++) {
            gen.sample = k;
            shade.row_offset = k * r->height;
            dispatch_pixels(r, l, pc->queue, PIPE_REFLECT_RAYGEN, gen_b, 5, &gen, sizeof(gen), cols.width, h);
            cv_cmd_trace_rays(l, pc->queue,
                              &(cv_trace_rays_args){ .accel = r->accel, .rays = rays, .hits = hits, .count = count });
            if (r->alpha_mask)
                record_alpha_rounds(r, pc, l, rays, hits, cv_graph_buffer(pc, r->buf[BUF_REFLECT_ALPHA_HITS]), count,
                                    false);
            dispatch_pixels(r, l, pc->queue, PIPE_REFLECT_SHADOW, shadow_b, 5, &shadow, sizeof(shadow), cols.width,
                            h);
            cv_cmd_trace_rays(l, pc->queue,
                              &(cv_trace_rays_args){ .accel = r->accel,
                                                     .rays = shadow_rays,
                                                     .hits = shadow_hits,
                                                     .count = count,
                                                     .flags = CV_TRACE_ANY_HIT });
            if (r->alpha_mask)
                record_alpha_rounds(r, pc, l, shadow_rays, shadow_hits,
                                    cv_graph_buffer(pc, r->buf[BUF_REFLECT_ALPHA_HITS]), count, true);
            dispatch_pixels(r, l, pc->queue, PIPE_REFLECT_SHADE, shade_b, 12, &shade, sizeof(shade), cols.width, h);
        }
    }
}

/* Moving camera: the longest reflection history kept (frames). As for the
 * shadows (REPROJECT_MAX_HISTORY), a reprojected history's error grows with
 * its length even for slow motion; room 96x54, 16 frames, reflection plane
 * against 1024 samples at the last frame (docs/renderer-quality.md,
 * Reflections, "Moving camera"), RMSE with at most 3 / 4 / 8 / 16 frames:
 * 0.0554 / 0.0496 / 0.0462 / 0.0503 at 0.05 degrees a frame, 0.0629 / 0.0612 /
 * 0.0604 / 0.0634 at 0.3, 0.0762 / 0.0792 / 0.0861 / 0.0900 at 1 (one frame
 * alone about 0.10), so 4: within 0.004 of the best at each speed. And the
 * roughness from which a reflection's history follows the surface alone
 * (below it the virtual point's weight is 1 - smoothstep(0, limit,
 * roughness); 0.2 and 1.0 changed the 1-degree figure by under 0.0003). */
#define REFLECT_MAX_HISTORY 4u
#define REFLECT_ROUGH_LIMIT 0.5f

/* Pass 'reflect_reproject' (primary, moving camera): the reflection history
 * brought to this frame's pixels by the virtual point's and the surface's
 * motion (render_reflect_reproject.comp). */
static void record_reflect_reproject(const cv_graph_pass_context *pc, cv_command_list *l, void *user) {
    cv_renderer *r = user;
    struct {
        float prev_view_proj[16];
        float eye[4];
        uint32_t width, height, has_history, material_count;
        float params[4];
    } push = { .eye = { r->camera.position[0], r->camera.position[1], r->camera.position[2],
                        REPROJECT_PLANE_TOLERANCE },
               .width = r->width,
               .height = r->height,
               .has_history = r->frame > 0,
               .material_count = r->data.material_count,
               .params = { REFLECT_ROUGH_LIMIT, 0.0f, 0.0f, 0.0f } };
    float far_plane;
    view_proj(r, &r->previous_camera, push.prev_view_proj, &far_plane);
    int tex[13] = { TEX_POSITION,
                    TEX_NORMAL,
                    TEX_MATERIAL,
                    TEX_MOTION,
                    TEX_HISTORY_POSITION,
                    TEX_HISTORY_NORMAL,
                    TEX_REFLECT,
                    TEX_REFLECT_HISTORY,
                    TEX_REFLECT_OWN,
                    TEX_REFLECT_STATE,
                    TEX_REFLECT_REPROJECTED,
                    TEX_REFLECT_OWN_REPROJECTED,
                    TEX_REFLECT_STATE_REPROJECTED };
    cv_binding b[13];
    for (int i = 0; i < 13; i++)
        b[i] = bind_texture(cv_graph_texture(pc, r->tex[tex[i]]));
    dispatch_image(r, l, pc->queue, PIPE_REFLECT_REPROJECT, b, 13, &push, sizeof(push));
}

/* Pass 'reflect_filter' (primary, every frame): spatial reuse of this frame's
 * reflection samples, into the running mean (render_reflect_filter.comp); a
 * moving camera's into the reprojected history. A still camera's pass binds
 * the history again in the slots it does not use. */
static void record_reflect_filter(const cv_graph_pass_context *pc, cv_command_list *l, void *user) {
    cv_renderer *r = user;
    const cv_render_settings *s = &r->settings;
    bool moving = r->graph_moving;
    struct {
        uint32_t width, height, frame, accumulated;
        float camera[4];
        int32_t radius;
        uint32_t material_count, quarter, moving_cap, samples, pad[3];
    } push = { r->width,
               r->height,
               s->first_frame + r->frame,
               /* A moving camera: per-pixel history lengths (the reprojected state). */
               moving ? 0u : r->frame,
               { r->camera.position[0], r->camera.position[1], r->camera.position[2], r->data.diagonal * 0.01f },
               s->reflection_scale < 1.0f ? s->reflection_radius + 1 : s->reflection_radius,
               r->data.material_count,
               s->reflection_scale < 1.0f ? 1u : 0u,
               moving ? REFLECT_MAX_HISTORY : 0u,
               s->reflection_samples,
               { 0, 0, 0 } };
    int tex[11] = { TEX_POSITION,
                    TEX_NORMAL,
                    TEX_MATERIAL,
                    TEX_REFLECT,
                    TEX_REFLECT_HISTORY,
                    TEX_REFLECT_OWN,
                    TEX_REFLECT_OUT,
                    moving ? TEX_REFLECT_REPROJECTED : TEX_REFLECT_HISTORY,
                    moving ? TEX_REFLECT_OWN_REPROJECTED : TEX_REFLECT_OWN,
                    moving ? TEX_REFLECT_STATE_REPROJECTED : TEX_REFLECT_HISTORY,
                    moving ? TEX_REFLECT_STATE : TEX_REFLECT_OWN };
    cv_binding b[12];
    for (int i = 0; i < 11; i++)
        b[i] = bind_texture(cv_graph_texture(pc, r->tex[tex[i]]));
    b[11] = bind_buffer(cv_graph_buffer(pc, r->buf[BUF_BLUE_NOISE]));
    dispatch_image(r, l, pc->queue, PIPE_REFLECT_FILTER, b, 12, &push, sizeof(push));
}

/* The angle one pixel subtends at the camera (2 tan(fov / 2) / height): times
 * a distance, the world size of a pixel there (the filters' footprint). */
static float pixel_angle(const cv_renderer *r) {
    return 2.0f * tanf(0.5f * r->camera.vertical_fov) / (float)r->height;
}

/* render.reflect_denoise (render_reflect_denoise.comp) on the frame that is
 * composited: REFLECT_DENOISE_ITERATIONS a-trous steps over the reconstructed
 * reflection. Measured on the room at 640x360 against 4096 samples
 * (docs/renderer-quality.md, "Reflections: the denoise pass"):
 * - iterations 2 / 3 / 4: one frame's reflection RMSE 0.0426 / 0.0363 /
 *   0.0359 (seed 1, sigma_l 32); 3 from here on;
 * - sigma_l with the spatial variance (fewer than 8 frames) 2 / 4 / 8 / 16 /
 *   32 / none: 0.0539 / 0.0433 / 0.0389 / 0.0372 / 0.0365 / 0.0363, bias
 *   -0.0043 ... -0.0019 / +0.0004: the signal weight pulls toward the
 *   commonest value (darker: bright samples are rare); 32 keeps real edges a
 *   little at SSIM 0.944 against none's 0.951;
 * - sigma_l with the temporal variance (8 frames on) 4 / 16: 64 frames 0.0113
 *   / 0.0121 (no denoise: 0.0145);
 * - lobe scale 0.5 / 1 / 2 / 4: 0.0452 / 0.0433 / 0.0424 / 0.0420 (sigma_l 4). */
#define REFLECT_DENOISE_ITERATIONS 3
#define REFLECT_DENOISE_SIGMA_L_SPATIAL 32.0f
#define REFLECT_DENOISE_SIGMA_L_TEMPORAL 4.0f
#define REFLECT_DENOISE_LOBE_SCALE 2.0f

/* The texture holding the reflection shown: the last denoise iteration's. */
static int reflect_shown_texture(void) {
    return REFLECT_DENOISE_ITERATIONS % 2 ? TEX_REFLECT_DENOISE_PING : TEX_REFLECT_DENOISE_PONG;
}

static void record_reflect_denoise(const cv_graph_pass_context *pc, cv_command_list *l, void *user) {
    cv_renderer *r = user;
    bool copy = r->graph_iterations == 0; /* unfiltered: the reconstruction as it is */
    for (uint32_t i = 0; i < REFLECT_DENOISE_ITERATIONS; i++) {
        int src = i == 0 ? TEX_REFLECT_OUT : (i % 2 ? TEX_REFLECT_DENOISE_PING : TEX_REFLECT_DENOISE_PONG);
        int dst = i % 2 ? TEX_REFLECT_DENOISE_PONG : TEX_REFLECT_DENOISE_PING;
        struct {
            uint32_t width, height, step, flags;
            float camera[4];
            float sigma_l_spatial, lobe_scale, pixel_angle, sigma_l_temporal;
        } push = { r->width,
                   r->height,
                   1u << i,
                   (i == 0 ? 1u : 0u) | (i + 1 == REFLECT_DENOISE_ITERATIONS ? 2u : 0u) | (copy ? 4u : 0u),
                   { r->camera.position[0], r->camera.position[1], r->camera.position[2], r->data.diagonal * 0.01f },
                   REFLECT_DENOISE_SIGMA_L_SPATIAL,
                   REFLECT_DENOISE_LOBE_SCALE,
                   pixel_angle(r),
                   REFLECT_DENOISE_SIGMA_L_TEMPORAL };
        int tex[6] = { TEX_POSITION, TEX_NORMAL, TEX_MATERIAL, TEX_REFLECT, src, dst };
        cv_binding b[6];
        for (int k = 0; k < 6; k++)
            b[k] = bind_texture(cv_graph_texture(pc, r->tex[tex[k]]));
        dispatch_image(r, l, pc->queue, PIPE_REFLECT_DENOISE, b, 6, &push, sizeof(push));
    }
}

/* The texture holding the final visibility after `iterations` filter steps. */
static int filtered_texture(uint32_t iterations) {
    return iterations == 0 ? TEX_HISTORY : (iterations % 2 ? TEX_PING : TEX_PONG);
}

/* Variance-guided a-trous iterations (steps 1, 2, 4, ...; render_filter.comp)
 * history -> ping -> pong -> ping ... sigma_l: SVGF's 4; 8 while the
 * variance is the spatial estimate (fewer than 4 frames), where 4 stopped at
 * noise it could have smoothed: room 160x90, one frame, against 4096 samples,
 * 8 took shadow / AO RMSE from 0.0262 / 0.0467 to 0.0252 / 0.0458 (16 and 32
 * gained less than 0.0005 more); at 64 frames 8 blurred (AO 0.0043 -> 0.0057).
 * Converged: a channel whose variance of the mean is below FILTER_CONVERGED_STD^2
 * (standard error 0.02; a binary shadow ray gets there by 625 frames) is left
 * unfiltered.
 * Shadow sigma: FILTER_PENUMBRA_SIGMA x P^(2/3) x footprint^(1/3), P the
 * penumbra's width (render_filter.comp). A sigma of a fixed number of
 * penumbra widths was best at 2 at 64x36 and 160x90, at 1 at 640x360 (the
 * room; docs/renderer-quality.md, "Filter reach from the pixel footprint");
 * the constant 1 / 1.5 / 1.75 / 2 / 3 measured from 64x36 to 640x360 and on
 * the glTF engine: 1.75 is within 0.0017 of the best at every size. With
 * shadow_samples rays a frame the whole sigma (floors included) is divided
 * by sqrt(shadow_samples), as the noise is: one frame of the glTF engine at
 * 640x360, 2 / 4 / 8 rays, was best at 0.7 / 0.5 / 0.35 of the one-ray sigma
 * (docs/renderer-quality.md, "AO: a local linear fit; shadow rays per
 * pixel").
 * AO sigma: FILTER_AO_SIGMA x sqrt(4 / ao_samples) x ao_radius^(2/3) x
 * footprint^(1/3) (render_filter.comp). The AO's estimate is a local linear
 * fit, not a weighted mean, which lets the kernel be wider than the mean's
 * best (0.7 with 4 rays) without the mean's bias at creases: with the fit,
 * 1 / 1.5 / 2 (x 0.7) measured on the room and the glTF engine at 640x360,
 * and 1 and 16 rays a frame (docs/renderer-quality.md, same section). */
#define FILTER_SIGMA_L 4.0f
#define FILTER_SIGMA_L_SPATIAL 8.0f
#define FILTER_CONVERGED_STD 0.02f
#define FILTER_PENUMBRA_SIGMA 1.75f
#define FILTER_AO_SIGMA 1.05f
/* The penumbra's width per unit of blocker distance: 2 tan(cone). */
static float penumbra_scale(const cv_renderer *r) {
    return 2.0f * tanf(r->settings.sun_cone_degrees * 3.14159265f / 180.0f);
}

static void record_filter(cv_renderer *r, uint32_t iterations, uint32_t frames, cv_command_list *l) {
    cv_cmd_begin_marker(l, CV_QUEUE_COMPUTE, &(cv_begin_marker_args){ .label = "filter" });
    for (uint32_t i = 0; i < iterations; i++) {
        int src = i == 0 ? TEX_HISTORY : filtered_texture(i), dst = filtered_texture(i + 1);
        struct {
            uint32_t width, height, step, frames;
            float position_sigma, sigma_l, converged_variance;
            uint32_t flags;
            float penumbra_scale, sigma_l_spatial, pixel_angle, ao_sigma_scale;
            float eye[4];
            float shadow_sigma_scale;
        } push = { r->width,
                   r->height,
                   1u << i,
                   frames,
                   r->data.diagonal * 0.01f,
                   FILTER_SIGMA_L,
                   FILTER_CONVERGED_STD * FILTER_CONVERGED_STD,
                   (i == 0 ? 1u : 0u) | (i + 1 == iterations ? 2u : 0u) | (r->graph_moving ? 4u : 0u),
                   penumbra_scale(r),
                   FILTER_SIGMA_L_SPATIAL,
                   pixel_angle(r),
                   FILTER_AO_SIGMA * sqrtf(4.0f / (float)r->settings.ao_samples) *
                       cbrtf(r->settings.ao_radius * r->settings.ao_radius),
                   { r->camera.position[0], r->camera.position[1], r->camera.position[2], FILTER_PENUMBRA_SIGMA },
                   1.0f / sqrtf((float)r->settings.shadow_samples) };
        /* A still camera's history length is `frames` everywhere: no motion texture. */
        cv_binding b[7] = { bind_texture(r->textures[TEX_POSITION]),
                            bind_texture(r->textures[TEX_NORMAL]),
                            bind_texture(r->textures[src]),
                            bind_texture(r->textures[dst]),
                            bind_texture(r->textures[TEX_HISTORY]),
                            bind_texture(r->textures[r->graph_moving ? TEX_MOTION : TEX_HISTORY]),
                            bind_texture(r->textures[TEX_VISIBILITY]) };
        dispatch_image(r, l, CV_QUEUE_COMPUTE, PIPE_FILTER, b, 7, &push, sizeof(push));
    }
    cv_cmd_end_marker(l, CV_QUEUE_COMPUTE, &(cv_end_marker_args){ 0 });
}

static void record_composite(cv_renderer *r, uint32_t iterations, cv_command_list *l) {
    struct {
        float sun[4], sun_color[4], sky[4];
        uint32_t width, height, material_count, light_count;
        float camera[4]; /* w: 1 = add the reflection */
    } push = { { r->sun_direction[0], r->sun_direction[1], r->sun_direction[2], r->data.sun_irradiance },
               { r->data.sun_color[0], r->data.sun_color[1], r->data.sun_color[2], 0.0f },
               { 0.12f, 0.15f, 0.2f, 0.0f },
               r->width,
               r->height,
               r->data.material_count,
               r->data.light_count,
               { r->camera.position[0], r->camera.position[1], r->camera.position[2],
                 r->graph_reflect ? 1.0f : 0.0f } };
    cv_binding b[9] = { bind_texture(r->textures[TEX_POSITION]),
                        bind_texture(r->textures[TEX_NORMAL]),
                        bind_texture(r->textures[filtered_texture(iterations)]),
                        bind_texture(r->textures[TEX_MATERIAL]),
                        bind_texture(r->textures[TEX_RADIANCE]),
                        bind_texture(r->textures[TEX_ALBEDO]),
                        bind_buffer(r->lights),
                        bind_texture(r->textures[reflect_shown_texture()]),
                        bind_texture(r->textures[TEX_EMISSION]) };
    cv_cmd_begin_marker(l, CV_QUEUE_COMPUTE, &(cv_begin_marker_args){ .label = "composite" });
    dispatch_image(r, l, CV_QUEUE_COMPUTE, PIPE_COMPOSITE, b, 9, &push, sizeof(push));
    cv_cmd_end_marker(l, CV_QUEUE_COMPUTE, &(cv_end_marker_args){ 0 });
}

/* Passes 'filter' and 'composite' (primary, last frame). The textures they
 * record are the renderer's, imported into the graph: the handles
 * cv_graph_texture would give. */
static void pass_filter(const cv_graph_pass_context *pc, cv_command_list *l, void *user) {
    (void)pc;
    cv_renderer *r = user;
    record_filter(r, r->graph_iterations, r->graph_frames, l);
}

static void pass_composite(const cv_graph_pass_context *pc, cv_command_list *l, void *user) {
    (void)pc;
    cv_renderer *r = user;
    record_composite(r, r->graph_iterations, l);
}

static cv_result read_output(cv_renderer *r, uint32_t iterations, uint32_t frames, cv_render_output *out) {
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
    if (res == CV_OK)
        res = cv_device_read_texture(p, r->textures[TEX_ALBEDO], all, out->albedo);
    if (res == CV_OK)
        res = cv_device_read_texture(p, r->textures[TEX_NORMAL], all, out->normal);
    if (res == CV_OK)
        res = cv_device_read_texture(p, r->textures[TEX_POSITION], all, out->position);
    /* The G-buffer's w packs the geometric normal (render_gbuffer.frag); the output says 1. */
    for (size_t i = 3; res == CV_OK && i < n; i += 4)
        out->position[i] = out->position[i] != 0.0f ? 1.0f : 0.0f;
    if (res == CV_OK)
        res = cv_device_read_texture(p, r->textures[filtered_texture(iterations)], all, out->visibility);
    if (res == CV_OK && !(out->motion = malloc(n * sizeof(float))))
        res = cv_error(CV_ERROR_OUT_OF_MEMORY, "renderer: motion plane");
    if (res == CV_OK && r->graph_moving) {
        res = cv_device_read_texture(p, r->textures[TEX_MOTION], all, out->motion);
    } else if (res == CV_OK) {
        /* A still camera: no motion; every covered pixel's history is all the frames. */
        for (size_t i = 0; i < n; i += 4) {
            bool covered = out->position[i + 3] != 0.0f;
            out->motion[i] = out->motion[i + 1] = 0.0f;
            out->motion[i + 2] = covered ? (float)frames : 0.0f;
            out->motion[i + 3] = covered && frames > 1 ? 1.0f : 0.0f;
        }
    }
    if (res == CV_OK) { /* direct light under the sun this render used (settings.sun_toward or the scene's) */
        render_scene_data lit = r->data;
        memcpy(lit.sun_direction, r->sun_direction, sizeof(lit.sun_direction));
        res = render_output_derive(out, r->camera.position, &lit);
    }
    if (res == CV_OK && r->graph_reflect) {
        out->reflection = malloc(n * sizeof(float));
        res = out->reflection ? cv_device_read_texture(p, r->textures[reflect_shown_texture()], all, out->reflection)
                              : cv_error(CV_ERROR_OUT_OF_MEMORY, "renderer: reflection plane");
    }
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
    free(out->depth);
    free(out->direct);
    free(out->motion);
    free(out->reflection);
    memset(out, 0, sizeof(*out));
}

/* The frame graph for the current targets, `iterations` filter steps, ray
 * buffers of `rays` rays and a still or moving camera (settings.orbit_degrees;
 * built again when any of them changes). */
static cv_result build_graph(cv_renderer *r, uint32_t iterations, uint64_t rays) {
    const cv_render_settings *s = &r->settings;
    bool moving = s->orbit_degrees != 0.0f;
    bool reflect = s->reflections == 1;
    uint64_t reflect_rays = reflect_capacity(r, s);
    if (r->graph && r->graph_iterations == iterations && r->graph_rays == rays && r->graph_moving == moving &&
        r->graph_reflect == reflect && r->graph_reflect_rays == reflect_rays)
        return CV_OK;
    destroy_graph(r);
    for (uint32_t d = 0; d < r->count; d++)
        if (rays * CV_RAY_BYTES > cv_device_get_info(r->devices[d])->max_storage_buffer_range)
            return cv_error(CV_ERROR_LIMIT_EXCEEDED,
                            "renderer: %llu rays (%llu bytes) exceed device '%s''s storage "
                            "buffer range; use fewer AO samples, a smaller image or more devices",
                            (unsigned long long)rays, (unsigned long long)(rays * CV_RAY_BYTES),
                            cv_device_label(r->devices[d]));
    cv_graph *g;
    cv_result res = cv_graph_create(r->ctx, r->devices, r->count, &g);
    if (res != CV_OK)
        return res;
    r->graph = g;
    r->graph_generation++;
    r->graph_iterations = iterations;
    r->graph_rays = rays;
    r->graph_moving = moving;
    r->graph_reflect = reflect;
    r->graph_reflect_rays = reflect_rays;
    for (int t = 0; t < TEX_COUNT && res == CV_OK; t++)
        res = cv_graph_import_texture(g, r->textures[t], &r->tex[t]);
    if (res == CV_OK)
        res = cv_graph_import_buffer(g, r->vertices, 0, &r->buf[BUF_VERTICES]);
    if (res == CV_OK)
        res = cv_graph_import_buffer(g, r->materials, 0, &r->buf[BUF_MATERIALS]);
    if (res == CV_OK)
        res = cv_graph_import_buffer(g, r->lights, 0, &r->buf[BUF_LIGHTS]);
    if (res == CV_OK)
        res = cv_graph_import_buffer(g, r->uvs, 0, &r->buf[BUF_UVS]);
    if (res == CV_OK)
        res = cv_graph_import_buffer(g, r->image_table, 0, &r->buf[BUF_IMAGE_TABLE]);
    if (res == CV_OK)
        res = cv_graph_import_buffer(g, r->image_pool, 0, &r->buf[BUF_IMAGE_POOL]);
    if (res == CV_OK)
        res = cv_graph_import_buffer(g, r->blue_noise, 0, &r->buf[BUF_BLUE_NOISE]);
    if (res == CV_OK)
        res = cv_graph_create_buffer(g, &(cv_buffer_desc){ .size = rays * CV_RAY_BYTES, .label = "rays" }, 0,
                                     &r->buf[BUF_RAYS]);
    if (res == CV_OK)
        res = cv_graph_create_buffer(g, &(cv_buffer_desc){ .size = rays * CV_HIT_BYTES, .label = "hits" }, 0,
                                     &r->buf[BUF_HITS]);
    if (res == CV_OK && (reflect || r->alpha_mask))
        res = cv_graph_import_buffer(g, r->instances, 0, &r->buf[BUF_INSTANCES]);
    if (res == CV_OK && r->alpha_mask)
        res = cv_graph_create_buffer(g, &(cv_buffer_desc){ .size = rays * CV_HIT_BYTES, .label = "alpha hits" }, 0,
                                     &r->buf[BUF_ALPHA_HITS]);
    if (res == CV_OK && r->alpha_mask && reflect)
        res = cv_graph_create_buffer(g,
                                     &(cv_buffer_desc){ .size = reflect_rays * CV_HIT_BYTES,
                                                        .label = "reflect alpha hits" },
                                     0, &r->buf[BUF_REFLECT_ALPHA_HITS]);
    static const char *reflect_labels[4] = { "reflect rays", "reflect hits", "reflect shadow rays",
                                             "reflect shadow hits" };
    for (int k = 0; k < 4 && res == CV_OK && reflect; k++) {
        cv_buffer_desc desc = { .size = reflect_rays * (k % 2 ? CV_HIT_BYTES : CV_RAY_BYTES) };
        strncpy(desc.label, reflect_labels[k], sizeof(desc.label) - 1);
        res = cv_graph_create_buffer(g, &desc, 0, &r->buf[BUF_REFLECT_RAYS + k]);
    }
    cv_graph_pass p = { 0 };
#define PASS(name, queue, policy, fn) \
    if (res == CV_OK) \
    res = cv_graph_add_pass(g, &(cv_graph_pass_desc){ name, queue, policy, fn, r }, &p)
#define READ(res_, access) \
    if (res == CV_OK) \
    res = cv_graph_read(g, p, res_, access)
#define WRITE(res_, access) \
    if (res == CV_OK) \
    res = cv_graph_write(g, p, res_, access, CV_GRAPH_TRANSFER_AUTO)
    /* The G-buffer, on the first frame when the camera is still, on every
     * frame when it moves; the trace and reflect passes on other devices read
     * it, each at the pixels of its own window. A still camera's G-buffer is
     * multicast whole: it is rendered once and the balancer moves the windows
     * in later frames. A moving camera's is rendered every frame, so each
     * device gets only that frame's window of it. */
    cv_graph_transfer gbuffer_rule = moving ? CV_GRAPH_TRANSFER_PRIMARY_TO_WINDOWS : CV_GRAPH_TRANSFER_MULTICAST;
    PASS("gbuffer", CV_QUEUE_GRAPHICS, CV_MGPU_PRIMARY_ONLY, record_gbuffer);
    READ(r->buf[BUF_VERTICES], CV_GRAPH_STORAGE_READ);
    READ(r->buf[BUF_UVS], CV_GRAPH_STORAGE_READ);
    READ(r->buf[BUF_MATERIALS], CV_GRAPH_STORAGE_READ);
    READ(r->buf[BUF_IMAGE_TABLE], CV_GRAPH_STORAGE_READ);
    READ(r->buf[BUF_IMAGE_POOL], CV_GRAPH_STORAGE_READ);
    if (res == CV_OK)
        res = cv_graph_write(g, p, r->tex[TEX_POSITION], CV_GRAPH_COLOR_TARGET, gbuffer_rule);
    if (res == CV_OK)
        res = cv_graph_write(g, p, r->tex[TEX_NORMAL], CV_GRAPH_COLOR_TARGET, gbuffer_rule);
    if (res == CV_OK)
        res = cv_graph_write(g, p, r->tex[TEX_MATERIAL], CV_GRAPH_COLOR_TARGET, gbuffer_rule);
    WRITE(r->tex[TEX_EMISSION], CV_GRAPH_COLOR_TARGET);
    WRITE(r->tex[TEX_DEPTH], CV_GRAPH_DEPTH_TARGET);
    r->gbuffer_pass = p;
    /* Every device traces its window; the primary's accumulate reads the
     * visibility, so the secondaries' windows are copied back. */
    PASS("trace", CV_QUEUE_COMPUTE, CV_MGPU_ALL_DEVICES, record_trace);
    READ(r->tex[TEX_POSITION], CV_GRAPH_STORAGE_READ);
    READ(r->tex[TEX_NORMAL], CV_GRAPH_STORAGE_READ);
    READ(r->buf[BUF_BLUE_NOISE], CV_GRAPH_STORAGE_READ);
    WRITE(r->buf[BUF_RAYS], CV_GRAPH_STORAGE_WRITE);
    WRITE(r->buf[BUF_HITS], CV_GRAPH_STORAGE_WRITE);
    WRITE(r->tex[TEX_VISIBILITY], CV_GRAPH_STORAGE_WRITE);
    if (r->alpha_mask) { /* the alpha-mask rule reads the hits' materials */
        READ(r->buf[BUF_VERTICES], CV_GRAPH_STORAGE_READ);
        READ(r->buf[BUF_INSTANCES], CV_GRAPH_STORAGE_READ);
        READ(r->buf[BUF_UVS], CV_GRAPH_STORAGE_READ);
        READ(r->buf[BUF_MATERIALS], CV_GRAPH_STORAGE_READ);
        READ(r->buf[BUF_IMAGE_TABLE], CV_GRAPH_STORAGE_READ);
        READ(r->buf[BUF_IMAGE_POOL], CV_GRAPH_STORAGE_READ);
        WRITE(r->buf[BUF_ALPHA_HITS], CV_GRAPH_STORAGE_WRITE);
    }
    /* Moving camera: the history follows the surfaces (motion vectors,
     * disocclusion), and the accumulate keeps this frame's G-buffer beside it. */
    r->reproject_pass = (cv_graph_pass){ 0 };
    if (moving) {
        PASS("reproject", CV_QUEUE_COMPUTE, CV_MGPU_PRIMARY_ONLY, record_reproject);
        READ(r->tex[TEX_POSITION], CV_GRAPH_STORAGE_READ);
        READ(r->tex[TEX_NORMAL], CV_GRAPH_STORAGE_READ);
        READ(r->tex[TEX_HISTORY_POSITION], CV_GRAPH_STORAGE_READ);
        READ(r->tex[TEX_HISTORY_NORMAL], CV_GRAPH_STORAGE_READ);
        READ(r->tex[TEX_HISTORY], CV_GRAPH_STORAGE_READ);
        WRITE(r->tex[TEX_MOTION], CV_GRAPH_STORAGE_WRITE);
        WRITE(r->tex[TEX_REPROJECTED], CV_GRAPH_STORAGE_WRITE);
        r->reproject_pass = p;
    }
    /* Reflections: every device traces its window as in 'trace' (the graph
     * copies the sample windows back); the primary reconstructs and
     * accumulates them every frame. */
    if (reflect) {
        PASS("reflect", CV_QUEUE_COMPUTE, CV_MGPU_ALL_DEVICES, record_reflect);
        READ(r->tex[TEX_POSITION], CV_GRAPH_STORAGE_READ);
        READ(r->tex[TEX_NORMAL], CV_GRAPH_STORAGE_READ);
        READ(r->tex[TEX_MATERIAL], CV_GRAPH_STORAGE_READ);
        READ(r->buf[BUF_VERTICES], CV_GRAPH_STORAGE_READ);
        READ(r->buf[BUF_MATERIALS], CV_GRAPH_STORAGE_READ);
        READ(r->buf[BUF_INSTANCES], CV_GRAPH_STORAGE_READ);
        READ(r->buf[BUF_UVS], CV_GRAPH_STORAGE_READ);
        READ(r->buf[BUF_IMAGE_TABLE], CV_GRAPH_STORAGE_READ);
        READ(r->buf[BUF_IMAGE_POOL], CV_GRAPH_STORAGE_READ);
        READ(r->buf[BUF_BLUE_NOISE], CV_GRAPH_STORAGE_READ);
        for (int k = BUF_REFLECT_RAYS; k <= BUF_SHADOW_HITS; k++)
            WRITE(r->buf[k], CV_GRAPH_STORAGE_WRITE);
        WRITE(r->tex[TEX_REFLECT], CV_GRAPH_STORAGE_WRITE);
        if (r->alpha_mask)
            WRITE(r->buf[BUF_REFLECT_ALPHA_HITS], CV_GRAPH_STORAGE_WRITE);
        if (moving) { /* the history follows the reflections (virtual point) and the surfaces */
            PASS("reflect_reproject", CV_QUEUE_COMPUTE, CV_MGPU_PRIMARY_ONLY, record_reflect_reproject);
            READ(r->tex[TEX_POSITION], CV_GRAPH_STORAGE_READ);
            READ(r->tex[TEX_NORMAL], CV_GRAPH_STORAGE_READ);
            READ(r->tex[TEX_MATERIAL], CV_GRAPH_STORAGE_READ);
            READ(r->tex[TEX_MOTION], CV_GRAPH_STORAGE_READ);
            READ(r->tex[TEX_HISTORY_POSITION], CV_GRAPH_STORAGE_READ);
            READ(r->tex[TEX_HISTORY_NORMAL], CV_GRAPH_STORAGE_READ);
            READ(r->tex[TEX_REFLECT], CV_GRAPH_STORAGE_READ);
            READ(r->tex[TEX_REFLECT_HISTORY], CV_GRAPH_STORAGE_READ);
            READ(r->tex[TEX_REFLECT_OWN], CV_GRAPH_STORAGE_READ);
            READ(r->tex[TEX_REFLECT_STATE], CV_GRAPH_STORAGE_READ);
            WRITE(r->tex[TEX_REFLECT_REPROJECTED], CV_GRAPH_STORAGE_WRITE);
            WRITE(r->tex[TEX_REFLECT_OWN_REPROJECTED], CV_GRAPH_STORAGE_WRITE);
            WRITE(r->tex[TEX_REFLECT_STATE_REPROJECTED], CV_GRAPH_STORAGE_WRITE);
        }
        PASS("reflect_filter", CV_QUEUE_COMPUTE, CV_MGPU_PRIMARY_ONLY, record_reflect_filter);
        READ(r->buf[BUF_BLUE_NOISE], CV_GRAPH_STORAGE_READ);
        READ(r->tex[TEX_POSITION], CV_GRAPH_STORAGE_READ);
        READ(r->tex[TEX_NORMAL], CV_GRAPH_STORAGE_READ);
        READ(r->tex[TEX_MATERIAL], CV_GRAPH_STORAGE_READ);
        READ(r->tex[TEX_REFLECT], CV_GRAPH_STORAGE_READ);
        READ(r->tex[TEX_REFLECT_HISTORY], CV_GRAPH_STORAGE_READ);
        READ(r->tex[TEX_REFLECT_OWN], CV_GRAPH_STORAGE_READ);
        WRITE(r->tex[TEX_REFLECT_HISTORY], CV_GRAPH_STORAGE_WRITE);
        WRITE(r->tex[TEX_REFLECT_OWN], CV_GRAPH_STORAGE_WRITE);
        WRITE(r->tex[TEX_REFLECT_OUT], CV_GRAPH_STORAGE_WRITE);
        if (moving) {
            READ(r->tex[TEX_REFLECT_REPROJECTED], CV_GRAPH_STORAGE_READ);
            READ(r->tex[TEX_REFLECT_OWN_REPROJECTED], CV_GRAPH_STORAGE_READ);
            READ(r->tex[TEX_REFLECT_STATE_REPROJECTED], CV_GRAPH_STORAGE_READ);
            WRITE(r->tex[TEX_REFLECT_STATE], CV_GRAPH_STORAGE_WRITE);
        }
    }
    PASS("accumulate", CV_QUEUE_COMPUTE, CV_MGPU_PRIMARY_ONLY, record_accumulate);
    READ(r->tex[TEX_VISIBILITY], CV_GRAPH_STORAGE_READ);
    READ(r->tex[TEX_HISTORY], CV_GRAPH_STORAGE_READ);
    WRITE(r->tex[TEX_HISTORY], CV_GRAPH_STORAGE_WRITE);
    if (moving) {
        READ(r->tex[TEX_MOTION], CV_GRAPH_STORAGE_READ);
        READ(r->tex[TEX_REPROJECTED], CV_GRAPH_STORAGE_READ);
        READ(r->tex[TEX_POSITION], CV_GRAPH_STORAGE_READ);
        READ(r->tex[TEX_NORMAL], CV_GRAPH_STORAGE_READ);
        WRITE(r->tex[TEX_HISTORY_POSITION], CV_GRAPH_STORAGE_WRITE);
        WRITE(r->tex[TEX_HISTORY_NORMAL], CV_GRAPH_STORAGE_WRITE);
    }
    /* On the last frame: a-trous iterations, then the composite. */
    r->reflect_denoise_pass = (cv_graph_pass){ 0 };
    if (reflect) {
        PASS("reflect_denoise", CV_QUEUE_COMPUTE, CV_MGPU_PRIMARY_ONLY, record_reflect_denoise);
        READ(r->tex[TEX_POSITION], CV_GRAPH_STORAGE_READ);
        READ(r->tex[TEX_NORMAL], CV_GRAPH_STORAGE_READ);
        READ(r->tex[TEX_MATERIAL], CV_GRAPH_STORAGE_READ);
        READ(r->tex[TEX_REFLECT], CV_GRAPH_STORAGE_READ);
        READ(r->tex[TEX_REFLECT_OUT], CV_GRAPH_STORAGE_READ);
        READ(r->tex[TEX_REFLECT_DENOISE_PING], CV_GRAPH_STORAGE_READ);
        WRITE(r->tex[TEX_REFLECT_DENOISE_PING], CV_GRAPH_STORAGE_WRITE);
        READ(r->tex[TEX_REFLECT_DENOISE_PONG], CV_GRAPH_STORAGE_READ);
        WRITE(r->tex[TEX_REFLECT_DENOISE_PONG], CV_GRAPH_STORAGE_WRITE);
        r->reflect_denoise_pass = p;
    }
    r->filter_pass = (cv_graph_pass){ 0 };
    if (iterations > 0) {
        PASS("filter", CV_QUEUE_COMPUTE, CV_MGPU_PRIMARY_ONLY, pass_filter);
        READ(r->tex[TEX_POSITION], CV_GRAPH_STORAGE_READ);
        READ(r->tex[TEX_NORMAL], CV_GRAPH_STORAGE_READ);
        READ(r->tex[TEX_HISTORY], CV_GRAPH_STORAGE_READ);
        READ(r->tex[TEX_VISIBILITY], CV_GRAPH_STORAGE_READ);
        if (moving)
            READ(r->tex[TEX_MOTION], CV_GRAPH_STORAGE_READ);
        WRITE(r->tex[TEX_PING], CV_GRAPH_STORAGE_WRITE);
        if (iterations > 1)
            WRITE(r->tex[TEX_PONG], CV_GRAPH_STORAGE_WRITE);
        r->filter_pass = p;
    }
    PASS("composite", CV_QUEUE_COMPUTE, CV_MGPU_PRIMARY_ONLY, pass_composite);
    READ(r->tex[TEX_POSITION], CV_GRAPH_STORAGE_READ);
    READ(r->tex[TEX_NORMAL], CV_GRAPH_STORAGE_READ);
    READ(r->tex[filtered_texture(iterations)], CV_GRAPH_STORAGE_READ);
    READ(r->tex[TEX_MATERIAL], CV_GRAPH_STORAGE_READ);
    READ(r->tex[TEX_EMISSION], CV_GRAPH_STORAGE_READ);
    READ(r->buf[BUF_LIGHTS], CV_GRAPH_STORAGE_READ);
    if (reflect)
        READ(r->tex[reflect_shown_texture()], CV_GRAPH_STORAGE_READ);
    WRITE(r->tex[TEX_RADIANCE], CV_GRAPH_STORAGE_WRITE);
    WRITE(r->tex[TEX_ALBEDO], CV_GRAPH_STORAGE_WRITE);
    r->composite_pass = p;
#undef PASS
#undef READ
#undef WRITE
    /* The accumulation carries over from frame to frame: an output, so the
     * accumulate is kept on frames without the composite. */
    if (res == CV_OK)
        res = cv_graph_output(g, r->tex[TEX_HISTORY]);
    if (res == CV_OK && moving)
        res = cv_graph_output(g, r->tex[TEX_HISTORY_POSITION]);
    if (res == CV_OK && moving)
        res = cv_graph_output(g, r->tex[TEX_HISTORY_NORMAL]);
    if (res == CV_OK && moving)
        res = cv_graph_output(g, r->tex[TEX_MOTION]);
    if (res == CV_OK && reflect)
        res = cv_graph_output(g, r->tex[TEX_REFLECT_HISTORY]);
    if (res == CV_OK && reflect)
        res = cv_graph_output(g, r->tex[TEX_REFLECT_OWN]);
    if (res == CV_OK && reflect)
        res = cv_graph_output(g, r->tex[TEX_REFLECT_OUT]);
    if (res == CV_OK && reflect)
        res = cv_graph_output(g, r->tex[reflect_shown_texture()]);
    if (res == CV_OK && reflect && moving)
        res = cv_graph_output(g, r->tex[TEX_REFLECT_STATE]);
    if (res == CV_OK)
        res = cv_graph_output(g, r->tex[TEX_RADIANCE]);
    if (res == CV_OK)
        res = cv_graph_output(g, r->tex[TEX_ALBEDO]);
    if (res != CV_OK)
        destroy_graph(r);
    return res;
}

/* Which passes frame f of `frames` runs: the G-buffer on the first (every
 * frame for a moving camera), the filters (visibility, reflection) and the
 * composite on the last. */
static cv_result enable_passes(cv_renderer *r, bool first, bool last) {
    cv_result res = cv_graph_enable_pass(r->graph, r->gbuffer_pass, first || r->graph_moving);
    if (res == CV_OK && r->filter_pass.id)
        res = cv_graph_enable_pass(r->graph, r->filter_pass, last);
    if (res == CV_OK && r->reflect_denoise_pass.id)
        res = cv_graph_enable_pass(r->graph, r->reflect_denoise_pass, last);
    if (res == CV_OK)
        res = cv_graph_enable_pass(r->graph, r->composite_pass, last);
    return res;
}

/* Adds one finished frame's graph timings to the render's stats: transfer
 * totals, and each device's trace time over the columns it had then (`used`).
 * frame_wall stands in where a device has no GPU timings. */
static void add_frame_timings(const cv_renderer *r, cv_render_stats *st, const cv_graph_timing *timings, uint32_t n,
                              const cv_partition *used, double frame_wall) {
    const cv_render_settings *s = &r->settings;
    for (uint32_t i = 0; i < n && i < 64; i++) {
        const cv_graph_timing *t = &timings[i];
        if (strncmp(t->name, "transfer ", 9) == 0) {
            st->transfer_bytes += t->bytes;
            st->transfer_ms += t->ms;
        } else if (strcmp(t->name, "trace") == 0 && t->device < r->count && t->device < used->device_count) {
            cv_column_range cols = used->ranges[t->device];
            double ms = t->ms > 0.0 ? t->ms : frame_wall; /* no GPU timing: the frame's wall time */
            st->devices[t->device] = (cv_render_device_stats){ .columns = cols,
                                                               .rays = (uint64_t)cols.width * r->height *
                                                                       cv_render_rays_per_pixel(s),
                                                               .trace_ms = ms,
                                                               .ms_per_column = ms / cols.width };
        }
    }
}

/* Before frame f's bake, with several devices: collects the frame `lag`
 * back (all frames still pending, on the last frame) and adds their timings. */
static cv_result collect_frames(cv_renderer *r, cv_render_stats *st, cv_graph_timing *timings,
                                uint64_t uncollected[CV_GRAPH_FRAMES_KEPT],
                                const cv_partition parts[CV_GRAPH_FRAMES_KEPT], uint32_t f, bool last) {
    const uint32_t lag = CV_GRAPH_FRAMES_KEPT - 1;
    double start = now_ms();
    cv_result res = CV_OK;
    for (uint32_t k = f >= lag ? f - lag : 0; k < f && res == CV_OK && r->count > 1; k++) {
        uint32_t slot = k % CV_GRAPH_FRAMES_KEPT, n = 0;
        if (!uncollected[slot] || (!last && k != f - lag))
            continue;
        res = cv_graph_collect(r->graph, uncollected[slot], timings, 64, &n);
        uncollected[slot] = 0;
        if (res == CV_OK)
            add_frame_timings(r, st, timings, n, &parts[slot], now_ms() - start);
    }
    return res;
}

cv_result cv_renderer_dump_graph(cv_renderer *r, FILE *text, FILE *dot) {
    if (!r || (!text && !dot))
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_renderer_dump_graph: NULL argument");
    if (!r->graph)
        return cv_error(CV_ERROR_BAD_STATE, "cv_renderer_dump_graph: nothing rendered yet");
    /* A frame with every pass (the first frame of a one-frame render), over
     * the last frame's columns. */
    cv_partition part;
    cv_result res = cv_graph_get_partition(r->graph, &part);
    if (res == CV_OK)
        res = enable_passes(r, true, true);
    if (res == CV_OK)
        res = cv_graph_bake(r->graph,
                            &(cv_graph_bake_desc){ .width = part.width, .tile = part.tile, .partition = &part });
    if (res == CV_OK && text)
        res = cv_graph_dump_text(r->graph, text);
    if (res == CV_OK && dot)
        res = cv_graph_dump_dot(r->graph, dot);
    return res;
}

/* A secondary device that is gone for good (its node died or disconnected)
 * leaves the renderer: the frame graph is rebuilt for the others, and the
 * frame it failed in is traced again by the survivors. Every pixel's rays
 * depend only on the pixel and the frame, so the image is the same as if the
 * device had never been there. The primary holds the image: without it there
 * is no frame. Returns how many devices were dropped. */
static uint32_t drop_lost_devices(cv_renderer *r) {
    if (r->count < 2 || cv_device_is_lost(r->devices[0]))
        return 0;
    uint32_t kept = 1;
    for (uint32_t d = 1; d < r->count; d++)
        if (!cv_device_is_lost(r->devices[d]))
            r->devices[kept++] = r->devices[d];
    uint32_t dropped = r->count - kept;
    if (dropped) {
        r->count = kept;
        destroy_graph(r);
    }
    return dropped;
}

/* What a device added later needs: the scene (buffers, BVH), the pipelines, the
 * textures every device holds and, once rendered, the G-buffer (the first frame
 * multicasts it; later frames do not render it again). */
static cv_result join_device(cv_renderer *r, cv_device *dev) {
    cv_handle scene[SCENE_HANDLES];
    scene_handles(r, scene);
    cv_result res = CV_OK;
    for (int i = 0; i < SCENE_HANDLES && res == CV_OK; i++)
        res = cv_device_load(dev, scene[i]);
    if (res == CV_OK)
        res = cv_device_write_buffer(dev, r->vertices, 0, r->data.vertex_count * sizeof(render_vertex),
                                     r->data.vertices);
    if (res == CV_OK)
        res = cv_device_write_buffer(dev, r->materials, 0, r->data.material_count * sizeof(render_material),
                                     r->data.materials);
    if (res == CV_OK)
        res = cv_device_write_buffer(dev, r->lights, 0, (r->data.light_count + 1) * sizeof(render_light),
                                     r->data.lights);
    if (res == CV_OK)
        res = cv_device_write_buffer(dev, r->instances, 0, (r->data.instance_count + 1) * sizeof(uint32_t),
                                     r->data.instance_first);
    if (res == CV_OK)
        res = cv_device_write_buffer(dev, r->uvs, 0, r->data.vertex_count * 2 * sizeof(float), r->data.uvs);
    if (res == CV_OK)
        res = cv_device_write_buffer(dev, r->image_table, 0, r->data.image_table_bytes, r->data.image_table);
    if (res == CV_OK)
        res = cv_device_write_buffer(dev, r->image_pool, 0, r->data.image_texels * sizeof(uint32_t),
                                     r->data.image_pool);
    if (res == CV_OK)
        res = cv_device_write_buffer(dev, r->blue_noise, 0, sizeof(r->blue_noise_ranks), r->blue_noise_ranks);
    if (res == CV_OK)
        res = cv_device_write_accel(dev, r->accel, r->bvh->nodes2, r->bvh->tris);
    for (int p = 0; p < PIPE_COUNT && res == CV_OK; p++)
        if (r->pipelines[p].id) /* render.alpha_continue only for a masked scene */
            res = cv_device_load(dev, cv_any(r->pipelines[p]));
    for (int t = 0; t < TEX_COUNT && res == CV_OK && r->width; t++)
        if (texture_info[t].everywhere)
            res = cv_device_load(dev, cv_any(r->textures[t]));
    cv_rect all = { 0, 0, r->width, r->height };
    if (res == CV_OK && r->width)
        res = cv_transfer_texture(r->devices[0], r->textures[TEX_POSITION], all, dev, r->textures[TEX_POSITION], 0, 0,
                                  NULL);
    if (res == CV_OK && r->width)
        res = cv_transfer_texture(r->devices[0], r->textures[TEX_NORMAL], all, dev, r->textures[TEX_NORMAL], 0, 0,
                                  NULL);
    if (res == CV_OK && r->width)
        res = cv_transfer_texture(r->devices[0], r->textures[TEX_MATERIAL], all, dev, r->textures[TEX_MATERIAL], 0, 0,
                                  NULL);
    return res;
}

cv_result cv_renderer_add_device(cv_renderer *r, cv_device *dev) {
    if (!r || !dev)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_renderer_add_device: NULL argument");
    if (cv_device_context(dev) != r->ctx)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "renderer: device '%s' belongs to another context",
                        cv_device_label(dev));
    for (uint32_t d = 0; d < r->count; d++)
        if (r->devices[d] == dev)
            return cv_error(CV_ERROR_ALREADY_EXISTS, "renderer: device '%s' is already device %u",
                            cv_device_label(dev), d);
    if (r->count == CV_MAX_DEVICES)
        return cv_error(CV_ERROR_LIMIT_EXCEEDED, "renderer: %u devices already (at most %u)", r->count,
                        CV_MAX_DEVICES);
    if (cv_device_is_lost(dev))
        return cv_error(CV_ERROR_DEVICE_LOST, "renderer: device '%s' is lost", cv_device_label(dev));
    uint64_t range = cv_device_get_info(dev)->max_storage_buffer_range;
    if (r->data.vertex_count * sizeof(render_vertex) > range || r->data.image_texels * sizeof(uint32_t) > range ||
        (r->graph && r->graph_rays * CV_RAY_BYTES > range))
        return cv_error(CV_ERROR_LIMIT_EXCEEDED,
                        "renderer: device '%s''s storage buffer range of %llu bytes is too small for this scene "
                        "and image",
                        cv_device_label(dev), (unsigned long long)range);
    cv_result res = join_device(r, dev);
    if (res != CV_OK) { /* nothing stays loaded on it */
        char why[1024];
        snprintf(why, sizeof(why), "%s", cv_last_error());
        cv_handle all[SCENE_HANDLES + PIPE_COUNT + TEX_COUNT];
        scene_handles(r, all);
        for (int p = 0; p < PIPE_COUNT; p++)
            all[SCENE_HANDLES + p] = cv_any(r->pipelines[p]);
        for (int t = 0; t < TEX_COUNT; t++)
            all[SCENE_HANDLES + PIPE_COUNT + t] = cv_any(r->textures[t]);
        for (size_t i = 0; i < sizeof(all) / sizeof(all[0]); i++)
            if (all[i].id && cv_device_has(dev, all[i]))
                cv_device_unload(dev, all[i]);
        return cv_error(res, "renderer: adding device '%s': %s", cv_device_label(dev), why);
    }
    if (range / CV_RAY_BYTES < r->band_limit)
        r->band_limit = range / CV_RAY_BYTES;
    r->devices[r->count++] = dev;
    if (r->graph) { /* the next frame runs on the new set (a new graph: the balancer starts even) */
        uint32_t iterations = r->graph_iterations;
        uint64_t rays = r->graph_rays;
        destroy_graph(r);
        res = build_graph(r, iterations, rays);
    }
    return res;
}

cv_result cv_renderer_render(cv_renderer *r, const cv_render_settings *settings, cv_render_output *out,
                             cv_render_stats *stats, void (*progress)(uint32_t, uint32_t, void *), void *user) {
    if (!r || !out)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_renderer_render: NULL argument");
    cv_render_settings s = cv_render_settings_resolve(settings, r->scene);
    cv_result res = cv_render_settings_check(&s);
    if (res == CV_OK)
        res = cv_render_camera_check(&s, r->scene);
    if (res != CV_OK)
        return res;
    render_sun_direction(&s, r->data.sun_direction, r->sun_direction);
    r->settings = s;
    r->graph_frames = s.frames;
    res = ensure_targets(r, s.width, s.height, s.reflections == 1 ? s.reflection_samples : 1);
    if (res == CV_OK)
        res = build_graph(r, (uint32_t)s.filter_iterations, band_capacity(r, &s));
    /* Several devices, a new graph: its first frame baked once before the
     * clock starts. The bake makes the transfer rings of the pairs it copies
     * between (graph.h, cv_graph_stats.rings), and making one costs time in
     * proportion to its memory (host-import pins and imports it: ~85 ms a
     * ring on the H200), so the first frames do not pay for them. */
    double setup_start = now_ms();
    bool setup = res == CV_OK && r->count > 1 && !r->graph_prebaked;
    if (setup) {
        r->frame = 0;
        res = enable_passes(r, true, s.frames == 1);
        if (res == CV_OK)
            res = cv_graph_bake(r->graph, &(cv_graph_bake_desc){ .width = r->width, .tile = s.tile });
        r->graph_prebaked = res == CV_OK;
    }
    if (res != CV_OK)
        return res;
    cv_render_stats st = { .device_count = r->count,
                           .frames = s.frames,
                           .upload_ms = r->upload_ms,
                           .setup_ms = setup ? now_ms() - setup_start : 0.0 };
    cv_graph_timing timings[64];
    double frames_start = now_ms();
    uint64_t accumulated[IN_FLIGHT_FRAMES] = { 0 }; /* the primary's last ticket of recent frames */
    /* Several devices: frames submitted but not collected yet, and their partitions (by f % CV_GRAPH_FRAMES_KEPT). */
    uint64_t uncollected[CV_GRAPH_FRAMES_KEPT] = { 0 };
    cv_partition parts[CV_GRAPH_FRAMES_KEPT];
    /* Frames are pipelined on any number of devices: up to IN_FLIGHT_FRAMES
     * submitted ahead, so a remote device's latency hides behind the work of
     * the frames before, and transfers between local devices are queued on
     * the GPUs (graph.h). With several devices the "last frame" whose trace
     * times the balancer splits from is the one CV_GRAPH_FRAMES_KEPT - 1 back
     * (collect_frames: lagged feedback; that frame has usually finished, so
     * collecting it rarely waits), which bounds the frames in flight to
     * CV_GRAPH_FRAMES_KEPT. The last frame collects every frame still pending,
     * then executes. */
    uint32_t generation = r->graph_generation;
    for (uint32_t f = 0; f < s.frames && res == CV_OK; f++) {
        bool last = f + 1 == s.frames;
        r->frame = f;
        if (r->graph_generation != generation) { /* cv_renderer_add_device from the progress callback */
            generation = r->graph_generation;
            memset(uncollected, 0, sizeof(uncollected)); /* the old graph's frames went with it */
            st.device_count = r->count;
        }
        r->camera = cv_render_camera(&s, r->scene, s.first_frame + f);
        r->previous_camera = cv_render_camera(&s, r->scene, s.first_frame + f - (s.first_frame + f > 0));
        res = enable_passes(r, f == 0, last);
        /* The graph's balancer splits the columns from the last frame's trace times. */
        if (res == CV_OK)
            res = collect_frames(r, &st, timings, uncollected, parts, f, last);
        if (res == CV_OK)
            res = cv_graph_bake(r->graph, &(cv_graph_bake_desc){ .width = r->width, .tile = s.tile });
        cv_partition part;
        if (res == CV_OK)
            res = cv_graph_get_partition(r->graph, &part);
        /* An observer wants every frame's timings: the frame ends here (no
         * pipelining); otherwise only the last frame waits. */
        bool wait_now = last || (s.observer && s.observer->frame);
        uint32_t n = 0;
        double submitted = now_ms();
        if (res == CV_OK && wait_now) {
            res = cv_graph_execute(r->graph, timings, 64, &n);
        } else if (res == CV_OK) {
            uint64_t tickets[CV_MAX_DEVICES];
            res = cv_graph_submit(r->graph, tickets);
            accumulated[f % IN_FLIGHT_FRAMES] = tickets[0];
            if (res == CV_OK && r->count > 1) {
                uncollected[f % CV_GRAPH_FRAMES_KEPT] = cv_graph_frame_id(r->graph);
                parts[f % CV_GRAPH_FRAMES_KEPT] = part;
            }
            if (res == CV_OK && f + 1 >= IN_FLIGHT_FRAMES && accumulated[(f + 1) % IN_FLIGHT_FRAMES])
                res = cv_device_wait(r->devices[0], accumulated[(f + 1) % IN_FLIGHT_FRAMES], UINT64_MAX);
        }
        uint32_t dropped = res != CV_OK ? drop_lost_devices(r) : 0;
        if (dropped) {
            st.devices_lost += dropped;
            st.device_count = r->count;
            memset(st.devices, 0, sizeof(st.devices));
            memset(uncollected, 0, sizeof(uncollected)); /* a new graph: the old one's frames are gone */
            res = build_graph(r, (uint32_t)s.filter_iterations, band_capacity(r, &s));
            if (res == CV_OK) {
                f--; /* this frame again, on the survivors (f wraps to the loop's f++ at 0) */
                continue;
            }
        }
        double frame_wall = now_ms() - submitted;
        if (res == CV_OK && wait_now)
            add_frame_timings(r, &st, timings, n, &part, frame_wall);
        if (res == CV_OK && wait_now)
            render_observe_frame(&(render_frame_report){ r->devices, r->count, &part, &s, f, r->height, submitted,
                                                         frame_wall, timings, n, 64 });
        for (uint32_t d = 0; d < r->count && res == CV_OK; d++)
            st.rays_total += (uint64_t)part.ranges[d].width * r->height * cv_render_rays_per_pixel(&s);
        if (res == CV_OK && r->graph_reflect)
            st.reflection_rays += 2 * reflect_traced_pixels(r, &s, s.first_frame + f) * s.reflection_samples;
        if (res == CV_OK && r->alpha_mask) /* the rounds run over every ray slot of every band */
            st.alpha_rays +=
                (uint64_t)r->width * r->height *
                (cv_render_rays_per_pixel(&s) * alpha_retraces(true) +
                 (r->graph_reflect ? (alpha_retraces(false) + alpha_retraces(true)) * s.reflection_samples : 0));
        if (res == CV_OK && progress)
            progress(f + 1, s.frames, user);
    }
    st.frame_ms = (now_ms() - frames_start) / s.frames;
    if (res == CV_OK)
        res = read_output(r, (uint32_t)s.filter_iterations, s.frames, out);
    if (res == CV_OK && stats)
        *stats = st;
    return res;
}
