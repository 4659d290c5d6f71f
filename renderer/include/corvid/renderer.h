/* The hybrid renderer: one frame of seed 000's pipeline across N devices.
 *
 *   primary:      G-buffer raster (world position, normal, material index;
 *                 the material at each pixel: base color, roughness,
 *                 emission, metalness, textures evaluated)
 *   primary ->    each device gets the G-buffer columns of its partition
 *   all devices:  ray generation for their columns (sun shadow rays in a cone,
 *                 cosine AO rays), trace_rays (any hit), resolve to visibility;
 *                 reflections: one GGX-sampled ray per pixel (closest hit),
 *                 a shadow ray at each hit, shading of the hit
 *   -> primary:   each device's visibility and reflection columns are copied back
 *   primary:      temporal accumulation (reprojected with motion vectors when
 *                 the camera orbits), edge-avoiding a-trous filter,
 *                 reflection reconstruction (spatial reuse) and accumulation
 *                 (reprojected by the reflected point's and the surface's
 *                 motion when the camera orbits),
 *                 composite (sun + sky light, emission, Fresnel times the
 *                 reflection; metal/roughness materials) to linear HDR
 *
 * Columns are split with partition/ (tile-snapped, rebalanced every frame from
 * each device's measured trace time). Devices are any cv_device: virtual GPUs on
 * lavapipe, real GPUs, or a mix. The scene is uploaded once per device (vertex
 * list and uvs, materials, texture images, BVH as an acceleration structure).
 *
 * Textured materials (glTF metal/roughness, corvid/material_eval.h): the
 * G-buffer evaluates each pixel's material with the footprint of the uv's
 * screen derivatives (trilinear over the mip chain), maps the shading normal
 * by the normal image in the triangle's tangent frame, and discards points
 * the alpha mask cuts away, so the surface behind shows. Reflection hits
 * evaluate the hit's material at its uv at level 0 (no ray-cone level of
 * detail) without the normal image. The alpha-mask rule for secondary rays
 * (shadow, AO, reflection rays and the shadow rays of reflection hits): a ray
 * goes on through the points the alpha mask cuts away (alpha factor x base
 * color image alpha at the hit's uv, level 0, below the cutoff), at most
 * CV_RENDER_ALPHA_LAYERS of them; the next cut point it meets counts as
 * opaque. The generic trace knows nothing of materials, so in a scene with
 * any masked material the renderer continues the rays itself (passes 'trace'
 * and 'reflect', render_alpha_continue.comp): after a trace it reads each
 * hit's material and re-traces a ray whose hit is cut, the same ray with
 * tmin = t + 2e-5 x the scene diagonal (the ray-origin offset: surfaces
 * closer than that behind a cut point are passed with it), closest-hit, front
 * to back; an any-hit ray that stopped at a cut point is re-traced closest-hit
 * from its own tmin first. Rounds run in lockstep over a band's rays (4
 * re-traces for closest-hit rays, 5 for any-hit ones, whatever the hits;
 * cv_render_stats.alpha_rays counts their ray slots); a retired ray is
 * rejected at the BVH root, so they cost far less than as many new rays
 * (docs/renderer-quality.md: +14% frame time for a scene of masked leaves on
 * lavapipe). A scene without masked materials records none of it and renders
 * the same bytes as before the rule. cv_render_reference follows the same rules
 * (camera rays go past every cut point; its other rays by the rule above). */
#ifndef CORVID_RENDERER_H
#define CORVID_RENDERER_H

#include <stdio.h>

#include "corvid/bvh.h"
#include "corvid/device.h"
#include "corvid/partition.h"
#include "corvid/render_observer.h"
#include "corvid/render_settings.h"
#include "corvid/scene.h"

/* Cut points of alpha-masked materials a secondary ray passes (the rule above). */
#define CV_RENDER_ALPHA_LAYERS 4u

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

typedef struct cv_renderer cv_renderer;

/* Uploads the scene to every device (device 0 is the primary). The devices
 * must share one context and outlive the renderer. */
cv_result cv_renderer_create(cv_device *const *devices, uint32_t device_count, const cv_scene *scene,
                             const cv_bvh *bvh, cv_renderer **out);
void cv_renderer_destroy(cv_renderer *r);

/* Adds a device (of the renderer's context) from the next frame on: uploads the
 * scene to it (the scene and BVH given at creation must still exist) and
 * rebuilds the frame graph. May be called from the progress callback: a node
 * that came back, or a new one, then takes columns from the next frame. A
 * device that cannot take the scene is refused and left as it was. */
cv_result cv_renderer_add_device(cv_renderer *r, cv_device *dev);

/* Renders settings->frames frames and reads the result back. `progress`, if
 * set, is called after every frame. */
cv_result cv_renderer_render(cv_renderer *r, const cv_render_settings *settings, cv_render_output *out,
                             cv_render_stats *stats, void (*progress)(uint32_t frame, uint32_t frames, void *user),
                             void *user);
void cv_render_output_free(cv_render_output *out);

/* The renderer's frame as its render graph (corvid/graph.h) sees it, after a
 * render: every pass (the first frame of a one-frame render) over the last
 * frame's columns, as text (cv_graph_dump_text) and/or Graphviz dot; either
 * FILE may be NULL. */
cv_result cv_renderer_dump_graph(cv_renderer *r, FILE *text, FILE *dot);

/* The reference (ground truth) for the renderer's image model, on the CPU
 * (renderer/src/reference.c): per pixel a closest-hit camera ray through the
 * pixel centre, then `samples` independent samples of the sun's cone (shadow)
 * and samples * ao_samples cosine AO rays, any-hit with scene/'s cv_trace_ray,
 * with the same ray rules (origin offset along the geometric normal, below the
 * surface = shadowed, AO mirrored above the geometric plane), accumulated in
 * float32, shaded as render.composite (unfiltered), seen by the camera of the
 * GPU image's frame (first_frame + frames - 1, which only an orbit changes).
 * With reflections on, `samples` GGX reflection samples per pixel
 * (renderer/src/reflect_model.h, from their own random stream), each shaded at
 * its closest hit as render.reflect_shade (sun with a shadow ray, emission; the
 * sky on a miss), fill the reflection plane (unreconstructed). tile,
 * band_rays, filter_iterations, reflection_radius and observer are ignored,
 * motion is not produced (NULL). `threads` pthreads (0 = 2). `samples` is
 * 1..CV_RENDER_REFERENCE_MAX_SAMPLES.
 * Fills *out like cv_renderer_render; failures leave it untouched. */
#define CV_RENDER_REFERENCE_MAX_SAMPLES 65536u
cv_result cv_render_reference(const cv_scene *scene, const cv_bvh *bvh, const cv_render_settings *settings,
                              uint32_t samples, uint32_t threads, cv_render_output *out);

#endif
