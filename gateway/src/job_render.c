/* One job's render and its images (job_render.h). */
#include "job_render.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "corvid/image_exr.h"
#include "corvid/image_png.h"
#include "corvid/tonemap.h"
#include "temp_files.h"

void gw_devices_close(cv_gateway_devices *d) {
    for (uint32_t i = d->count; i-- > 0;)
        cv_device_destroy(d->devices[i]);
    if (d->ctx)
        cv_context_destroy(d->ctx);
    memset(d, 0, sizeof(*d));
}

void gw_render_result_free(gw_render_result *r) {
    free(r->png);
    free(r->exr);
    memset(r, 0, sizeof(*r));
}

/* The PNG and the EXR of a frame, written in a private directory and read back. */
static cv_result encode_images(const cv_render_output *o, float exposure, const char *temp_dir,
                               gw_render_result *out) {
    char dir[GW_PATH_MAX], png[GW_PATH_MAX + 16], exr[GW_PATH_MAX + 16];
    cv_result r = gw_temp_dir_create(temp_dir, dir);
    if (r != CV_OK)
        return r;
    snprintf(png, sizeof(png), "%s/image.png", dir);
    snprintf(exr, sizeof(exr), "%s/image.exr", dir);
    uint8_t *rgb = malloc((size_t)o->width * o->height * 3);
    r = rgb ? CV_OK : cv_error(CV_ERROR_OUT_OF_MEMORY, "image: %ux%u RGB", o->width, o->height);
    if (r == CV_OK)
        r = cv_tonemap_to_srgb8(&(cv_tonemap_desc){ .exposure = exposure, .curve = CV_TONEMAP_ACES }, o->radiance, 4,
                                o->width, o->height, rgb, 3);
    if (r == CV_OK)
        r = cv_png_write(png, o->width, o->height, 3, rgb);
    free(rgb);
    cv_exr_layer layers[4] = {
        { .channel_count = 4, .channels = { "R", "G", "B", "A" }, .type = CV_EXR_FLOAT, .interleaved = o->radiance },
        { .name = "albedo", .channel_count = 3, .channels = { "R", "G", "B" }, .type = CV_EXR_HALF },
        { .name = "normal", .channel_count = 3, .channels = { "X", "Y", "Z" }, .type = CV_EXR_FLOAT },
        { .name = "depth", .channel_count = 1, .channels = { "Z" }, .type = CV_EXR_FLOAT, .planes = { o->depth } },
    };
    uint32_t layer_count = 1;
    float *planes = NULL;
    if (r == CV_OK && o->albedo && o->normal) {
        /* The 4-float pixels of albedo and normal as planes of their first three channels. */
        size_t n = (size_t)o->width * o->height;
        planes = malloc(n * 6 * sizeof(float));
        r = planes ? CV_OK : cv_error(CV_ERROR_OUT_OF_MEMORY, "image: EXR planes");
        for (size_t i = 0; planes && i < n; i++)
            for (int c = 0; c < 3; c++) {
                planes[c * n + i] = o->albedo[i * 4 + c];
                planes[(3 + c) * n + i] = o->normal[i * 4 + c];
            }
        for (int c = 0; planes && c < 3; c++) {
            layers[1].planes[c] = planes + c * n;
            layers[2].planes[c] = planes + (3 + c) * n;
        }
        layer_count = planes ? (o->depth ? 4 : 3) : 1;
    }
    if (r == CV_OK)
        r = cv_exr_write(exr, &(cv_exr_desc){ .width = o->width,
                                              .height = o->height,
                                              .compression = CV_EXR_ZIP,
                                              .layer_count = layer_count,
                                              .layers = layers });
    free(planes);
    if (r == CV_OK)
        r = gw_file_read(png, &out->png, &out->png_size);
    if (r == CV_OK)
        r = gw_file_read(exr, &out->exr, &out->exr_size);
    gw_temp_dir_remove(dir);
    if (r != CV_OK)
        gw_render_result_free(out);
    return r;
}

/* How long one frame may take on the GPU before the job gives up on its device. */
#define FRAME_WAIT_NS (300ull * 1000000000ull)

/* The frames, one step each, seeing a cancel between them; the last one's planes into *o. */
static cv_result render_frames(const gw_render_input *in, cv_renderer *renderer, cv_render_output *o,
                               bool *cancelled) {
    cv_device *primary = in->devices->devices[0];
    for (uint32_t k = 0; k < in->settings.frames; k++) {
        if (atomic_load(in->cancel)) {
            *cancelled = true;
            return CV_OK;
        }
        cv_render_step step;
        cv_result r = cv_renderer_step(renderer, &in->settings, &step);
        if (r == CV_OK)
            r = cv_device_wait(primary, step.ticket, FRAME_WAIT_NS);
        if (r != CV_OK)
            return cv_error(r, "frame %u: %s", k + 1, cv_last_error());
        if (in->progress)
            in->progress(k + 1, in->user);
    }
    cv_result r = cv_renderer_read_output(renderer, o);
    return r == CV_OK ? CV_OK : cv_error(r, "reading the image: %s", cv_last_error());
}

cv_result gw_render_run(const gw_render_input *in, gw_render_result *out) {
    memset(out, 0, sizeof(*out));
    cv_renderer *renderer = NULL;
    cv_render_output o = { 0 };
    cv_result r = cv_renderer_create(in->devices->devices, in->devices->count, in->scene, in->bvh, &renderer);
    if (r != CV_OK)
        r = cv_error(r, "renderer: %s", cv_last_error());
    if (r == CV_OK)
        r = render_frames(in, renderer, &o, &out->cancelled);
    /* Destroying a renderer on a lost device may record errors of its own: keep the frame's. */
    char error[CV_ERROR_MESSAGE_MAX];
    snprintf(error, sizeof(error), "%s", r == CV_OK ? "" : cv_last_error());
    cv_renderer_destroy(renderer);
    if (r != CV_OK)
        r = cv_error(r, "%s", error);
    if (r == CV_OK && !out->cancelled)
        r = encode_images(&o, in->settings.exposure, in->temp_dir, out);
    cv_render_output_free(&o);
    return r;
}
