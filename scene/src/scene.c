/* The scene model: growable arrays of meshes, materials, images, instances,
 * cameras and lights, with validation on the way in. Images get their mip
 * chain here (build_mips). */
#include "corvid/scene.h"

#include <assert.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "vec3.h"

struct cv_scene {
    cv_mesh *meshes;
    uint32_t mesh_count, mesh_cap;
    cv_material *materials;
    uint32_t material_count, material_cap;
    cv_image *images;
    uint32_t image_count, image_cap;
    uint64_t image_bytes; /* all images, all levels */
    cv_instance *instances;
    uint32_t instance_count, instance_cap;
    cv_camera *cameras;
    uint32_t camera_count, camera_cap;
    cv_light *lights;
    uint32_t light_count, light_cap;
};

/* Makes room for one more element of `size` bytes in *array. */
static bool grow(void **array, uint32_t *cap, uint32_t count, size_t size) {
    if (count < *cap)
        return true;
    if (count == UINT32_MAX)
        return false;
    uint32_t new_cap = *cap ? (*cap > UINT32_MAX / 2 ? UINT32_MAX : *cap * 2) : 16;
    void *p = realloc(*array, (size_t)new_cap * size);
    if (!p)
        return false;
    *array = p;
    *cap = new_cap;
    return true;
}

static bool all_finite(const float *v, size_t n) {
    for (size_t i = 0; i < n; i++)
        if (!isfinite(v[i]))
            return false;
    return true;
}

cv_material cv_material_default(void) {
    return (cv_material){
        .base_color = { 0.8f, 0.8f, 0.8f },
        .roughness = 0.5f,
        .metalness = 0.0f,
        .emission = { 0.0f, 0.0f, 0.0f },
        .transmission = 0.0f,
        .ior = 1.5f,
        .alpha = 1.0f,
        .alpha_mode = CV_ALPHA_OPAQUE,
        .alpha_cutoff = 0.5f,
        .base_color_image = CV_NO_IMAGE,
        .metal_rough_image = CV_NO_IMAGE,
        .normal_image = CV_NO_IMAGE,
        .normal_scale = 1.0f,
        .emissive_image = CV_NO_IMAGE,
    };
}

cv_result cv_scene_create(cv_scene **out) {
    if (!out)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_scene_create: out is NULL");
    cv_scene *s = calloc(1, sizeof *s);
    if (!s)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "cv_scene_create: no memory for the scene");
    *out = s;
    return CV_OK;
}

void cv_scene_destroy(cv_scene *scene) {
    if (!scene)
        return;
    for (uint32_t i = 0; i < scene->mesh_count; i++) {
        free(scene->meshes[i].positions);
        free(scene->meshes[i].normals);
        free(scene->meshes[i].uvs);
        free(scene->meshes[i].indices);
    }
    free(scene->meshes);
    free(scene->materials);
    for (uint32_t i = 0; i < scene->image_count; i++)
        free(scene->images[i].texels);
    free(scene->images);
    free(scene->instances);
    free(scene->cameras);
    free(scene->lights);
    free(scene);
}

/* Area-weighted vertex normals (the cross product's length is twice the area). */
static void compute_normals(cv_mesh *m) {
    memset(m->normals, 0, (size_t)m->vertex_count * 3 * sizeof(float));
    for (uint32_t t = 0; t < m->triangle_count; t++) {
        const uint32_t *idx = &m->indices[3 * t];
        float e1[3], e2[3], n[3];
        v3_sub(e1, &m->positions[3 * idx[1]], &m->positions[3 * idx[0]]);
        v3_sub(e2, &m->positions[3 * idx[2]], &m->positions[3 * idx[0]]);
        v3_cross(n, e1, e2);
        for (int k = 0; k < 3; k++)
            v3_add(&m->normals[3 * idx[k]], &m->normals[3 * idx[k]], n);
    }
    for (uint32_t v = 0; v < m->vertex_count; v++) {
        float *n = &m->normals[3 * v];
        if (v3_dot(n, n) > 0.0f)
            v3_normalize(n, n);
        else
            v3_set(n, 0.0f, 1.0f, 0.0f);
    }
}

