/* The renderer's settings: cv_render_settings and the one table that owns
 * every setting's option name, range, default and help text.
 *
 * CV_RENDER_SETTINGS_TABLE has a row per field of cv_render_settings (the
 * observer aside, which is no setting). From it come the defaults
 * (cv_render_settings_resolve), the checks with their messages
 * (cv_render_settings_check), the programs' option parser and --help
 * (corvid/render_options.h), and the descriptors below, so that no range is
 * written twice. A zero field means "the default" for every setting, so
 * `(cv_render_settings){ .frames = 8 }` is a whole request. Some rows keep
 * two more meanings in the sign or in zero (their flags below): a negative
 * filter_iterations, reflection_radius or sun_cone_degrees means "none" (the
 * option's 0), and a zero camera_fov_degrees or sun_toward leaves the
 * scene's camera or sun.
 *
 *   cv_render_settings s = { .width = 320, .height = 180, .ao_samples = 40 };
 *   if (cv_render_settings_check(&s) != CV_OK)  // "renderer: AO samples 40 is outside <min>..<max>"
 *       fprintf(stderr, "%s\n", cv_last_error());
 *   s.ao_samples = 8;
 *   cv_render_settings r = cv_render_settings_resolve(&s, scene); // r.frames: the frames row's def
 *
 *   const cv_render_setting *row = &cv_render_setting_rows[CV_RENDER_SETTING_frames];
 *   printf("%s: %g..%g, default %g\n", row->option, row->min, row->max, row->def); // "--frames: <min>..<max>, <default>"
 *
 * Adding a setting: a field in cv_render_settings, a row in the table (the
 * build checks the field's type against the row's kind); the programs then
 * parse it, print its help and refuse values outside its range. */
#ifndef CORVID_RENDER_SETTINGS_H
#define CORVID_RENDER_SETTINGS_H

#include <math.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "corvid/render_observer.h"
#include "corvid/result.h"
#include "corvid/scene.h"
#include "corvid/types.h"

/* Rays per trace_rays command: a partition is traced in bands of rows so its
 * ray and hit buffers stay bounded (128 MiB of rays) whatever the image size. */
#define CV_RENDER_BAND_RAYS (1u << 22)

/* Cut points of alpha-masked materials a secondary ray passes (the
 * alpha-mask rule, renderer.h). Here, below renderer.h, for the renderer's
 * passes and the CPU reference. */
#define CV_RENDER_ALPHA_LAYERS 4u

/* The widest vertical field of view rendered, the scene's cameras' too. The
 * G-buffer's near plane (1e-4 of the scene's diagonal) cuts, at the image's
 * edges, what lies within tan(fov / 2) near planes of the camera, which the
 * CPU reference (no near plane) still sees: 0.11% of the diagonal at 170
 * degrees, but 11% at 179.9 (the room from its default eye: 1040 of 1328
 * pixels) and everything at 179.999 (an empty image). Wider is refused, by
 * the renderer and the reference alike. */
#define CV_RENDER_MAX_FOV_DEGREES 170.0f

/* What a row's field holds. */
typedef enum cv_setting_kind {
    CV_SETTING_U32,    /* uint32_t: a whole number in min..max */
    CV_SETTING_I32,    /* int32_t: a whole number in min..max */
    CV_SETTING_ON_OFF, /* int32_t: 1 = on, -1 = off (the option's words) */
    CV_SETTING_F32,    /* float: a finite number in min..max (its ends as the flags say) */
    CV_SETTING_VEC3,   /* float[3]: finite numbers (no range; set through a compound option) */
} cv_setting_kind;

/* A row's flags. */
enum {
    CV_SETTING_POW2 = 1u << 0,     /* only powers of two (1, 2, 4, ...; 0.5 too for a float) */
    CV_SETTING_MIN_OPEN = 1u << 1, /* min itself is outside the range */
    CV_SETTING_MAX_OPEN = 1u << 2, /* max itself is outside the range */
    CV_SETTING_NONE = 1u << 3,     /* negative = none (resolved to 0); the option's 0 stores -1 */
    CV_SETTING_SCENE = 1u << 4,    /* 0 keeps the scene's: no default is filled in */
    CV_SETTING_DIAGONAL = 1u << 5, /* the default is def times the scene's diagonal */
};

/* X(field, kind, flags, option, metavar, min, max, def, name, unit, help):
 *   option   the programs' option ("--frames"), NULL for none; rows set by one
 *            compound option name it alike (--size: width and height)
 *   min/max  the range of the option's value (with the flags: open ends);
 *            def the value a 0 field resolves to
 *   name     the setting in messages and help ("AO samples"); unit: "" or "pixels"
 *   help     what it does, for --help (its range and default are added). */
