/* The scene model: what the renderer draws and the BVH builders consume.
 *
 * A cv_scene owns its data (everything passed in is copied):
 *   meshes     indexed triangle lists in object space: float3 positions, float3
 *              normals, optional float2 uvs, u32 indices (3 per triangle);
 *   materials  metal/roughness parameters (base color, emission, transmission, ior),
 *              optionally textured (glTF 2.0 PBR metallic-roughness: base color,
 *              metal/rough, normal and emissive images; alpha mask);
 *   images     RGBA8 texture images with a mip chain, referenced by materials
 *              (sampled by cv_material_evaluate, corvid/material_eval.h);
 *              imported from glTF files (corvid/scene_import.h) or added
 *              directly (cv_scene_add_image);
 *   instances  a mesh placed in the world: mesh index, 3x4 row-major
 *              object-to-world transform, material index;
 *   cameras    pinhole cameras (position, target, up, vertical field of view);
 *   lights     directional and point lights.
 * Indices are dense and stable: the n-th mesh added has index n.
 *
 * Mesh uvs follow glTF: (0, 0) is an image's top-left corner, v grows
 * downward (the importer converts other conventions).
 *
 * Geometry is validated when added (finite positions, indices in range, an
 * invertible transform), so everything downstream (BVH build, traversal) may
 * assume it is well formed. Instance transforms and mesh positions can change
 * after creation (cv_scene_set_instance_transform, cv_scene_set_mesh_positions)
 * for animation; see bvh.h for rebuilding or refitting after such changes.
 *
 * Triangles are front-facing when their vertices run counter-clockwise as seen
 * from the viewer (geometric normal = cross(v1 - v0, v2 - v0), as in glTF).
 * Units are metres by convention (the procedural scenes use them). */
#ifndef CORVID_SCENE_H
#define CORVID_SCENE_H

#include <stdbool.h>
#include <stdint.h>
#include "corvid/result.h"

typedef struct cv_scene cv_scene;

#define CV_SCENE_NAME_MAX 64

/* Input to cv_scene_add_mesh. normals may be NULL (smooth, area-weighted
 * normals are then computed); uvs may be NULL (the mesh has none). */
typedef struct cv_mesh_desc {
    const float *positions;  /* vertex_count * 3 */
    const float *normals;    /* vertex_count * 3, or NULL */
    const float *uvs;        /* vertex_count * 2, or NULL */
    uint32_t vertex_count;   /* >= 1 */
    const uint32_t *indices; /* triangle_count * 3, each < vertex_count */
    uint32_t triangle_count; /* >= 1 */
    const char *name;        /* may be NULL; truncated to CV_SCENE_NAME_MAX - 1 */
} cv_mesh_desc;

/* A stored mesh (read-only view; the arrays belong to the scene). */
typedef struct cv_mesh {
    float *positions;  /* vertex_count * 3 */
    float *normals;    /* vertex_count * 3 */
    float *uvs;        /* vertex_count * 2, or NULL */
    uint32_t *indices; /* triangle_count * 3 */
    uint32_t vertex_count;
    uint32_t triangle_count;
    char name[CV_SCENE_NAME_MAX];
} cv_mesh;

/* A texture image: RGBA8, rows top to bottom (glTF's convention: uv (0, 0)
 * is the top-left corner of the image, v grows downward). The scene keeps a
 * mip chain: level 0 is the image, level k + 1 the 2x2 box filter of level k
 * (an odd side's last row/column folded into the one before), down to 1x1;
 * the filter averages the stored bytes (rounding to nearest), whatever the
 * data means, so the CPU and the GPU sample the same texels. Precisely: the
 * level k + 1 texel (x, y) takes source columns {2x, 2x + 1} ({0} when the
 * source side is 1, {2x, 2x + 1, 2x + 2} for the last x when it is odd), rows
 * alike, and each channel is (sum + n / 2) / n in integers over those n
 * (1, 2, 3, 4, 6 or 9) texels, all weighted equally. */
#define CV_IMAGE_MAX_SIDE 16384u
#define CV_IMAGE_MAX_LEVELS 15u /* log2(CV_IMAGE_MAX_SIDE) + 1 */
/* All images of a scene together, all levels: at most this many bytes. */
#define CV_SCENE_MAX_IMAGE_BYTES (1024ull * 1024 * 1024)

typedef struct cv_image_desc {
    uint32_t width, height; /* 1..CV_IMAGE_MAX_SIDE */
    const uint8_t *rgba8;   /* width * height * 4 bytes, row-major, top row first */
    const char *name;       /* may be NULL; truncated to CV_SCENE_NAME_MAX - 1 */
} cv_image_desc;