cv_result cv_scene_add_mesh(cv_scene *scene, const cv_mesh_desc *d, uint32_t *out_index) {
    if (!scene || !d)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_scene_add_mesh: scene or desc is NULL");
    const char *name = d->name ? d->name : "";
    if (!d->positions || !d->indices)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "mesh '%s': positions or indices is NULL", name);
    if (d->vertex_count == 0 || d->triangle_count == 0)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "mesh '%s': %u vertices and %u triangles (need >= 1 of each)",
                        name, d->vertex_count, d->triangle_count);
    if ((uint64_t)d->triangle_count * 3 > UINT32_MAX)
        return cv_error(CV_ERROR_LIMIT_EXCEEDED, "mesh '%s': %u triangles (index count over 2^32)", name,
                        d->triangle_count);
    size_t nv = d->vertex_count, ni = (size_t)d->triangle_count * 3;
    for (size_t i = 0; i < nv * 3; i++)
        if (!isfinite(d->positions[i]))
            return cv_error(CV_ERROR_INVALID_ARGUMENT, "mesh '%s': vertex %zu has a non-finite position", name,
                            i / 3);
    for (size_t i = 0; i < ni; i++)
        if (d->indices[i] >= d->vertex_count)
            return cv_error(CV_ERROR_INVALID_ARGUMENT, "mesh '%s': index %zu is %u, vertex count is %u", name, i,
                            d->indices[i], d->vertex_count);
    if (d->normals && !all_finite(d->normals, nv * 3))
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "mesh '%s': normals are not all finite", name);
    if (d->uvs && !all_finite(d->uvs, nv * 2))
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "mesh '%s': uvs are not all finite", name);
    if (!grow((void **)&scene->meshes, &scene->mesh_cap, scene->mesh_count, sizeof(cv_mesh)))
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "mesh '%s': no memory for mesh %u", name, scene->mesh_count);

    cv_mesh m = { .vertex_count = d->vertex_count, .triangle_count = d->triangle_count };
    m.positions = malloc(nv * 3 * sizeof(float));
    m.normals = malloc(nv * 3 * sizeof(float));
    m.uvs = d->uvs ? malloc(nv * 2 * sizeof(float)) : NULL;
    m.indices = malloc(ni * sizeof(uint32_t));
    if (!m.positions || !m.normals || !m.indices || (d->uvs && !m.uvs)) {
        free(m.positions);
        free(m.normals);
        free(m.uvs);
        free(m.indices);
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "mesh '%s': no memory for %u vertices, %u triangles", name,
                        d->vertex_count, d->triangle_count);
    }
    memcpy(m.positions, d->positions, nv * 3 * sizeof(float));
    memcpy(m.indices, d->indices, ni * sizeof(uint32_t));
    if (d->uvs)
        memcpy(m.uvs, d->uvs, nv * 2 * sizeof(float));
    if (d->normals)
        memcpy(m.normals, d->normals, nv * 3 * sizeof(float));
    else
        compute_normals(&m);
    snprintf(m.name, sizeof m.name, "%s", name);
    scene->meshes[scene->mesh_count] = m;
    if (out_index)
        *out_index = scene->mesh_count;
    scene->mesh_count++;
    return CV_OK;
}

static cv_result check_image_ref(const cv_scene *scene, uint32_t ref, const char *field) {
    if (ref > scene->image_count)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "material %u: %s %u names image %u, the scene has %u images",
                        scene->material_count, field, ref, ref - 1, scene->image_count);
    return CV_OK;
}

static bool in_unit_interval(float x) { return x >= 0.0f && x <= 1.0f; } /* false for NaN */

