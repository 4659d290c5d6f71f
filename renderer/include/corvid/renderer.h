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
 *                 reflection; metal/roughness materials) to linear HDR,
 *                 present (the HDR times 2^exposure, ACES, sRGB: an RGBA8
 *                 display image, cv_renderer_step's)
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
#include "corvid/render_pass.h"
#include "corvid/render_observer.h"
#include "corvid/render_output.h"
#include "corvid/render_settings.h"
#include "corvid/scene.h"

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

/* Adds a pass module (corvid/render_pass.h) to the frame, after the
 * renderer's own passes (and those added before it), from the next render
 * on; `user` is passed to its callbacks. The module and user must outlive
 * the renderer. Refused during a render (from its progress callback), for a
 * module without name, declare or record, a name the frame has already, or
 * more than 8 added passes. docs/render-graph.md, "Writing a pass". */
cv_result cv_renderer_add_pass(cv_renderer *r, const cv_render_pass_module *module, void *user);

/* Renders settings->frames frames and reads the result back. `progress`, if
 * set, is called after every frame. */
cv_result cv_renderer_render(cv_renderer *r, const cv_render_settings *settings, cv_render_output *out,
                             cv_render_stats *stats, void (*progress)(uint32_t frame, uint32_t frames, void *user),
                             void *user);

/* Progressive, interactive rendering: one frame a call, presented.
 *
 *   cv_render_step step;
 *   while (viewing) {
 *       settings.camera_eye[0] = ...;  // a change restarts the history
 *       if (cv_renderer_step(r, &settings, &step) != CV_OK) { ... cv_last_error() ... }
 *       // step.display: RGBA8 on the primary, complete after step.ticket
 *       cv_device_wait(primary, step.ticket, UINT64_MAX);
 *       cv_device_read_texture(primary, step.display, (cv_rect){ 0, 0, step.width, step.height }, rgba8);
 *   }
 *
 * The display textures form a ring of CV_RENDER_DISPLAY_SLOTS (step N writes
 * slot N % CV_RENDER_DISPLAY_SLOTS), so a reader can encode one while the next
 * frames render. */
#define CV_RENDER_DISPLAY_SLOTS 3u

typedef struct cv_render_step {
    cv_texture display;  /* RGBA8_UNORM on the primary: tone-mapped (ACES, settings.exposure),
                          * sRGB-encoded; one of CV_RENDER_DISPLAY_SLOTS textures, rewritten
                          * CV_RENDER_DISPLAY_SLOTS steps later */
    cv_texture radiance; /* RGBA32F linear HDR on the primary (rewritten by the next step) */
    uint32_t width, height;
    uint32_t accumulated; /* frames in this image's history: 1 after a restart */
    uint64_t ticket;      /* on the primary: the display and radiance are complete after it */
    double frame_ms;      /* host time of the step */
} cv_render_step;

/* Whether a render or step would take these settings, checked as they
 * would be (the table's ranges, the camera against the scene), without
 * rendering or changing anything. Reads only what creation fixed, so any
 * thread may call it while another renders (corvid/live.h checks a viewer's
 * input with it before the input reaches the render thread). */
cv_result cv_renderer_check_settings(const cv_renderer *r, const cv_render_settings *settings);

/* Renders one more frame of a progressive image and presents it (filter,
 * composite and the tone-mapping pass 'present' run on every step). The
 * history goes on from the previous step while the settings are equal
 * (frames, first_frame and observer are ignored; exposure only changes the
 * tone map of the history); any other change (camera, sun, size, a setting)
 * restarts it. Step k of a history (from 0) draws the
 * sample set first_frame + k, first_frame as the restart's settings said, so
 * N steps of a still view give the image of cv_renderer_render with frames =
 * N. Submits and returns without waiting for the GPU where it can (one
 * device; with several it waits for the frame, as a render's last frame
 * does); the ticket says when it is done, and a reader of `display` waits for
 * it. Settings are checked first: a bad one changes nothing. A render
 * (cv_renderer_render) between steps restarts the history. */
cv_result cv_renderer_step(cv_renderer *r, const cv_render_settings *settings, cv_render_step *out);

/* The last step's (or render's) frame as planes, as cv_renderer_render gives
 * them (waits for the frame). */
cv_result cv_renderer_read_output(cv_renderer *r, cv_render_output *out);

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
