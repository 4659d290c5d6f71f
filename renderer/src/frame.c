/* The frame state's lifetime (the scene on the devices, the texture table)
 * and the math and recording helpers the passes share (frame.h). */
#include "frame.h"

#include <math.h>
#include <string.h>

#include "camera.h"

static const char *const pipeline_names[PIPE_COUNT] = {
    "render.gbuffer",         "render.raygen",         "render.resolve",        "render.accumulate",
    "render.filter",          "render.composite",      "render.reproject",      "render.reflect_raygen",
    "render.reflect_shadow",  "render.reflect_shade",  "render.reflect_filter", "render.reflect_reproject",
    "render.reflect_denoise", "render.alpha_continue", "render.present",
};

const render_texture_info render_textures[TEX_COUNT] = {
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
    [TEX_DISPLAY] = { CV_FORMAT_RGBA8_UNORM, CV_TEXTURE_USAGE_STORAGE, false, "display 0" },
    [TEX_DISPLAY + 1] = { CV_FORMAT_RGBA8_UNORM, CV_TEXTURE_USAGE_STORAGE, false, "display 1" },
    [TEX_DISPLAY + 2] = { CV_FORMAT_RGBA8_UNORM, CV_TEXTURE_USAGE_STORAGE, false, "display 2" },
};
_Static_assert(RENDER_DISPLAY_SLOTS == 3, "render_textures names one display image per slot");

static cv_result load_everywhere(cv_render_frame *f, cv_handle h) {
    for (uint32_t d = 0; d < f->count; d++) {
        cv_result res = cv_device_load(f->devices[d], h);
        if (res != CV_OK)
            return res;
    }
    return CV_OK;
}

static cv_result upload_buffer(cv_render_frame *f, const void *data, uint64_t size, const char *label,
                               cv_buffer *out) {
    cv_buffer_desc desc = { .size = size, .usage = CV_BUFFER_USAGE_STORAGE };
    strncpy(desc.label, label, sizeof(desc.label) - 1);
    cv_result res = cv_buffer_create(f->ctx, &desc, out);
    if (res == CV_OK)
        res = load_everywhere(f, cv_any(*out));
    for (uint32_t d = 0; d < f->count && res == CV_OK; d++)
        res = cv_device_write_buffer(f->devices[d], *out, 0, size, data);
    return res;
}

/* Whether a buffer of `bytes` fits every device's storage buffer range; the
 * message names the first device it does not fit, and ends with `hint`. */
static cv_result fits_storage_range(const cv_render_frame *f, uint64_t bytes, const char *what, const char *hint) {
    for (uint32_t d = 0; d < f->count; d++) {
        uint64_t range = cv_device_get_info(f->devices[d])->max_storage_buffer_range;
        if (bytes > range)
            return cv_error(CV_ERROR_LIMIT_EXCEEDED,
                            "renderer: %llu bytes of %s exceed device '%s''s storage buffer range of %llu bytes%s",
                            (unsigned long long)bytes, what, cv_device_label(f->devices[d]),
                            (unsigned long long)range, hint);
    }
    return CV_OK;
}