cv_result cv_scene_add_material(cv_scene *scene, const cv_material *mat, uint32_t *out_index) {
    if (!scene || !mat)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_scene_add_material: scene or material is NULL");
    uint32_t i = scene->material_count;
    if (!all_finite(mat->base_color, 3) || !all_finite(mat->emission, 3) || !isfinite(mat->roughness) ||
        !isfinite(mat->metalness) || !isfinite(mat->transmission) || !isfinite(mat->ior))
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "material %u: a parameter is not finite", i);
    if (mat->ior < 1.0f)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "material %u: ior %g is below 1", i, (double)mat->ior);
    if (!in_unit_interval(mat->alpha))
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "material %u: alpha %g is not in [0, 1]", i, (double)mat->alpha);
    if (!in_unit_interval(mat->alpha_cutoff))
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "material %u: alpha_cutoff %g is not in [0, 1]", i,
                        (double)mat->alpha_cutoff);
    if (mat->alpha_mode != CV_ALPHA_OPAQUE && mat->alpha_mode != CV_ALPHA_MASK)
        return cv_error(CV_ERROR_INVALID_ARGUMENT,
                        "material %u: alpha_mode %d is not CV_ALPHA_OPAQUE or CV_ALPHA_MASK", i,
                        (int)mat->alpha_mode);
    if (!isfinite(mat->normal_scale))
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "material %u: normal_scale is not finite", i);
    cv_result r;
    if ((r = check_image_ref(scene, mat->base_color_image, "base_color_image")) != CV_OK ||
        (r = check_image_ref(scene, mat->metal_rough_image, "metal_rough_image")) != CV_OK ||
        (r = check_image_ref(scene, mat->normal_image, "normal_image")) != CV_OK ||
        (r = check_image_ref(scene, mat->emissive_image, "emissive_image")) != CV_OK)
        return r;
    if (!grow((void **)&scene->materials, &scene->material_cap, i, sizeof(cv_material)))
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "no memory for material %u", i);
    scene->materials[i] = *mat;
    if (out_index)
        *out_index = i;
    scene->material_count++;
    return CV_OK;
}

/* The mip chain's filter (scene.h): level k + 1 texel (x, y) is the average
 * of the level k texels in columns {2x, 2x + 1} and rows {2y, 2y + 1}, where
 * a side of 1 contributes its single column (row) {0}, and an odd side's last
 * destination column (row) also takes the source's last one, 2x + 2: three
 * columns (rows) then fold into that texel, each with weight 1/3. So a
 * destination texel averages 1, 2, 3, 4, 6 or 9 source texels, with equal
 * weights, per channel: (sum + count / 2) / count in integers (round to
 * nearest, halves up). Every source texel lands in exactly one destination
 * texel. */
static void mip_span(uint32_t src_side, uint32_t dst_side, uint32_t d, uint32_t *first, uint32_t *count) {
    if (src_side == 1) {
        *first = 0;
        *count = 1;
        return;
    }
    *first = 2 * d;
    *count = (d == dst_side - 1 && (src_side & 1)) ? 3 : 2;
}

static void build_mips(cv_image *im) {
    for (uint32_t k = 0; k + 1 < im->levels; k++) {
        uint32_t sw = cv_image_level_side(im->width, k), sh = cv_image_level_side(im->height, k);
        uint32_t dw = cv_image_level_side(im->width, k + 1), dh = cv_image_level_side(im->height, k + 1);
        const uint8_t *src = im->texels + 4 * im->level_offset[k];
        uint8_t *dst = im->texels + 4 * im->level_offset[k + 1];
        for (uint32_t y = 0; y < dh; y++) {
            uint32_t y0, ny;
            mip_span(sh, dh, y, &y0, &ny);
            for (uint32_t x = 0; x < dw; x++) {
                uint32_t x0, nx;
                mip_span(sw, dw, x, &x0, &nx);
                uint32_t sum[4] = { 0, 0, 0, 0 };
                for (uint32_t j = 0; j < ny; j++)
                    for (uint32_t i = 0; i < nx; i++) {
                        const uint8_t *t = src + 4 * ((size_t)(y0 + j) * sw + x0 + i);
                        for (int c = 0; c < 4; c++)
                            sum[c] += t[c];
                    }
                uint32_t n = nx * ny;
                for (int c = 0; c < 4; c++)
                    dst[4 * ((size_t)y * dw + x) + c] = (uint8_t)((sum[c] + n / 2) / n);
            }
        }
    }
}

uint64_t cv_image_stored_bytes(uint32_t width, uint32_t height) {
    if (width == 0 || height == 0 || width > CV_IMAGE_MAX_SIDE || height > CV_IMAGE_MAX_SIDE)
        return 0;
    uint64_t texels = 0;
    for (uint32_t k = 0; k < CV_IMAGE_MAX_LEVELS; k++) {
        texels += (uint64_t)cv_image_level_side(width, k) * cv_image_level_side(height, k);
        if ((width >> (k + 1)) == 0 && (height >> (k + 1)) == 0)
            break;
    }
    return texels * 4;
}

uint64_t cv_scene_image_bytes(const cv_scene *scene) { return scene ? scene->image_bytes : 0; }