#define CV_RENDER_SETTINGS_TABLE(X) \
    X(width, CV_SETTING_U32, 0, "--size", "WxH", 1, CV_MAX_TEXTURE_DIM, 640, "width", "pixels", \
      "image size in pixels") \
    X(height, CV_SETTING_U32, 0, "--size", "WxH", 1, CV_MAX_TEXTURE_DIM, 360, "height", "pixels", \
      "image size in pixels") \
    X(frames, CV_SETTING_U32, 0, "--frames", "N", 1, 4096, 4, "frames", "", \
      "frames accumulated (more = less noise)") \
    X(ao_samples, CV_SETTING_U32, 0, "--ao-samples", "N", 1, 32, 4, "AO samples", "", \
      "ambient occlusion rays per pixel per frame (0 is refused: AO cannot be turned off)") \
    X(shadow_samples, CV_SETTING_U32, CV_SETTING_POW2, "--shadow-samples", "N", 1, 32, 1, "shadow samples", "", \
      "rays toward the sun per pixel per frame (more rays, less noise in soft shadows)") \
    X(ao_radius, CV_SETTING_F32, CV_SETTING_MIN_OPEN | CV_SETTING_DIAGONAL, "--ao-radius", "M", 0, INFINITY, 0.02, \
      "AO radius", "scene units", "AO ray length") \
    X(camera, CV_SETTING_U32, 0, NULL, NULL, 0, UINT32_MAX, 0, "scene camera", "", \
      "the scene's camera shown (a framing camera if the scene has none)") \
    X(tile, CV_SETTING_U32, 0, NULL, NULL, 1, UINT32_MAX, 8, "partition tile", "pixels", \
      "partition tile width: devices take whole tiles of columns") \
    X(filter_iterations, CV_SETTING_I32, CV_SETTING_NONE, "--filter", "N", 0, 8, 2, "filter iterations", "", \
      "variance-guided a-trous filter iterations of shadow and AO (steps 1, 2, 4, ...); 0 = unfiltered, also " \
      "no reflection denoise") \
    X(band_rays, CV_SETTING_U32, 0, NULL, NULL, 1, UINT32_MAX, CV_RENDER_BAND_RAYS, "band rays", "", \
      "most rays per trace_rays command") \
    X(first_frame, CV_SETTING_U32, 0, NULL, NULL, 0, 1u << 24, 0, "first frame", "", \
      "sample index of the first frame: frames draw the sample sets of first_frame .. first_frame + frames - 1 " \
      "(a render can continue another's sequence)") \
    X(camera_eye, CV_SETTING_VEC3, CV_SETTING_SCENE, "--camera", "EX,EY,EZ,TX,TY,TZ,FOV", 0, 0, 0, "camera eye", "", \
      "the camera at eye EX,EY,EZ") \
    X(camera_target, CV_SETTING_VEC3, CV_SETTING_SCENE, "--camera", "EX,EY,EZ,TX,TY,TZ,FOV", 0, 0, 0, \
      "camera target", "", "looking at TX,TY,TZ (up +y; +z when it looks straight up or down)") \
    X(camera_fov_degrees, CV_SETTING_F32, CV_SETTING_MIN_OPEN | CV_SETTING_SCENE, "--camera", \
      "EX,EY,EZ,TX,TY,TZ,FOV", 0, CV_RENDER_MAX_FOV_DEGREES, 0, "camera fov", "degrees", \
      "with a vertical field of view of FOV degrees") \
    X(sun_toward, CV_SETTING_VEC3, CV_SETTING_SCENE, "--sun", "DX,DY,DZ,A", 0, 0, 0, "sun direction", "", \
      "direction toward the sun DX,DY,DZ (any length but 0,0,0)") \
    X(sun_cone_degrees, CV_SETTING_F32, CV_SETTING_MAX_OPEN | CV_SETTING_NONE, "--sun", "DX,DY,DZ,A", 0, 90, 1.5, \
      "sun cone half angle", "degrees", \
      "half angle A of the sun's cone in degrees (soft shadows; 0 = hard shadows)") \
    X(orbit_degrees, CV_SETTING_F32, 0, "--orbit", "D", -360, 360, 0, "orbit", "degrees per frame", \
      "the camera turns D degrees per frame about the vertical axis through its target (a moving camera: " \
      "reprojected history, motion vectors)") \
    X(reflections, CV_SETTING_ON_OFF, 0, "--reflections", "on|off", 0, 0, 1, "reflections", "", \
      "GGX reflections (off: no specular term)") \
    X(reflection_radius, CV_SETTING_I32, CV_SETTING_NONE, "--reflect-radius", "N", 0, 8, 1, "reflection radius", \
      "pixels", "spatial reuse radius of the reflection filter, pixels; 0 = every pixel keeps its own samples") \
    X(reflection_scale, CV_SETTING_F32, CV_SETTING_POW2, "--reflection-scale", "S", 0.5, 1, 1, "reflection scale", \
      "", "reflection rays per pixel side: 0.5 = half resolution, one reflection ray per 2x2 pixels per frame") \
    X(reflection_samples, CV_SETTING_U32, CV_SETTING_POW2, "--reflection-samples", "N", 1, 8, 1, \
      "reflection samples", "", \
      "reflection rays per traced pixel per frame, each with a shadow ray at its hit (less noise in glossy " \
      "reflections, at N times the reflection pass's cost); the image height times N is at most the texture " \
      "limit") \
    X(zero_copy, CV_SETTING_U32, 0, NULL, NULL, 0, 2, 0, "zero copy", "", \
      "columns gathered through memory the devices share (the frame graph's cv_graph_zero_copy): 0 = auto, " \
      "1 = on (or the render fails), 2 = off (copies); programs read CORVID_ZERO_COPY into it") \
    X(sync_transfers, CV_SETTING_U32, 0, NULL, NULL, 0, 1, 0, "synchronous transfers", "", \
      "1: every transfer between devices synchronous on the host, as before transfer rings (for comparisons); " \
      "programs read CORVID_TRANSFER_ASYNC=0 into it") \
    X(exposure, CV_SETTING_F32, 0, NULL, NULL, -20, 20, 0, "exposure", "stops", \
      "exposure of the presented image (pass 'present': ACES tone map of the radiance times 2^exposure, sRGB)")

