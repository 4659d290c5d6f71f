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
#include "corvid/render_pass.h"
#include "corvid/render_observer.h"
#include "corvid/render_output.h"
#include "corvid/scene.h"

/* Cut points of alpha-masked materials a secondary ray passes (the rule above). */
#define CV_RENDER_ALPHA_LAYERS 4u

/* Rays per trace_rays command: a partition is traced in bands of rows so its
 * ray and hit buffers stay bounded (128 MiB of rays) whatever the image size. */
#define CV_RENDER_BAND_RAYS (1u << 22)

typedef struct cv_render_settings {
    uint32_t width, height;             /* [640x360] pixels */
    uint32_t frames;                    /* [4] frames accumulated (more = less noise) */
    uint32_t ao_samples;                /* [4] AO rays per pixel per frame (0..32) */
    uint32_t shadow_samples;            /* [1] shadow rays per pixel per frame: 1, 2, 4, 8, 16 or 32 */
    float ao_radius;                    /* [2% of the scene diagonal] AO ray length, metres */
    float sun_cone_degrees;             /* [1.5] half angle of the sun's cone (soft shadows); < 0 = hard shadows */
    uint32_t camera;                    /* [0] scene camera index; a framing camera if the scene has none */
    uint32_t tile;                      /* [8] partition tile width, pixels */
    int32_t filter_iterations;          /* [2] a-trous iterations (steps 1, 2, 4, ...) of shadow and AO;
                                           -1 = none, and no reflection denoise either */
    uint32_t band_rays;                 /* [CV_RENDER_BAND_RAYS] most rays per trace_rays command */
    uint32_t first_frame;               /* [0] sample index of the first frame: frames draw the sample sets of
                                 * first_frame .. first_frame + frames - 1 (a render can continue
                                 * another's sequence; tests render single frames of a sequence) */
    const cv_render_observer *observer; /* [NULL] called after every frame with its timings
                                         * (corvid/render_observer.h); NULL = none */
    /* View and light controls (corvid-render --camera, --sun, --orbit); zeros keep the scene's. */
    float camera_eye[3];         /* with camera_fov_degrees > 0, the camera at camera_eye looks at */
    float camera_target[3];      /* camera_target, up +y (+z when it looks straight up or down) */
    float camera_fov_degrees;    /* [0 = the scene's camera, `camera`] vertical field of view,
                                  * (0, CV_RENDER_MAX_FOV_DEGREES] */
    float sun_toward[3];         /* [0,0,0 = the scene's sun] direction toward the sun, any length > 0;
                               * its cone is sun_cone_degrees */
    float orbit_degrees;         /* [0] the camera turns by this much per frame (sample index) about the
                               * vertical axis (its up) through its target: a moving camera, whose
                               * G-buffer runs every frame and whose history is reprojected */
    int32_t reflections;         /* [1] 1 = GGX reflections (reflection_samples rays per pixel per frame,
                                  * shaded with the sun, a shadow ray and the sky), -1 = none (no
                                  * specular term) */
    int32_t reflection_radius;   /* [1] spatial reuse radius of the reflection filter, pixels (0..8);
                                 * -1 = none (every pixel keeps its own samples) */
    float reflection_scale;      /* [1] reflection rays per pixel side: 1, or 0.5 = half resolution (one
                                 * ray per 2x2 quad per frame, the quad's pixels in turn; the filter
                                 * fills the others, its reuse radius one pixel wider) */
    uint32_t reflection_samples; /* [1] reflection rays per traced pixel per frame: 1, 2, 4 or 8 (each
                                  * with its shadow ray; the filter reuses all of them); the image
                                  * height times this is at most CV_MAX_TEXTURE_DIM */
} cv_render_settings;

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
 * motion is not produced (NULL). `threads` pthreads (0 = 2).
 * Fills *out like cv_renderer_render; failures leave it untouched. */
cv_result cv_render_reference(const cv_scene *scene, const cv_bvh *bvh, const cv_render_settings *settings,
                              uint32_t samples, uint32_t threads, cv_render_output *out);

/* The widest vertical field of view rendered, the scene's cameras' too. The
 * G-buffer's near plane (1e-4 of the scene's diagonal) cuts, at the image's
 * edges, what lies within tan(fov / 2) near planes of the camera, which the
 * CPU reference (no near plane) still sees: 0.11% of the diagonal at 170
 * degrees, but 11% at 179.9 (the room from its default eye: 1040 of 1328
 * pixels) and everything at 179.999 (an empty image). Wider is refused, by
 * the renderer and the reference alike. */
#define CV_RENDER_MAX_FOV_DEGREES 170.0f

/* Checks the view and light controls of `s`: finite numbers, camera_fov_degrees
 * 0 or in (0, CV_RENDER_MAX_FOV_DEGREES] with camera_eye != camera_target, sun_toward not 0,0,0 when
 * set (any finite value is "set"), sun_cone_degrees below 90, shadow_samples
 * 0 (the default) or a power of two up to 32, reflection_samples 0 (the
 * default) or a power of two up to 8 and, with reflections on, height times
 * reflection_samples at most CV_MAX_TEXTURE_DIM. The error names
 * the field and its value; cv_renderer_render and cv_render_reference check
 * the same. */
cv_result cv_render_settings_check(const cv_render_settings *s);

/* The camera of sample index `frame` (first_frame + the frame of a render):
 * camera_eye/target/fov if set, else the scene's camera `camera` (a framing
 * camera if the scene has none), turned by orbit_degrees * frame about the
 * vertical axis through its target. The CPU reference renders the camera of
 * first_frame + frames - 1, the frame cv_renderer_render's image shows. */
cv_camera cv_render_camera(const cv_render_settings *s, const cv_scene *scene, uint32_t frame);

/* CV_ERROR_OUT_OF_RANGE when the camera cv_render_camera picks for `s` has a
 * vertical field of view over CV_RENDER_MAX_FOV_DEGREES (a scene's camera can:
 * scene files allow up to 180); cv_renderer_render and cv_render_reference
 * check it after cv_render_settings_check. */
cv_result cv_render_camera_check(const cv_render_settings *s, const cv_scene *scene);

/* Shadow and AO rays per pixel per frame of resolved settings. */
static inline uint32_t cv_render_rays_per_pixel(const cv_render_settings *s) {
    return s->shadow_samples + s->ao_samples;
}

/* The settings with defaults filled in for this scene. */
cv_render_settings cv_render_settings_resolve(const cv_render_settings *in, const cv_scene *scene);

#endif
