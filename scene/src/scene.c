/* The scene model: growable arrays of meshes, materials, instances, cameras
 * and lights, with validation on the way in. */
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

cv_result cv_scene_add_material(cv_scene *scene, const cv_material *mat, uint32_t *out_index) {
    if (!scene || !mat)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_scene_add_material: scene or material is NULL");
    if (!all_finite(mat->base_color, 3) || !all_finite(mat->emission, 3) || !isfinite(mat->roughness) ||
        !isfinite(mat->metalness) || !isfinite(mat->transmission) || !isfinite(mat->ior))
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "material %u: a parameter is not finite", scene->material_count);
    if (mat->ior < 1.0f)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "material %u: ior %g is below 1", scene->material_count,
                        (double)mat->ior);
    if (!grow((void **)&scene->materials, &scene->material_cap, scene->material_count, sizeof(cv_material)))
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "no memory for material %u", scene->material_count);
    scene->materials[scene->material_count] = *mat;
    if (out_index)
        *out_index = scene->material_count;
    scene->material_count++;
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