typedef struct cv_image {
    uint32_t width, height;                     /* of level 0 */
    uint32_t levels;                            /* 1 + floor(log2(max(width, height))) */
    uint8_t *texels;                            /* every level, level 0 first, RGBA8 rows top to bottom */
    uint64_t level_offset[CV_IMAGE_MAX_LEVELS]; /* in texels (4 bytes each) from texels[0] */
    uint64_t texel_count;                       /* all levels */
    char name[CV_SCENE_NAME_MAX];
} cv_image;

/* Level `level`'s side: max(1, side >> level). */
static inline uint32_t cv_image_level_side(uint32_t side, uint32_t level) {
    uint32_t s = level < 32 ? side >> level : 0;
    return s ? s : 1;
}

typedef enum cv_alpha_mode {
    CV_ALPHA_OPAQUE = 0, /* alpha is ignored */
    CV_ALPHA_MASK = 1,   /* a surface point whose alpha is below alpha_cutoff is not there */
} cv_alpha_mode;

/* Image references in a material are 1 + the image's index; 0 = no image.
 * (So a zero-initialised material has none.) */
#define CV_NO_IMAGE 0u

typedef struct cv_material {
    float base_color[3]; /* linear rgb, 0..1 (times the base color image's decoded sRGB rgb) */
    float roughness;     /* 0..1 (perceptual; times the metal/rough image's g) */
    float metalness;     /* 0..1 (times the metal/rough image's b) */
    float emission[3];   /* linear rgb radiance, >= 0 (times the emissive image's decoded sRGB rgb) */
    float transmission;  /* 0..1: fraction of light passing through */
    float ior;           /* index of refraction, >= 1 */
    /* Textures and alpha (glTF 2.0 PBR metallic-roughness). */
    float alpha;                /* 0..1: base color alpha factor (times the base color image's a) */
    cv_alpha_mode alpha_mode;   /* CV_ALPHA_OPAQUE or CV_ALPHA_MASK */
    float alpha_cutoff;         /* 0..1: with CV_ALPHA_MASK, points whose alpha < cutoff are cut away */
    uint32_t base_color_image;  /* 1 + image index, or CV_NO_IMAGE: rgb sRGB-encoded, a linear alpha */
    uint32_t metal_rough_image; /* 1 + image index, or CV_NO_IMAGE: g roughness, b metalness (linear) */
    uint32_t normal_image;      /* 1 + image index, or CV_NO_IMAGE: tangent-space normal, 2 * rgb - 1 */
    float normal_scale;         /* finite: the normal image's x and y are scaled by it (glTF's scale) */
    uint32_t emissive_image;    /* 1 + image index, or CV_NO_IMAGE: rgb sRGB-encoded */
} cv_material;

/* Base color 0.8 grey, roughness 0.5, dielectric, no emission, opaque, ior
 * 1.5, alpha 1 (opaque mode, cutoff 0.5), no images, normal scale 1. */
cv_material cv_material_default(void);

typedef struct cv_instance {
    uint32_t mesh;         /* index of a mesh of the scene */
    uint32_t material;     /* index of a material of the scene */
    float transform[3][4]; /* object to world, row-major: world = T * (p, 1) */
} cv_instance;

typedef struct cv_camera {
    float position[3];
    float target[3];    /* a point looked at (forward = target - position) */
    float up[3];        /* need not be orthogonal to forward, must not be parallel */
    float vertical_fov; /* full vertical angle, radians, in (0, pi) */
} cv_camera;

typedef enum cv_light_type {
    CV_LIGHT_DIRECTIONAL = 0,
    CV_LIGHT_POINT = 1,
} cv_light_type;

typedef struct cv_light {
    cv_light_type type;
    float direction[3]; /* directional: unit direction the light travels (sun to scene) */
    float position[3];  /* point: world position */
    float color[3];     /* linear rgb, max component 1 by convention */
    float intensity;    /* directional: irradiance (lux-like); point: intensity */
} cv_light;

cv_result cv_scene_create(cv_scene **out);
void cv_scene_destroy(cv_scene *scene); /* NULL is allowed */

/* Each add copies its input and returns the new element's index in *out_index
 * (may be NULL). Fails with CV_ERROR_INVALID_ARGUMENT naming the bad field. */
cv_result cv_scene_add_mesh(cv_scene *scene, const cv_mesh_desc *desc, uint32_t *out_index);
/* Images first: a material's image references must name images already added
 * (and alpha, alpha_cutoff in [0, 1], alpha_mode one of the enum,
 * normal_scale finite); the error names the material and the field. */
cv_result cv_scene_add_material(cv_scene *scene, const cv_material *material, uint32_t *out_index);
/* Copies the image and builds its mip chain. Refused (naming the image): no
 * pixels, a side of 0 or over CV_IMAGE_MAX_SIDE, the scene's images over
 * CV_SCENE_MAX_IMAGE_BYTES (CV_ERROR_LIMIT_EXCEEDED). */
