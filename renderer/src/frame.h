/* The state a frame's passes share, in one place: the devices, the scene as
 * the GPU holds it (buffers, BVH, pipelines), the size-dependent texture
 * table, the frame graph and its pass slots, this frame's settings and
 * cameras, and the band and capacity math of the ray buffers. The pass
 * modules (passes/) read it; renderer.c, frame_graph.c, readback.c and
 * device_join.c change it. */
#ifndef CORVID_RENDER_FRAME_H
#define CORVID_RENDER_FRAME_H

#include "corvid/blue_noise.h"
#include "corvid/bvh.h"
#include "corvid/device.h"
#include "corvid/render_output.h"
#include "corvid/render_pass.h"
#include "corvid/render_settings.h"
#include "scene_upload.h"

enum {
    PIPE_GBUFFER,
    PIPE_RAYGEN,
    PIPE_RESOLVE,
    PIPE_ACCUMULATE,
    PIPE_FILTER,
    PIPE_COMPOSITE,
    PIPE_REPROJECT,
    PIPE_REFLECT_RAYGEN,
    PIPE_REFLECT_SHADOW,
    PIPE_REFLECT_SHADE,
    PIPE_REFLECT_FILTER,
    PIPE_REFLECT_REPROJECT,
    PIPE_REFLECT_DENOISE,
    PIPE_ALPHA_CONTINUE, /* scenes with alpha-masked materials only */
    PIPE_PRESENT,
    PIPE_COUNT
};

/* Images in the display ring of pass 'present': renderer.h's
 * CV_RENDER_DISPLAY_SLOTS (renderer.c checks they agree; this header stays
 * below renderer.h). */
#define RENDER_DISPLAY_SLOTS 3u

/* Size-dependent textures (render_texture_info: formats, labels, which are
 * loaded on every device). */
enum {
    TEX_POSITION,
    TEX_NORMAL,
    TEX_VISIBILITY,
    TEX_DEPTH,
    TEX_HISTORY,
    TEX_PING,
    TEX_PONG,
    TEX_RADIANCE,
    TEX_ALBEDO,
    TEX_MOTION,           /* moving camera: render.reproject's motion and history length */
    TEX_REPROJECTED,      /* moving camera: the history brought to this frame's pixels */
    TEX_HISTORY_POSITION, /* moving camera: the G-buffer the history was accumulated on */
    TEX_HISTORY_NORMAL,
    TEX_REFLECT,
    TEX_REFLECT_HISTORY,
    TEX_REFLECT_OWN,
    TEX_REFLECT_OUT,
    TEX_MATERIAL,            /* G-buffer: the material at the pixel (textures evaluated): base color rgb, roughness */
    TEX_EMISSION,            /* G-buffer: emission rgb, metalness */
    TEX_REFLECT_STATE,       /* moving camera: render.reflect_filter's per-pixel history state */
    TEX_REFLECT_REPROJECTED, /* moving camera: the reflection histories and state brought to */
    TEX_REFLECT_OWN_REPROJECTED, /* this frame's pixels (render.reflect_reproject) */
    TEX_REFLECT_STATE_REPROJECTED,
    TEX_REFLECT_DENOISE_PING, /* render.reflect_denoise's iterations (the last one is the reflection shown) */
    TEX_REFLECT_DENOISE_PONG,
    TEX_DISPLAY, /* pass 'present': the ring of RENDER_DISPLAY_SLOTS RGBA8 images, TEX_DISPLAY + slot */
    TEX_DISPLAY_LAST = TEX_DISPLAY + RENDER_DISPLAY_SLOTS - 1,
    TEX_COUNT
};

typedef struct render_texture_info {
    cv_format format;
    uint32_t usage;
    bool everywhere; /* loaded on every device, not only the primary */
    const char *label;
} render_texture_info;
extern const render_texture_info render_textures[TEX_COUNT];

/* The scene buffers, imported into the frame graph (the ray and hit buffers
 * are transients of the passes that use them, 'trace' and 'reflect'). */
