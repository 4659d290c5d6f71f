/* Building meshes vertex by vertex for the procedural scenes, and the prop
 * shapes made with it. Shapes are centred on the origin and fit the cube
 * [-0.5, 0.5]^3 (scale them with the instance transform). */
#ifndef CORVID_SCENE_MESH_BUILDER_H
#define CORVID_SCENE_MESH_BUILDER_H

#include <stdbool.h>
#include <stdint.h>
#include "corvid/scene.h"

typedef struct cvs_mesh_builder {
    float *positions, *normals, *uvs;
    uint32_t *indices;
    uint32_t vertex_count, vertex_cap;
    uint32_t triangle_count, triangle_cap;
    bool smooth; /* normals left to cv_scene_add_mesh (area-weighted) */
    bool failed; /* an allocation failed; reported by cvs_mb_add_to_scene */
} cvs_mesh_builder;

void cvs_mb_init(cvs_mesh_builder *b);
void cvs_mb_free(cvs_mesh_builder *b);
uint32_t cvs_mb_vertex(cvs_mesh_builder *b, const float p[3], const float n[3], float u, float v);
void cvs_mb_triangle(cvs_mesh_builder *b, uint32_t a, uint32_t c, uint32_t d);
/* A flat convex polygon (3..8 points) facing away from the origin, with its
 * own vertices (hard edges) and planar uvs. */
void cvs_mb_flat_polygon(cvs_mesh_builder *b, const float (*pts)[3], int count);
/* Adds the built mesh to the scene; CV_ERROR_OUT_OF_MEMORY if building ran out. */
cv_result cvs_mb_add_to_scene(cvs_mesh_builder *b, cv_scene *scene, const char *name, uint32_t *out_index);

void cvs_shape_box(cvs_mesh_builder *b);
void cvs_shape_beveled_box(cvs_mesh_builder *b, float bevel);
void cvs_shape_sphere(cvs_mesh_builder *b, uint32_t slices, uint32_t stacks);
void cvs_shape_cylinder(cvs_mesh_builder *b, uint32_t segments);
void cvs_shape_cone(cvs_mesh_builder *b, uint32_t segments);
/* A lumpy sphere with exactly triangle_count triangles (>= 1): a latitude-
 * longitude sphere displaced by a few seeded waves; when its grid has more
 * triangles than asked, the last rows are left open. Smooth normals. */
void cvs_shape_blob(cvs_mesh_builder *b, uint32_t triangle_count, uint64_t seed);

#endif