cv_result cv_scene_add_image(cv_scene *scene, const cv_image_desc *d, uint32_t *out_index) {
    if (!scene || !d)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_scene_add_image: scene or desc is NULL");
    uint32_t index = scene->image_count;
    const char *name = d->name ? d->name : "";
    if (!d->rgba8)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "image %u ('%s'): rgba8 is NULL", index, name);
    if (d->width == 0 || d->height == 0 || d->width > CV_IMAGE_MAX_SIDE || d->height > CV_IMAGE_MAX_SIDE)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "image %u ('%s'): %ux%u texels (each side must be 1..%u)", index,
                        name, d->width, d->height, CV_IMAGE_MAX_SIDE);
    cv_image im = { .width = d->width, .height = d->height };
    uint32_t side = d->width > d->height ? d->width : d->height;
    im.levels = 1;
    while ((side >> im.levels) != 0)
        im.levels++;
    /* Sides <= 2^14: every count below fits easily in 64 bits. */
    for (uint32_t k = 0; k < im.levels; k++) {
        im.level_offset[k] = im.texel_count;
        im.texel_count += (uint64_t)cv_image_level_side(d->width, k) * cv_image_level_side(d->height, k);
    }
    uint64_t bytes = im.texel_count * 4;
    if (bytes > CV_SCENE_MAX_IMAGE_BYTES - scene->image_bytes)
        return cv_error(CV_ERROR_LIMIT_EXCEEDED,
                        "image %u ('%s'): %ux%u with its mip chain is %llu bytes; the scene's images would pass "
                        "%llu bytes (%llu already)",
                        index, name, d->width, d->height, (unsigned long long)bytes,
                        (unsigned long long)CV_SCENE_MAX_IMAGE_BYTES, (unsigned long long)scene->image_bytes);
    if (!grow((void **)&scene->images, &scene->image_cap, index, sizeof(cv_image)))
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "image %u ('%s'): no memory for the image table", index, name);
    im.texels = malloc((size_t)bytes);
    if (!im.texels)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "image %u ('%s'): no memory for %llu bytes of texels", index, name,
                        (unsigned long long)bytes);
    memcpy(im.texels, d->rgba8, (size_t)d->width * d->height * 4);
    build_mips(&im);
    snprintf(im.name, sizeof im.name, "%s", name);
    scene->images[index] = im;
    scene->image_bytes += bytes;
    if (out_index)
        *out_index = index;
    scene->image_count++;
    return CV_OK;
}

static cv_result check_transform(const float t[3][4], const char *what, uint32_t index) {
    float inv[3][4];
    if (!all_finite(&t[0][0], 12))
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "%s %u: transform is not finite", what, index);
    if (!cv_transform_invert(t, inv))
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "%s %u: transform is singular", what, index);
    return CV_OK;
}

cv_result cv_scene_add_instance(cv_scene *scene, const cv_instance *inst, uint32_t *out_index) {
    if (!scene || !inst)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_scene_add_instance: scene or instance is NULL");
    uint32_t i = scene->instance_count;
    if (inst->mesh >= scene->mesh_count)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "instance %u: mesh %u out of range (%u meshes)", i, inst->mesh,
                        scene->mesh_count);
    if (inst->material >= scene->material_count)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "instance %u: material %u out of range (%u materials)", i,
                        inst->material, scene->material_count);
    cv_result r = check_transform(inst->transform, "instance", i);
    if (r != CV_OK)
        return r;
    if (!grow((void **)&scene->instances, &scene->instance_cap, i, sizeof(cv_instance)))
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "no memory for instance %u", i);
    scene->instances[i] = *inst;
    if (out_index)
        *out_index = i;
    scene->instance_count++;
    return CV_OK;
}

