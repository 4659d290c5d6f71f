/* What a render gives back: the frame as planes of floats (cv_render_output,
 * filled by cv_renderer_render and cv_render_reference, corvid/renderer.h)
 * and its figures (cv_render_stats). A header of its own, below renderer.h,
 * so that the renderer's modules that fill them (readback, output_derive,
 * frame_stats) need not include the renderer's whole interface.
 *
 *     cv_render_output out = { 0 };
 *     cv_render_stats stats;
 *     if (cv_renderer_render(r, &settings, &out, &stats, NULL, NULL) == CV_OK)
 *         write_exr(out.width, out.height, out.radiance);
 *     cv_render_output_free(&out);
 */
#ifndef CORVID_RENDER_OUTPUT_H
#define CORVID_RENDER_OUTPUT_H

#include <stdint.h>

#include "corvid/device.h"
#include "corvid/partition.h"

/* Per-device figures of the last frame. */
typedef struct cv_render_device_stats {
    cv_column_range columns;
    uint64_t rays;
    double trace_ms; /* GPU (or CPU, on lavapipe) time of raygen+trace+resolve */
    double ms_per_column;
} cv_render_device_stats;

typedef struct cv_render_stats {
    uint32_t device_count;
    uint32_t frames;
    cv_render_device_stats devices[CV_MAX_DEVICES];
    uint64_t rays_total; /* over all frames: shadow and AO rays, (shadow_samples + ao_samples) per pixel per frame */
    /* Over all frames, not in rays_total: reflection rays and the shadow ray from each one's hit, two per
     * reflection sample per traced pixel per frame (every pixel; at reflection_scale 0.5 the pixels of the
     * frame's slot of each 2x2 quad). As rays_total, it counts every pixel's rays, sky pixels' and lost samples' included. */
    uint64_t reflection_rays;
    /* Over all frames: ray slots of the alpha-mask re-traces (renderer.h's rule), every ray of a band
     * per round, retired or not; 0 for a scene without alpha-masked materials (no round runs). */
    uint64_t alpha_rays;
    uint32_t devices_lost;   /* secondaries that died during the render; their columns went to the others */
    uint64_t transfer_bytes; /* over all frames, between devices */
    double transfer_ms;
    double upload_ms; /* scene upload to all devices */
    double frame_ms;  /* wall time per frame, mean */
    double setup_ms;  /* several devices, a new graph: its first bake before the frames (transfer rings) */
} cv_render_stats;

/* The frame as planes of RGBA floats (width * height * 4 each; depth: 1 per pixel). */
typedef struct cv_render_output {
    uint32_t width, height;
    float *radiance; /* linear HDR; alpha 1 on geometry, 0 on sky */
    float *albedo;
    float *normal;     /* xyz, w = material index */
    float *position;   /* world position, w = 1 on geometry */
    float *visibility; /* r = sun visibility, g = ambient occlusion (filtered; accumulated in
                                 * float32), b, a = their mean squares over the frames (unfiltered) */
    /* Planes added for the EXR's per-pass layers; NULL when not produced. */
    float *depth;      /* ONE float per pixel (width * height): distance from the camera's position to the
                        * visible surface (camera distance, not view-plane depth); +infinity on sky */
    float *direct;     /* direct sun light as the composite adds it (albedo * sun * N.L * sun visibility / pi),
                        * derived on the host from albedo, normal and visibility; alpha 1 on geometry */
    float *motion;     /* NULL unless produced (cv_renderer_render): xy = where the pixel's surface
                        * was in the previous frame's image minus the pixel centre, in pixels (the EXR's motion.X, motion.Y)
                        * (0 for a still camera and on sky), z = the pixel's history length in
                        * frames (this one included), w = 1 where the history was reprojected */
    float *reflection; /* rgb = reflected radiance (GGX sample weight G2 / G1 applied, Fresnel not:
                        * radiance adds F * reflection), a = 1 on geometry; NULL without reflections
                        * (the EXR's reflection.R, G, B) */
} cv_render_output;

/* Frees every plane of *out and zeroes it (a zeroed output is fine). */
void cv_render_output_free(cv_render_output *out);

#endif
