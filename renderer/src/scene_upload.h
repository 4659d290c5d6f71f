/* The scene as the renderer's GPU buffers want it (host side, built once):
 * a flat vertex list (three world-space vertices per triangle, with normal,
 * material and whether its mesh is closed), the material table, and the sun. */
#ifndef CORVID_RENDER_SCENE_UPLOAD_H
#define CORVID_RENDER_SCENE_UPLOAD_H

#include "corvid/scene.h"

/* Matches render_gbuffer.vert's Vertex (32 bytes, std430). */
typedef struct render_vertex {
    float position[3];
    uint32_t material;
    float normal[3];
    float closed; /* 1: the mesh is closed (its back faces are never seen), else 0 */
} render_vertex;

/* Matches render_composite.comp's Material (32 bytes, std430). */
typedef struct render_material {
    float base_color_roughness[4];
    float emission_metalness[4];
} render_material;

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
    render_material *materials;
    uint32_t material_count;
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

#endif