cv_result render_frame_upload_scene(cv_render_frame *f) {
    const cv_scene *scene = f->scene;
    const cv_bvh *bvh = f->bvh;
    cv_device *const *devices = f->devices;
    uint32_t device_count = f->count;
    cv_result res = render_scene_data_build(scene, &f->data);
    uint64_t vertex_bytes = f->data.vertex_count * sizeof(render_vertex);
    if (res == CV_OK)
        res = fits_storage_range(f, vertex_bytes, "vertices", "; use a smaller scene");
    if (res == CV_OK)
        res = upload_buffer(f, f->data.vertices, vertex_bytes, "scene vertices", &f->vertices);
    if (res == CV_OK)
        res = upload_buffer(f, f->data.materials, f->data.material_count * sizeof(render_material), "materials",
                            &f->materials);
    if (res == CV_OK)
        res = upload_buffer(f, f->data.lights, (f->data.light_count + 1) * sizeof(render_light), "point lights",
                            &f->lights);
    uint64_t pool_bytes = f->data.image_texels * sizeof(uint32_t);
    if (res == CV_OK)
        res = fits_storage_range(f, pool_bytes, "texture images", "");
    if (res == CV_OK)
        res = upload_buffer(f, f->data.uvs, f->data.vertex_count * 2 * sizeof(float), "scene uvs", &f->uvs);
    if (res == CV_OK)
        res = upload_buffer(f, f->data.image_table, f->data.image_table_bytes, "image table", &f->image_table);
    if (res == CV_OK)
        res = upload_buffer(f, f->data.image_pool, pool_bytes, "image pool", &f->image_pool);
    if (res == CV_OK)
        res = upload_buffer(f, f->data.instance_first, (f->data.instance_count + 1) * sizeof(uint32_t),
                            "instance first triangles", &f->instances);
    if (res == CV_OK) {
        cv_blue_noise_ranks(f->blue_noise_ranks);
        res = upload_buffer(f, f->blue_noise_ranks, sizeof(f->blue_noise_ranks), "blue noise", &f->blue_noise);
    }
    /* Immutable scene data goes to every device once (the multicast rule). */
    if (res == CV_OK)
        res = cv_accel_create(f->ctx,
                              &(cv_accel_desc){ .triangle_count = bvh->tri_count,
                                                .node_count = bvh->node2_count,
                                                .label = "scene" },
                              &f->accel);
    if (res == CV_OK)
        res = load_everywhere(f, cv_any(f->accel));
    for (uint32_t d = 0; d < device_count && res == CV_OK; d++)
        res = cv_device_write_accel(devices[d], f->accel, bvh->nodes2, bvh->tris);
    f->alpha_mask = render_scene_alpha_masked(&f->data);
    for (int p = 0; p < PIPE_COUNT && res == CV_OK; p++) {
        if (p == PIPE_ALPHA_CONTINUE && !f->alpha_mask)
            continue;
        res = cv_pipeline_create(f->ctx, pipeline_names[p], &f->pipelines[p]);
        if (res == CV_OK)
            res = load_everywhere(f, cv_any(f->pipelines[p]));
    }
    uint64_t limit = UINT64_MAX;
    for (uint32_t d = 0; d < device_count; d++)
        if (cv_device_get_info(devices[d])->max_storage_buffer_range < limit)
            limit = cv_device_get_info(devices[d])->max_storage_buffer_range;
    f->band_limit = limit / CV_RAY_BYTES;
    return res;
}

static void destroy_handle(cv_render_frame *f, uint64_t id) {
    if (id)
        cv_destroy(f->ctx, (cv_handle){ id });
}

void render_frame_scene_handles(const cv_render_frame *f, cv_handle out[RENDER_SCENE_HANDLES]) {
    const cv_handle all[RENDER_SCENE_HANDLES] = {
        cv_any(f->vertices),    cv_any(f->materials),  cv_any(f->lights),
        cv_any(f->accel),       cv_any(f->instances),  cv_any(f->uvs),
        cv_any(f->image_table), cv_any(f->image_pool), cv_any(f->blue_noise)
    };
    memcpy(out, all, sizeof(all));
}

static void destroy_targets(cv_render_frame *f) {
    cv_graph_destroy(f->graph);
    f->graph = NULL;
    f->graph_prebaked = false;
    for (int t = 0; t < TEX_COUNT; t++)
        destroy_handle(f, f->textures[t].id);
    memset(f->textures, 0, sizeof(f->textures));
    f->width = f->height = f->reflect_layers = 0;
}

void render_frame_release(cv_render_frame *f) {
    destroy_targets(f);
    cv_handle scene[RENDER_SCENE_HANDLES];
    render_frame_scene_handles(f, scene);
    for (int i = 0; i < RENDER_SCENE_HANDLES; i++)
        destroy_handle(f, scene[i].id);
    for (int p = 0; p < PIPE_COUNT; p++)
        destroy_handle(f, f->pipelines[p].id);
    render_scene_data_free(&f->data);
}

cv_result render_frame_ensure_targets(cv_render_frame *f, uint32_t width, uint32_t height, uint32_t layers) {
    if (f->width == width && f->height == height && f->reflect_layers == layers)
        return CV_OK;
    destroy_targets(f);
    cv_result res = CV_OK;
    for (int t = 0; t < TEX_COUNT && res == CV_OK; t++) {
        cv_texture_desc desc = { .width = width,
                                 .height = t == TEX_REFLECT ? height * layers : height,
                                 .format = render_textures[t].format,
                                 .usage = render_textures[t].usage };
        strncpy(desc.label, render_textures[t].label, sizeof(desc.label) - 1);
        res = cv_texture_create(f->ctx, &desc, &f->textures[t]);
        if (res == CV_OK)
            res = render_textures[t].everywhere ? load_everywhere(f, cv_any(f->textures[t]))
                                                : cv_device_load(f->devices[0], cv_any(f->textures[t]));
    }
    if (res == CV_OK) {
        f->width = width;
        f->height = height;
        f->reflect_layers = layers;
    }
    return res;
}