enum {
    BUF_VERTICES,
    BUF_MATERIALS,
    BUF_LIGHTS,
    BUF_INSTANCES,   /* instance -> its first triangle in the vertex list (reflection hits, the alpha-mask rule) */
    BUF_UVS,         /* per flat vertex uv */
    BUF_IMAGE_TABLE, /* texture images: where each lies in the pool (scene_upload.h) */
    BUF_IMAGE_POOL,  /* and their texels */
    BUF_BLUE_NOISE,  /* the blue-noise rank mask (corvid/blue_noise.h): render.raygen, the reflection samples */
    BUF_COUNT
};

/* Passes a program may add after the table's (cv_renderer_add_pass). */
#define RENDER_MAX_EXTRA_PASSES 8u
#define RENDER_MAX_PASSES (16u + RENDER_MAX_EXTRA_PASSES)

/* One pass of the frame: its module, and what its declare gave. */
typedef struct render_pass_slot {
    const cv_render_pass_module *module;
    void *user;
    const cv_render_frame *frame;
    cv_graph_pass pass; /* id 0: not in the graph */
    cv_graph_use uses[CV_RENDER_PASS_MAX_USES];
} render_pass_slot;

/* The scene's handles every device holds: its buffers and the accel. */
enum { RENDER_SCENE_HANDLES = 9 };

struct cv_render_frame {
    cv_render_frame_view info; /* what the passes see of this frame */
    cv_context *ctx;
    cv_device *devices[CV_MAX_DEVICES]; /* devices[0] is the primary; the passes never look */
    uint32_t count;
    const cv_scene *scene;
    const cv_bvh *bvh; /* for devices added later (cv_renderer_add_device) */
    render_scene_data data;
    cv_buffer vertices, materials, lights, instances;
    cv_buffer uvs, image_table, image_pool; /* textured materials (scene_upload.h) */
    /* The blue-noise mask as render.raygen reads it: ranks[y * 64 + x], two a
     * 32-bit word (the even x in the low half: the bytes of a little-endian
     * uint16 array). A buffer, not a constant in the shader: lavapipe took
     * 1.4 s to make a pipeline with a 2048-word constant array. */
    uint16_t blue_noise_ranks[CV_BLUE_NOISE_CELLS];
    cv_buffer blue_noise;
    cv_accel accel;
    bool alpha_mask; /* some material is alpha-masked: secondary rays follow the alpha-mask rule */
    cv_pipeline pipelines[PIPE_COUNT];
    uint32_t width, height;  /* of the textures below; 0 = none yet */
    uint32_t reflect_layers; /* images in TEX_REFLECT, one a reflection sample (reflection_samples) */
    cv_texture textures[TEX_COUNT];
    uint64_t band_limit; /* most rays per band on every device */

    /* The frame as a render graph, built again when its shape changes (the
     * size, the filter iterations, the ray buffers' size, a still or moving
     * camera, reflections, the devices). */
    cv_graph *graph;
    uint32_t graph_generation;   /* counts graphs built: a frame loop sees a device added (or dropped) */
    bool graph_prebaked;         /* baked once before a render's clock (its transfer rings exist) */
    uint64_t graph_rays;         /* rays the ray and hit buffers of pass 'trace' hold */
    uint64_t graph_reflect_rays; /* rays each of the reflect pass's buffers holds */
    cv_graph_resource tex[TEX_COUNT], buf[BUF_COUNT];
    render_pass_slot slots[RENDER_MAX_PASSES]; /* the table's passes, then the extra ones */
    uint32_t slot_count;
    struct {
        const cv_render_pass_module *module;
        void *user;
    } extra[RENDER_MAX_EXTRA_PASSES];
    uint32_t extra_count;

    /* What the passes record this frame (set before each bake, read by the
     * record callbacks on the graph's worker threads). */
    cv_render_settings settings;
    cv_camera camera, previous_camera; /* this frame's and the previous frame's */
    float sun_direction[3];            /* unit, the way the light travels: the scene's or settings.sun_toward */
    uint32_t display_slot;             /* the TEX_DISPLAY image pass 'present' writes this frame */
    uint64_t presented;                /* frames presented so far (the display ring's position) */
};

