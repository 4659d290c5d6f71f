/* One job's render on its devices, and its images: the frames one at a
 * time (so a cancel is seen between frames and the progress is exact), then
 * the radiance tone-mapped to a PNG (ACES, the settings' exposure, as
 * corvid-render writes it) and the planes as an EXR (beauty RGBA as float, bit
 * for bit the renderer's radiance; albedo, normal and depth layers), both
 * written through private temporary files into memory. */
#ifndef CORVID_GATEWAY_JOB_RENDER_H
#define CORVID_GATEWAY_JOB_RENDER_H

#include <stdatomic.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "corvid/gateway_types.h"
#include "corvid/renderer.h"

typedef struct gw_render_input {
    const cv_scene *scene;
    const cv_bvh *bvh;
    cv_render_settings settings; /* checked */
    const cv_gateway_devices *devices;
    const atomic_bool *cancel; /* seen before each frame */
    void (*progress)(uint32_t frames_done, void *user);
    void *user;
    const char *temp_dir;
} gw_render_input;

typedef struct gw_render_result {
    bool cancelled; /* stopped before its last frame: no images */
    uint8_t *png, *exr;
    size_t png_size, exr_size;
} gw_render_result;

/* Fills *out (free it with gw_render_result_free); an error names the frame ("frame 3: ..."). */
cv_result gw_render_run(const gw_render_input *in, gw_render_result *out);
void gw_render_result_free(gw_render_result *r);

/* Destroys a job's devices (in reverse), then its context; zeroes *d. */
void gw_devices_close(cv_gateway_devices *d);

#endif