uint64_t render_band_rays(const cv_render_frame *f, const cv_render_settings *s) {
    return f->band_limit < s->band_rays ? f->band_limit : s->band_rays;
}

uint32_t render_band_rows(const cv_render_frame *f, const cv_render_settings *s, uint32_t width) {
    uint64_t rows = render_band_rays(f, s) / ((uint64_t)width * cv_render_rays_per_pixel(s));
    if (rows == 0)
        rows = 1;
    return rows < f->height ? (uint32_t)rows : f->height;
}

uint64_t render_band_capacity(const cv_render_frame *f, const cv_render_settings *s) {
    uint64_t per_pixel = cv_render_rays_per_pixel(s), row = (uint64_t)f->width * per_pixel;
    uint64_t image = row * f->height, band = render_band_rays(f, s);
    return row > band ? row : band < image ? band : image;
}

uint64_t render_reflect_capacity(const cv_render_frame *f, const cv_render_settings *s) {
    uint64_t band = render_band_rays(f, s) / 2, image = (uint64_t)f->width * f->height;
    if (band < f->width)
        band = f->width;
    return band < image ? band : image;
}

uint64_t render_reflect_traced_pixels(const cv_render_frame *f, const cv_render_settings *s, uint32_t frame) {
    if (s->reflection_scale >= 1.0f)
        return (uint64_t)f->width * f->height;
    uint32_t x0 = frame % 4 & 1, y0 = frame % 4 >> 1;
    return (uint64_t)((f->width - x0 + 1) / 2) * ((f->height - y0 + 1) / 2);
}

void render_view_proj(const cv_render_frame *f, const cv_camera *camera, float out[16], float *far_plane) {
    float near_plane = f->data.diagonal * 1e-4f;
    *far_plane = f->data.diagonal * 4.0f;
    render_camera_view_proj(camera, (float)f->width / (float)f->height, near_plane, *far_plane, out);
}

float render_pixel_angle(const cv_render_frame *f) {
    return 2.0f * tanf(0.5f * f->camera.vertical_fov) / (float)f->height;
}

void render_dispatch_pixels(const cv_render_frame *f, cv_command_list *l, cv_queue_type queue, int pipeline,
                            const cv_binding *b, uint32_t count, const void *push, uint32_t push_size, uint32_t width,
                            uint32_t height) {
    cv_cmd_dispatch(l, queue,
                    &(cv_dispatch_args){ .pipeline = f->pipelines[pipeline],
                                         .bindings = b,
                                         .bindings_count = count,
                                         .push = push,
                                         .push_size = push_size,
                                         .groups_x = render_groups(width, 8),
                                         .groups_y = render_groups(height, 8),
                                         .groups_z = 1 });
}

cv_graph_use render_band_buffer(cv_graph_builder *b, const char *label, uint64_t bytes) {
    cv_buffer_desc desc = { .size = bytes };
    strncpy(desc.label, label, sizeof(desc.label) - 1);
    return cv_graph_pass_create_buffer(b, &desc, 0, CV_GRAPH_STORAGE_WRITE, CV_GRAPH_TRANSFER_AUTO, NULL);
}

void render_bind_uses(const cv_graph_pass_context *pc, const cv_graph_use *uses, uint32_t count, cv_binding *b) {
    for (uint32_t i = 0; i < count; i++)
        b[i] = cv_graph_use_binding(pc, uses[i]);
}

void render_dispatch_image(const cv_render_frame *f, cv_command_list *l, cv_queue_type queue, int pipeline,
                           const cv_binding *b, uint32_t count, const void *push, uint32_t push_size) {
    render_dispatch_pixels(f, l, queue, pipeline, b, count, push, push_size, f->width, f->height);
}

const cv_render_frame_view *cv_render_frame_get_view(const cv_render_frame *f) { return &f->info; }

cv_graph_resource cv_render_frame_target(const cv_render_frame *f, cv_render_target t) {
    static const int textures[CV_RENDER_TARGET_COUNT] = { [CV_RENDER_TARGET_RADIANCE] = TEX_RADIANCE,
                                                          [CV_RENDER_TARGET_ALBEDO] = TEX_ALBEDO,
                                                          [CV_RENDER_TARGET_POSITION] = TEX_POSITION,
                                                          [CV_RENDER_TARGET_NORMAL] = TEX_NORMAL };
    return (unsigned)t < CV_RENDER_TARGET_COUNT ? f->tex[textures[t]] : (cv_graph_resource){ 0 };
}

cv_graph *cv_render_frame_graph(const cv_render_frame *f) { return f->graph; }