cv_result cv_scene_add_camera(cv_scene *scene, const cv_camera *cam, uint32_t *out_index) {
    if (!scene || !cam)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_scene_add_camera: scene or camera is NULL");
    uint32_t i = scene->camera_count;
    float f[3], side[3];
    v3_sub(f, cam->target, cam->position);
    v3_cross(side, f, cam->up);
    if (!all_finite(cam->position, 3) || !all_finite(cam->target, 3) || !all_finite(cam->up, 3))
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "camera %u: a vector is not finite", i);
    if (!(v3_dot(f, f) > 0.0f) || !(v3_dot(side, side) > 0.0f))
        return cv_error(CV_ERROR_INVALID_ARGUMENT,
                        "camera %u: target equals position or up is parallel to the view direction", i);
    if (!(cam->vertical_fov > 0.0f && cam->vertical_fov < 3.14159f))
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "camera %u: vertical_fov %g is not in (0, pi)", i,
                        (double)cam->vertical_fov);
    if (!grow((void **)&scene->cameras, &scene->camera_cap, i, sizeof(cv_camera)))
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "no memory for camera %u", i);
    scene->cameras[i] = *cam;
    if (out_index)
        *out_index = i;
    scene->camera_count++;
    return CV_OK;
}

cv_result cv_scene_add_light(cv_scene *scene, const cv_light *light, uint32_t *out_index) {
    if (!scene || !light)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_scene_add_light: scene or light is NULL");
    uint32_t i = scene->light_count;
    if (light->type != CV_LIGHT_DIRECTIONAL && light->type != CV_LIGHT_POINT)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "light %u: unknown type %d", i, (int)light->type);
    if (!all_finite(light->direction, 3) || !all_finite(light->position, 3) || !all_finite(light->color, 3) ||
        !isfinite(light->intensity))
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "light %u: a parameter is not finite", i);
    if (light->type == CV_LIGHT_DIRECTIONAL && !(v3_dot(light->direction, light->direction) > 0.0f))
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "light %u: directional light with a zero direction", i);
    if (!grow((void **)&scene->lights, &scene->light_cap, i, sizeof(cv_light)))
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "no memory for light %u", i);
    cv_light l = *light;
    if (l.type == CV_LIGHT_DIRECTIONAL)
        v3_normalize(l.direction, l.direction);
    scene->lights[i] = l;
    if (out_index)
        *out_index = i;
    scene->light_count++;
    return CV_OK;
}

cv_result cv_scene_set_instance_transform(cv_scene *scene, uint32_t instance, const float t[3][4]) {
    if (!scene || !t)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_scene_set_instance_transform: scene or transform is NULL");
    if (instance >= scene->instance_count)
        return cv_error(CV_ERROR_OUT_OF_RANGE, "instance %u out of range (%u instances)", instance,
                        scene->instance_count);
    cv_result r = check_transform(t, "instance", instance);
    if (r != CV_OK)
        return r;
    memcpy(scene->instances[instance].transform, t, sizeof(float[3][4]));
    return CV_OK;
}

cv_result cv_scene_set_mesh_positions(cv_scene *scene, uint32_t mesh, const float *positions, uint32_t vertex_count) {
    if (!scene || !positions)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_scene_set_mesh_positions: scene or positions is NULL");
    if (mesh >= scene->mesh_count)
        return cv_error(CV_ERROR_OUT_OF_RANGE, "mesh %u out of range (%u meshes)", mesh, scene->mesh_count);
    cv_mesh *m = &scene->meshes[mesh];
    if (vertex_count != m->vertex_count)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "mesh %u ('%s'): %u positions given, mesh has %u vertices", mesh,
                        m->name, vertex_count, m->vertex_count);
    if (!all_finite(positions, (size_t)vertex_count * 3))
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "mesh %u ('%s'): new positions are not all finite", mesh, m->name);
    memcpy(m->positions, positions, (size_t)vertex_count * 3 * sizeof(float));
    return CV_OK;
}

uint32_t cv_scene_mesh_count(const cv_scene *s) { return s->mesh_count; }
uint32_t cv_scene_material_count(const cv_scene *s) { return s->material_count; }
uint32_t cv_scene_image_count(const cv_scene *s) { return s->image_count; }
uint32_t cv_scene_instance_count(const cv_scene *s) { return s->instance_count; }
uint32_t cv_scene_camera_count(const cv_scene *s) { return s->camera_count; }
uint32_t cv_scene_light_count(const cv_scene *s) { return s->light_count; }

uint64_t cv_scene_triangle_count(const cv_scene *s) {
    uint64_t n = 0;
    for (uint32_t i = 0; i < s->mesh_count; i++)
        n += s->meshes[i].triangle_count;
    return n;
}

uint64_t cv_scene_world_triangle_count(const cv_scene *s) {
    uint64_t n = 0;
    for (uint32_t i = 0; i < s->instance_count; i++)
        n += s->meshes[s->instances[i].mesh].triangle_count;
    return n;
}

