/* Reading the frame back from the primary (readback.h). */
#include "readback.h"

#include <stdlib.h>
#include <string.h>

#include "output_derive.h"
#include "passes/passes.h"

cv_result render_read_output(const cv_render_frame *f, uint32_t frames, cv_render_output *out) {
    uint32_t iterations = f->info.filter_iterations;
    size_t n = (size_t)f->width * f->height * 4;
    memset(out, 0, sizeof(*out));
    out->width = f->width;
    out->height = f->height;
    float **planes[5] = { &out->radiance, &out->albedo, &out->normal, &out->position, &out->visibility };
    for (int i = 0; i < 5; i++)
        if (!(*planes[i] = malloc(n * sizeof(float)))) {
            cv_render_output_free(out);
            return cv_error(CV_ERROR_OUT_OF_MEMORY, "renderer: output planes");
        }
    cv_device *p = f->devices[0];
    cv_rect all = { 0, 0, f->width, f->height };
    cv_result res = cv_device_read_texture(p, f->textures[TEX_RADIANCE], all, out->radiance);
    if (res == CV_OK)
        res = cv_device_read_texture(p, f->textures[TEX_ALBEDO], all, out->albedo);
    if (res == CV_OK)
        res = cv_device_read_texture(p, f->textures[TEX_NORMAL], all, out->normal);
    if (res == CV_OK)
        res = cv_device_read_texture(p, f->textures[TEX_POSITION], all, out->position);
    /* The G-buffer's w packs the geometric normal (render_gbuffer.frag); the output says 1. */
    for (size_t i = 3; res == CV_OK && i < n; i += 4)
        out->position[i] = out->position[i] != 0.0f ? 1.0f : 0.0f;
    if (res == CV_OK)
        res = cv_device_read_texture(p, f->textures[render_filtered_texture(iterations)], all, out->visibility);
    if (res == CV_OK && !(out->motion = malloc(n * sizeof(float))))
        res = cv_error(CV_ERROR_OUT_OF_MEMORY, "renderer: motion plane");
    if (res == CV_OK && f->info.moving) {
        res = cv_device_read_texture(p, f->textures[TEX_MOTION], all, out->motion);
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
        render_scene_data lit = f->data;
        memcpy(lit.sun_direction, f->sun_direction, sizeof(lit.sun_direction));
        res = render_output_derive(out, f->camera.position, &lit);
    }
    if (res == CV_OK && f->info.reflections) {
        out->reflection = malloc(n * sizeof(float));
        res = out->reflection
                  ? cv_device_read_texture(p, f->textures[render_reflect_shown_texture()], all, out->reflection)
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