/* The fields' meanings are the table's help texts; their ranges and defaults
 * are the table's. */
typedef struct cv_render_settings {
    uint32_t width, height;
    uint32_t frames;
    uint32_t ao_samples;
    uint32_t shadow_samples;
    float ao_radius;
    float sun_cone_degrees;
    uint32_t camera;
    uint32_t tile;
    int32_t filter_iterations;
    uint32_t band_rays;
    uint32_t first_frame;
    /* Called after every frame with its timings (corvid/render_observer.h); NULL = none. */
    const cv_render_observer *observer;
    float camera_eye[3];
    float camera_target[3];
    float camera_fov_degrees;
    float sun_toward[3];
    float orbit_degrees;
    int32_t reflections;
    int32_t reflection_radius;
    float reflection_scale;
    uint32_t reflection_samples;
    uint32_t zero_copy;      /* cv_graph_zero_copy (corvid/graph.h) */
    uint32_t sync_transfers; /* cv_graph_bake_desc.sync_transfers */
    float exposure;          /* EV of the presented image (cv_renderer_step's display) */
} cv_render_settings;

/* A row of the table as data. */
typedef struct cv_render_setting {
    const char *field; /* "ao_samples" */
    cv_setting_kind kind;
    uint32_t flags;
    const char *option; /* "--ao-samples", or NULL */
    const char *metavar;
    double min, max, def;
    const char *name, *unit, *help;
    size_t offset; /* of the field in cv_render_settings */
} cv_render_setting;

typedef enum cv_render_setting_id {
#define CV_RENDER_SETTING_ID(field, ...) CV_RENDER_SETTING_##field,
    CV_RENDER_SETTINGS_TABLE(CV_RENDER_SETTING_ID)
#undef CV_RENDER_SETTING_ID
        CV_RENDER_SETTING_COUNT
} cv_render_setting_id;

extern const cv_render_setting cv_render_setting_rows[CV_RENDER_SETTING_COUNT];

/* The row's range as the programs write it into messages and help: "<min>..<max>",
 * "one of <the powers of two in it>", "(<min>,<max>]", "> <min>", "on or off". */
void cv_render_setting_range(const cv_render_setting *row, char *out, size_t size);

/* Whether `value`, in the units of the row's option, is within its range:
 * min..max with the row's open ends, a power of two where the row says so. */
bool cv_render_setting_accepts(const cv_render_setting *row, double value);

/* Checks every field against its row (0 = the default; negative = none where
 * the row allows it), then what no single field decides: a camera's eye is
 * not its target, a set sun direction is not 0,0,0, and, with reflections
 * on, height times reflection_samples is at most CV_MAX_TEXTURE_DIM. The
 * error names the setting, its value and its range ("renderer: AO samples 40
 * is outside <min>..<max>"); cv_renderer_render and cv_render_reference check the
 * same. */
cv_result cv_render_settings_check(const cv_render_settings *s);

/* The settings with the table's defaults filled in for this scene (ao_radius:
 * a share of its diagonal), "none" turned to 0. */
cv_render_settings cv_render_settings_resolve(const cv_render_settings *in, const cv_scene *scene);

/* Shadow and AO rays per pixel per frame of resolved settings. */
static inline uint32_t cv_render_rays_per_pixel(const cv_render_settings *s) {
    return s->shadow_samples + s->ao_samples;
}

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

#endif