const cv_mesh *cv_scene_mesh(const cv_scene *s, uint32_t i) { return i < s->mesh_count ? &s->meshes[i] : NULL; }
const cv_material *cv_scene_material(const cv_scene *s, uint32_t i) {
    return i < s->material_count ? &s->materials[i] : NULL;
}
const cv_image *cv_scene_image(const cv_scene *s, uint32_t i) { return i < s->image_count ? &s->images[i] : NULL; }
const cv_instance *cv_scene_instance(const cv_scene *s, uint32_t i) {
    return i < s->instance_count ? &s->instances[i] : NULL;
}
const cv_camera *cv_scene_camera(const cv_scene *s, uint32_t i) {
    return i < s->camera_count ? &s->cameras[i] : NULL;
}
const cv_light *cv_scene_light(const cv_scene *s, uint32_t i) { return i < s->light_count ? &s->lights[i] : NULL; }

void cv_scene_bounds(const cv_scene *s, float bmin[3], float bmax[3]) {
    v3_set(bmin, INFINITY, INFINITY, INFINITY);
    v3_set(bmax, -INFINITY, -INFINITY, -INFINITY);
    for (uint32_t i = 0; i < s->instance_count; i++) {
        const cv_instance *inst = &s->instances[i];
        const cv_mesh *m = &s->meshes[inst->mesh];
        for (uint32_t v = 0; v < m->vertex_count; v++) {
            float p[3];
            cv_transform_point(inst->transform, &m->positions[3 * v], p);
            for (int k = 0; k < 3; k++) {
                bmin[k] = v3_min_f(bmin[k], p[k]);
                bmax[k] = v3_max_f(bmax[k], p[k]);
            }
        }
    }
    if (s->instance_count == 0) {
        v3_set(bmin, 0.0f, 0.0f, 0.0f);
        v3_set(bmax, 0.0f, 0.0f, 0.0f);
    }
}

void cv_scene_world_triangle(const cv_scene *s, uint32_t instance, uint32_t triangle, float out[3][3]) {
    assert(instance < s->instance_count);
    const cv_instance *inst = &s->instances[instance];
    const cv_mesh *m = &s->meshes[inst->mesh];
    assert(triangle < m->triangle_count);
    for (int k = 0; k < 3; k++)
        cv_transform_point(inst->transform, &m->positions[3 * m->indices[3 * triangle + k]], out[k]);
}

cv_camera cv_scene_framing_camera(const cv_scene *s) {
    /* In double: the diagonal of a scene 2e19 wide squared overflows a float,
     * and one 1e-5 wide far from the origin needs more than float precision
     * between its centre and the camera. */
    float bmin[3], bmax[3];
    cv_scene_bounds(s, bmin, bmax);
    double center[3], d2 = 0.0;
    for (int k = 0; k < 3; k++) {
        center[k] = 0.5 * ((double)bmin[k] + bmax[k]);
        d2 += ((double)bmax[k] - bmin[k]) * ((double)bmax[k] - bmin[k]);
    }
    double radius = 0.5 * sqrt(d2);
    if (!(radius > 0.0))
        radius = 1.0;
    /* A sphere of that radius fits a 60 degree cone at distance 2r; 2.2r leaves a margin. */
    const double dir = 0.57735026918962576;
    cv_camera c = { .up = { 0.0f, 1.0f, 0.0f }, .vertical_fov = 1.04719755f };
    for (int k = 0; k < 3; k++) {
        c.position[k] = (float)(center[k] + dir * 2.2 * radius);
        c.target[k] = (float)center[k];
    }
    return c;
}

