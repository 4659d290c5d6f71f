/* The scene as the renderer's GPU buffers want it (host side, built once):
 * a flat vertex list (three world-space vertices per triangle, with normal,
 * material and whether its mesh is closed) and its uvs (a parallel list), the
 * material table, the texture images (one pool of texels, every level of
 * every image, and a table saying where each image lies in it), and the sun. */
#ifndef CORVID_RENDER_SCENE_UPLOAD_H
#define CORVID_RENDER_SCENE_UPLOAD_H

#include <stddef.h>

#include "corvid/scene.h"

/* Matches render_gbuffer.vert's Vertex (32 bytes, std430). */
typedef struct render_vertex {
    float position[3];
    uint32_t material;
    float normal[3];
    float closed; /* 1: the mesh is closed (its back faces are never seen), else 0 */
} render_vertex;

/* Matches shaders/render_material.glsl's Material (64 bytes, std430): the
 * scene's cv_material with its image references (1 + image index, 0 = none). */
typedef struct render_material {
    float base_color_roughness[4];
    float emission_metalness[4];
    uint32_t base_color_image, metal_rough_image, normal_image, emissive_image;
    float alpha;
    uint32_t alpha_mode; /* cv_alpha_mode */
    float alpha_cutoff;
    float normal_scale;
} render_material;
_Static_assert(sizeof(render_material) == 64, "render_material is render_material.glsl's Material (64 bytes)");
_Static_assert(offsetof(render_material, emission_metalness) == 16 &&
                   offsetof(render_material, base_color_image) == 32 && offsetof(render_material, alpha) == 48 &&
                   offsetof(render_material, normal_scale) == 60,
               "render_material's fields lie where render_material.glsl's Material has them");

/* Matches render_material.glsl's Image (16 bytes, std430): where an image's
 * texels lie in the pool (one uint per RGBA8 texel, r in the low byte; its
 * levels one after the other, level 0 first, rows top to bottom). */
typedef struct render_image {
    uint32_t offset; /* level 0's first texel in the pool */
    uint32_t width, height, levels;
} render_image;
_Static_assert(sizeof(render_image) == 16, "render_image is render_material.glsl's Image (16 bytes)");

/* The image table buffer (render_material.glsl's ImageTable): 256 floats,
 * byte -> linear with the sRGB transfer function (cv_srgb_to_linear); 256
 * floats byte / 255 (as scene/ computes them: the GPU decodes texels to the
 * same floats); then a render_image per image (at least one entry). */
#define RENDER_IMAGE_TABLE_HEADER 512u /* floats before the first render_image */

/* Matches render_composite.comp's PointLight (32 bytes, std430). */
typedef struct render_light {
    float position[3];
    float intensity;
    float color[3];
    float pad;
} render_light;

typedef struct render_scene_data {
    render_vertex *vertices;
    uint64_t vertex_count;
    float *uvs; /* vertex_count * 2: each flat vertex's uv (0, 0 for meshes without) */
    render_material *materials;
    uint32_t material_count;
    uint32_t *image_table; /* RENDER_IMAGE_TABLE_HEADER floats (as bits), then render_image[] */
    uint64_t image_table_bytes;
    uint32_t *image_pool;     /* every image's texels; one texel (0) when the scene has no images */
    uint64_t image_texels;    /* >= 1 */
    uint32_t image_count;     /* real images */
    uint32_t *instance_first; /* per instance (at least one entry): the index of its first triangle in
                               * `vertices` (three vertices each); a trace hit (instance, triangle) is
                               * vertices[3 * (instance_first[instance] + triangle)] */
    uint32_t instance_count;
    render_light *lights;   /* point lights; at least one entry (intensity 0 if none) */
    uint32_t light_count;   /* real point lights */
    float sun_direction[3]; /* unit, the way light travels */
    float sun_color[3];
    float sun_irradiance;
    float bounds_min[3], bounds_max[3];
    float diagonal;
} render_scene_data;

cv_result render_scene_data_build(const cv_scene *scene, render_scene_data *out);
void render_scene_data_free(render_scene_data *d);

/* How far a secondary ray starts from the surface it leaves, along the
 * geometric normal, and how far past a cut point an alpha-mask continuation
 * starts (renderer.h): 2e-5 of the scene's diagonal, on the GPU and in the
 * reference alike. */
static inline float render_ray_offset(const render_scene_data *d) { return d->diagonal * 2e-5f; }

/* Whether some material is alpha-masked (secondary rays then follow the alpha-mask rule, renderer.h). */
static inline bool render_scene_alpha_masked(const render_scene_data *d) {
    for (uint32_t m = 0; m < d->material_count; m++)
        if (d->materials[m].alpha_mode == CV_ALPHA_MASK)
            return true;
    return false;
}

#endif