cv_result cv_scene_add_image(cv_scene *scene, const cv_image_desc *image, uint32_t *out_index);
/* Bytes an image of width x height takes in a scene, its mip chain included
 * (what counts against CV_SCENE_MAX_IMAGE_BYTES); 0 for a side of 0 or over
 * CV_IMAGE_MAX_SIDE. Importers compare it with what is left before decoding. */
uint64_t cv_image_stored_bytes(uint32_t width, uint32_t height);
/* Bytes the scene's images take, all levels. */
uint64_t cv_scene_image_bytes(const cv_scene *scene);
cv_result cv_scene_add_instance(cv_scene *scene, const cv_instance *instance, uint32_t *out_index);
cv_result cv_scene_add_camera(cv_scene *scene, const cv_camera *camera, uint32_t *out_index);
cv_result cv_scene_add_light(cv_scene *scene, const cv_light *light, uint32_t *out_index);

/* Moves an instance (same checks as add). */
cv_result cv_scene_set_instance_transform(cv_scene *scene, uint32_t instance, const float transform[3][4]);
/* Replaces a mesh's positions (same vertex count, finite values); topology,
 * normals and uvs are kept. */
cv_result cv_scene_set_mesh_positions(cv_scene *scene, uint32_t mesh, const float *positions, uint32_t vertex_count);

uint32_t cv_scene_mesh_count(const cv_scene *scene);
uint32_t cv_scene_material_count(const cv_scene *scene);
uint32_t cv_scene_image_count(const cv_scene *scene);
uint32_t cv_scene_instance_count(const cv_scene *scene);
uint32_t cv_scene_camera_count(const cv_scene *scene);
uint32_t cv_scene_light_count(const cv_scene *scene);

/* Triangles stored in meshes (each mesh counted once). */
uint64_t cv_scene_triangle_count(const cv_scene *scene);
/* Triangles in the world: sum over instances of their mesh's triangle count. */
uint64_t cv_scene_world_triangle_count(const cv_scene *scene);

/* Element views; NULL when the index is out of range. Valid until the scene
 * is changed or destroyed. */
const cv_mesh *cv_scene_mesh(const cv_scene *scene, uint32_t index);
const cv_material *cv_scene_material(const cv_scene *scene, uint32_t index);
const cv_image *cv_scene_image(const cv_scene *scene, uint32_t index);
const cv_instance *cv_scene_instance(const cv_scene *scene, uint32_t index);
const cv_camera *cv_scene_camera(const cv_scene *scene, uint32_t index);
const cv_light *cv_scene_light(const cv_scene *scene, uint32_t index);

/* World-space bounds of all instances ({0,0,0} twice for an empty scene). */
void cv_scene_bounds(const cv_scene *scene, float min[3], float max[3]);

/* The three world-space vertices of one triangle of one instance: each
 * position transformed by the instance's transform, exactly as the BVH
 * builders do it (same float operations, so results compare bit for bit).
 * Indices must be in range (checked with assert). */
void cv_scene_world_triangle(const cv_scene *scene, uint32_t instance, uint32_t triangle, float out[3][3]);

/* A camera that frames the whole scene (from the +x+y+z diagonal, 60 degree
 * vertical field of view), for scenes that bring none. */
cv_camera cv_scene_framing_camera(const cv_scene *scene);

/* Scenes the framing camera and the renderer's float arithmetic can show:
 * finite bounds, not a single point, an extent of at least
 * CV_SCENE_MIN_EXTENT and of at least CV_SCENE_MIN_RELATIVE_EXTENT of its
 * distance from the origin, and a framing camera and far plane within
 * CV_SCENE_MAX_COORDINATE. CV_ERROR_OUT_OF_RANGE with the figures otherwise. */
#define CV_SCENE_MIN_EXTENT 1e-12
#define CV_SCENE_MIN_RELATIVE_EXTENT 1e-5
#define CV_SCENE_MAX_COORDINATE 1e18
cv_result cv_scene_check_framing(const cv_scene *scene);

/* 3x4 affine helpers used by importers and procedural scenes. */
void cv_transform_identity(float out[3][4]);
/* out = a * b, both taken as 4x4 matrices with last row (0, 0, 0, 1). */
void cv_transform_multiply(const float a[3][4], const float b[3][4], float out[3][4]);
/* Inverse of an affine transform; false (out untouched) when singular or not finite. */
bool cv_transform_invert(const float t[3][4], float out[3][4]);
void cv_transform_point(const float t[3][4], const float p[3], float out[3]);

#endif