cv_result cv_scene_check_framing(const cv_scene *s) {
    float bmin[3], bmax[3];
    cv_scene_bounds(s, bmin, bmax);
    double extent = 0.0, offset = 0.0, d2 = 0.0;
    for (int k = 0; k < 3; k++) {
        if (!isfinite(bmin[k]) || !isfinite(bmax[k]))
            return cv_error(CV_ERROR_OUT_OF_RANGE, "scene bounds are not finite: it cannot be framed");
        extent = fmax(extent, (double)bmax[k] - bmin[k]);
        offset = fmax(offset, fabs(0.5 * ((double)bmin[k] + bmax[k])));
        d2 += ((double)bmax[k] - bmin[k]) * ((double)bmax[k] - bmin[k]);
    }
    if (!(extent > 0.0))
        return cv_error(CV_ERROR_OUT_OF_RANGE,
                        "scene is degenerate (all its points are one point): it cannot be "
                        "framed");
    if (extent < CV_SCENE_MIN_EXTENT)
        return cv_error(CV_ERROR_OUT_OF_RANGE,
                        "scene extent %g is below %g: too small for float precision in the "
                        "renderer",
                        extent, CV_SCENE_MIN_EXTENT);
    if (extent < offset * CV_SCENE_MIN_RELATIVE_EXTENT)
        return cv_error(CV_ERROR_OUT_OF_RANGE,
                        "scene extent %g at %g from the origin is below float precision there "
                        "(it must be at least %g of its distance)",
                        extent, offset, CV_SCENE_MIN_RELATIVE_EXTENT);
    if (offset + 4.4 * sqrt(d2) > CV_SCENE_MAX_COORDINATE)
        return cv_error(CV_ERROR_OUT_OF_RANGE,
                        "scene extent %g at %g from the origin: the framing camera and its "
                        "far plane would pass %g, beyond what float arithmetic in the renderer keeps finite",
                        extent, offset, CV_SCENE_MAX_COORDINATE);
    return CV_OK;
}

void cv_transform_identity(float out[3][4]) {
    memset(out, 0, sizeof(float[3][4]));
    out[0][0] = out[1][1] = out[2][2] = 1.0f;
}

void cv_transform_multiply(const float a[3][4], const float b[3][4], float out[3][4]) {
    float r[3][4];
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 4; j++)
            r[i][j] = a[i][0] * b[0][j] + a[i][1] * b[1][j] + a[i][2] * b[2][j];
        r[i][3] += a[i][3];
    }
    memcpy(out, r, sizeof r);
}

bool cv_transform_invert(const float t[3][4], float out[3][4]) {
    /* Inverse of the 3x3 part by cofactors, in double: transforms of large
     * scenes combine big translations with small scales. */
    double m[3][3];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            m[i][j] = t[i][j];
    double c00 = m[1][1] * m[2][2] - m[1][2] * m[2][1];
    double c01 = m[1][2] * m[2][0] - m[1][0] * m[2][2];
    double c02 = m[1][0] * m[2][1] - m[1][1] * m[2][0];
    double det = m[0][0] * c00 + m[0][1] * c01 + m[0][2] * c02;
    double scale = fabs(m[0][0]) + fabs(m[0][1]) + fabs(m[0][2]) + fabs(m[1][0]) + fabs(m[1][1]) + fabs(m[1][2]) +
                   fabs(m[2][0]) + fabs(m[2][1]) + fabs(m[2][2]);
    if (!isfinite(det) || !(fabs(det) > 1e-12 * scale * scale * scale))
        return false;
    double inv[3][3] = {
        { c00, m[0][2] * m[2][1] - m[0][1] * m[2][2], m[0][1] * m[1][2] - m[0][2] * m[1][1] },
        { c01, m[0][0] * m[2][2] - m[0][2] * m[2][0], m[0][2] * m[1][0] - m[0][0] * m[1][2] },
        { c02, m[0][1] * m[2][0] - m[0][0] * m[2][1], m[0][0] * m[1][1] - m[0][1] * m[1][0] },
    };
    float r[3][4];
    for (int i = 0; i < 3; i++) {
        double tr = 0.0;
        for (int j = 0; j < 3; j++) {
            inv[i][j] /= det;
            tr -= inv[i][j] * t[j][3];
        }
        for (int j = 0; j < 3; j++)
            r[i][j] = (float)inv[i][j];
        r[i][3] = (float)tr;
    }
    if (!all_finite(&r[0][0], 12))
        return false;
    memcpy(out, r, sizeof r);
    return true;
}

void cv_transform_point(const float t[3][4], const float p[3], float out[3]) {
    float x = t[0][0] * p[0] + t[0][1] * p[1] + t[0][2] * p[2] + t[0][3];
    float y = t[1][0] * p[0] + t[1][1] * p[1] + t[1][2] * p[2] + t[1][3];
    float z = t[2][0] * p[0] + t[2][1] * p[1] + t[2][2] * p[2] + t[2][3];
    out[0] = x;
    out[1] = y;
    out[2] = z;
}
