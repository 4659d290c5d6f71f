/* Devices joining and leaving a renderer (device_join.h). */
#include "device_join.h"

#include <stdio.h>

#include "corvid/transfer.h"
#include "frame_graph.h"

/* A secondary device that is gone for good (its node died or disconnected)
 * leaves the renderer: the frame graph is rebuilt for the others, and the
 * frame it failed in is traced again by the survivors. Every pixel's rays
 * depend only on the pixel and the frame, so the image is the same as if the
 * device had never been there. The primary holds the image: without it there
 * is no frame. Returns how many devices were dropped. */
uint32_t render_devices_drop_lost(cv_render_frame *f) {
    if (f->count < 2 || cv_device_is_lost(f->devices[0]))
        return 0;
    uint32_t kept = 1;
    for (uint32_t d = 1; d < f->count; d++)
        if (!cv_device_is_lost(f->devices[d]))
            f->devices[kept++] = f->devices[d];
    uint32_t dropped = f->count - kept;
    if (dropped) {
        f->count = kept;
        render_graph_destroy(f);
    }
    return dropped;
}

/* What a device added later needs: the scene (buffers, BVH), the pipelines, the
 * textures every device holds and, once rendered, the G-buffer (the first frame
 * multicasts it; later frames do not render it again). */
static cv_result join_device(cv_render_frame *f, cv_device *dev) {
    cv_handle scene[RENDER_SCENE_HANDLES];
    render_frame_scene_handles(f, scene);
    cv_result res = CV_OK;
    for (int i = 0; i < RENDER_SCENE_HANDLES && res == CV_OK; i++)
        res = cv_device_load(dev, scene[i]);
    if (res == CV_OK)
        res = cv_device_write_buffer(dev, f->vertices, 0, f->data.vertex_count * sizeof(render_vertex),
                                     f->data.vertices);
    if (res == CV_OK)
        res = cv_device_write_buffer(dev, f->materials, 0, f->data.material_count * sizeof(render_material),
                                     f->data.materials);
    if (res == CV_OK)
        res = cv_device_write_buffer(dev, f->lights, 0, (f->data.light_count + 1) * sizeof(render_light),
                                     f->data.lights);
    if (res == CV_OK)
        res = cv_device_write_buffer(dev, f->instances, 0, (f->data.instance_count + 1) * sizeof(uint32_t),
                                     f->data.instance_first);
    if (res == CV_OK)
        res = cv_device_write_buffer(dev, f->uvs, 0, f->data.vertex_count * 2 * sizeof(float), f->data.uvs);
    if (res == CV_OK)
        res = cv_device_write_buffer(dev, f->image_table, 0, f->data.image_table_bytes, f->data.image_table);
    if (res == CV_OK)
        res = cv_device_write_buffer(dev, f->image_pool, 0, f->data.image_texels * sizeof(uint32_t),
                                     f->data.image_pool);
    if (res == CV_OK)
        res = cv_device_write_buffer(dev, f->blue_noise, 0, sizeof(f->blue_noise_ranks), f->blue_noise_ranks);
    if (res == CV_OK)
        res = cv_device_write_accel(dev, f->accel, f->bvh->nodes2, f->bvh->tris);
    for (int p = 0; p < PIPE_COUNT && res == CV_OK; p++)
        if (f->pipelines[p].id) /* render.alpha_continue only for a masked scene */
            res = cv_device_load(dev, cv_any(f->pipelines[p]));
    for (int t = 0; t < TEX_COUNT && res == CV_OK && f->width; t++)
        if (render_textures[t].everywhere)
            res = cv_device_load(dev, cv_any(f->textures[t]));
    cv_rect all = { 0, 0, f->width, f->height };
    if (res == CV_OK && f->width)
        res = cv_transfer_texture(f->devices[0], f->textures[TEX_POSITION], all, dev, f->textures[TEX_POSITION], 0, 0,
                                  NULL);
    if (res == CV_OK && f->width)
        res = cv_transfer_texture(f->devices[0], f->textures[TEX_NORMAL], all, dev, f->textures[TEX_NORMAL], 0, 0,
                                  NULL);
    if (res == CV_OK && f->width)
        res = cv_transfer_texture(f->devices[0], f->textures[TEX_MATERIAL], all, dev, f->textures[TEX_MATERIAL], 0, 0,
                                  NULL);
    return res;
}

cv_result render_devices_add(cv_render_frame *f, cv_device *dev) {
    if (cv_device_context(dev) != f->ctx)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "renderer: device '%s' belongs to another context",
                        cv_device_label(dev));
    for (uint32_t d = 0; d < f->count; d++)
        if (f->devices[d] == dev)
            return cv_error(CV_ERROR_ALREADY_EXISTS, "renderer: device '%s' is already device %u",
                            cv_device_label(dev), d);
    if (f->count == CV_MAX_DEVICES)
        return cv_error(CV_ERROR_LIMIT_EXCEEDED, "renderer: %u devices already (at most %u)", f->count,
                        CV_MAX_DEVICES);
    if (cv_device_is_lost(dev))
        return cv_error(CV_ERROR_DEVICE_LOST, "renderer: device '%s' is lost", cv_device_label(dev));
    uint64_t range = cv_device_get_info(dev)->max_storage_buffer_range;
    if (f->data.vertex_count * sizeof(render_vertex) > range || f->data.image_texels * sizeof(uint32_t) > range ||
        (f->graph && f->graph_rays * CV_RAY_BYTES > range))
        return cv_error(CV_ERROR_LIMIT_EXCEEDED,
                        "renderer: device '%s''s storage buffer range of %llu bytes is too small for this scene "
                        "and image",
                        cv_device_label(dev), (unsigned long long)range);
    cv_result res = join_device(f, dev);
    if (res != CV_OK) { /* nothing stays loaded on it */
        char why[1024];
        snprintf(why, sizeof(why), "%s", cv_last_error());
        cv_handle all[RENDER_SCENE_HANDLES + PIPE_COUNT + TEX_COUNT];
        render_frame_scene_handles(f, all);
        for (int p = 0; p < PIPE_COUNT; p++)
            all[RENDER_SCENE_HANDLES + p] = cv_any(f->pipelines[p]);
        for (int t = 0; t < TEX_COUNT; t++)
            all[RENDER_SCENE_HANDLES + PIPE_COUNT + t] = cv_any(f->textures[t]);
        for (size_t i = 0; i < sizeof(all) / sizeof(all[0]); i++)
            if (all[i].id && cv_device_has(dev, all[i]))
                cv_device_unload(dev, all[i]);
        return cv_error(res, "renderer: adding device '%s': %s", cv_device_label(dev), why);
    }
    if (range / CV_RAY_BYTES < f->band_limit)
        f->band_limit = range / CV_RAY_BYTES;
    f->devices[f->count++] = dev;
    if (f->graph) /* the next frame runs on the new set (a new graph: the balancer starts even) */
        res = render_graph_rebuild(f);
    return res;
}