/* Uploads the scene to every device of f (devices, count, ctx, scene and bvh
 * set): buffers, BVH, pipelines; sets the band limit. */
cv_result render_frame_upload_scene(cv_render_frame *f);
/* Frees what render_frame_upload_scene and render_frame_ensure_targets made
 * (the graph too); f's devices must be idle. */
void render_frame_release(cv_render_frame *f);
void render_frame_scene_handles(const cv_render_frame *f, cv_handle out[RENDER_SCENE_HANDLES]);
/* The textures for width x height images; the reflection samples' holds
 * `layers` images, one above the other (render.reflect_shade). */
cv_result render_frame_ensure_targets(cv_render_frame *f, uint32_t width, uint32_t height, uint32_t layers);

/* Rays traced per band: the ray and hit buffers hold one band, so a window of
 * any size fits every device's storage buffer range. */
uint64_t render_band_rays(const cv_render_frame *f, const cv_render_settings *s);
/* Rows per band for a window `width` columns wide. */
uint32_t render_band_rows(const cv_render_frame *f, const cv_render_settings *s, uint32_t width);
/* Rays the ray and hit buffers must hold for a band of any window of the
 * image: a band of a narrower window is never larger (at least a row). */
uint64_t render_band_capacity(const cv_render_frame *f, const cv_render_settings *s);
/* Rays of one band of pass 'reflect' (one per pixel): each of its four
 * buffers holds a band of any window (at least a row; half the trace pass's
 * band, as two buffers of rays are live at once). */
uint64_t render_reflect_capacity(const cv_render_frame *f, const cv_render_settings *s);
/* Pixels whose reflection ray sample index `frame` traces: all, or at half
 * resolution those of the frame's slot of each 2x2 quad (render.reflect_raygen:
 * slot (x & 1) + 2 (y & 1) == frame % 4). */
uint64_t render_reflect_traced_pixels(const cv_render_frame *f, const cv_render_settings *s, uint32_t frame);
/* Re-traces of the alpha-mask rule (renderer.h) after a trace with or without CV_TRACE_ANY_HIT. */
static inline uint32_t render_alpha_retraces(bool any_hit) { return CV_RENDER_ALPHA_LAYERS + (any_hit ? 1u : 0u); }

/* The view-projection of `camera` for the G-buffer (and the reprojection). */
void render_view_proj(const cv_render_frame *f, const cv_camera *camera, float out[16], float *far_plane);
/* The angle one pixel subtends at the camera (2 tan(fov / 2) / height): times
 * a distance, the world size of a pixel there (the filters' footprint). */
float render_pixel_angle(const cv_render_frame *f);

/* Moving camera: how far a previous frame's surface may lie from this
 * frame's plane and still be the same surface, per unit of distance from the
 * eye (render_reproject.comp, render_reflect_reproject.comp). */
#define RENDER_REPROJECT_PLANE_TOLERANCE 0.01f

static inline uint32_t render_groups(uint32_t n, uint32_t size) { return (n + size - 1) / size; }
/* One dispatch of 8x8 groups over width x height pixels (a band of a
 * partition's columns: the trace and reflect passes' per-ray shaders). */
void render_dispatch_pixels(const cv_render_frame *f, cv_command_list *l, cv_queue_type queue, int pipeline,
                            const cv_binding *b, uint32_t count, const void *push, uint32_t push_size, uint32_t width,
                            uint32_t height);
/* The same over the whole image: the primary's per-pixel passes. */
void render_dispatch_image(const cv_render_frame *f, cv_command_list *l, cv_queue_type queue, int pipeline,
                           const cv_binding *b, uint32_t count, const void *push, uint32_t push_size);
/* A transient the declaring pass writes: one band of rays or hits of any
 * window (render_band_capacity), on every device. */
cv_graph_use render_band_buffer(cv_graph_builder *b, const char *label, uint64_t bytes);
/* b[i] = the binding of uses[i] on the device being recorded, for i < count (a pass whose shader
 * binds its declarations in their order). */
void render_bind_uses(const cv_graph_pass_context *pc, const cv_graph_use *uses, uint32_t count, cv_binding *b);

#endif
