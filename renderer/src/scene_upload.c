/* Builds the renderer's vertex list, uvs, material table and image pool from a scene. */
#include "scene_upload.h"

#include "corvid/material_eval.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Normals go through the inverse transpose of the instance's 3x3 part. */
static void normal_matrix(const float t[3][4], float out[3][3]) {
    float inv[3][4];
    if (!cv_transform_invert(t, inv)) {
        for (int r = 0; r < 3; r++)
            for (int c = 0; c < 3; c++)
                out[r][c] = r == c;
        return;
    }
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 3; c++)
            out[r][c] = inv[c][r];
}

static void transform_normal(const float m[3][3], const float n[3], float out[3]) {
    for (int r = 0; r < 3; r++)
        out[r] = m[r][0] * n[0] + m[r][1] * n[1] + m[r][2] * n[2];
    float l = sqrtf(out[0] * out[0] + out[1] * out[1] + out[2] * out[2]);
    if (l > 0.0f)
        for (int r = 0; r < 3; r++)
            out[r] /= l;
}

typedef struct welded {
    float p[3];
    uint32_t index;
} welded;

static int compare_welded(const void *a, const void *b) {
    const welded *x = a, *y = b;
    for (int k = 0; k < 3; k++)
        if (x->p[k] != y->p[k])
            return x->p[k] < y->p[k] ? -1 : 1;
    return x->index < y->index ? -1 : x->index > y->index;
}

static int compare_u64(const void *a, const void *b) {
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return x < y ? -1 : x > y;
}

static bool has_edge(const uint64_t *edges, size_t n, uint64_t e) {
    size_t lo = 0, hi = n;
    while (lo < hi) {
        size_t mid = (lo + hi) / 2;
        if (edges[mid] < e)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo < n && edges[lo] == e;
}

/* Whether a mesh is closed and consistently wound: with vertices welded by
 * equal position, every directed edge appears once and its reverse once. Only
 * closed meshes may have their back faces dropped by the G-buffer (a wall of
 * one sheet has no inside). *ok is false without memory. */
static bool mesh_closed(const cv_mesh *mesh, bool *ok) {
    uint32_t nv = mesh->vertex_count, nt = mesh->triangle_count;
    welded *w = malloc((size_t)nv * sizeof(*w));
    uint32_t *canon = malloc((size_t)nv * sizeof(*canon));
    uint64_t *edges = malloc((size_t)nt * 3 * sizeof(*edges));
    bool closed = w && canon && edges;
    *ok = closed;
    for (uint32_t v = 0; closed && v < nv; v++) {
        memcpy(w[v].p, &mesh->positions[3 * v], sizeof(w[v].p));
        w[v].index = v;
    }
    if (closed)
        qsort(w, nv, sizeof(*w), compare_welded);
    for (uint32_t v = 0, first = 0; closed && v < nv; v++) {
        if (v > 0 && memcmp(w[v].p, w[v - 1].p, sizeof(w[v].p)) != 0)
            first = v;
        canon[w[v].index] = w[first].index;
    }
    for (uint32_t t = 0; closed && t < nt; t++)
        for (int k = 0; k < 3; k++) {
            uint32_t a = canon[mesh->indices[3 * t + k]], b = canon[mesh->indices[3 * t + (k + 1) % 3]];
            if (a == b)
                closed = false; /* degenerate: no winding to trust */
            edges[3 * (size_t)t + k] = (uint64_t)a << 32 | b;
        }
    if (closed)
        qsort(edges, (size_t)nt * 3, sizeof(*edges), compare_u64);
    for (size_t e = 0; closed && e < (size_t)nt * 3; e++) {
        if (e > 0 && edges[e] == edges[e - 1])
            closed = false;
        else if (!has_edge(edges, (size_t)nt * 3, edges[e] << 32 | edges[e] >> 32))
            closed = false;
    }
    free(w);
    free(canon);
    free(edges);
    return closed;
}

/* The image table and pool: every level of every image, one uint a texel
 * (the RGBA8 bytes as they lie: r in the low byte). */
static cv_result build_images(const cv_scene *scene, render_scene_data *out) {
    uint32_t images = cv_scene_image_count(scene);
    uint64_t texels = 0;
    for (uint32_t i = 0; i < images; i++) {
        const cv_image *im = cv_scene_image(scene, i);
        for (uint32_t l = 0; l < im->levels; l++)
            texels += (uint64_t)cv_image_level_side(im->width, l) * cv_image_level_side(im->height, l);
    }
    if (texels > UINT32_MAX)
        return cv_error(CV_ERROR_LIMIT_EXCEEDED, "renderer: %llu texels of images (at most 2^32 - 1)",
                        (unsigned long long)texels);
    out->image_count = images;
    out->image_texels = texels ? texels : 1;
    out->image_table_bytes = RENDER_IMAGE_TABLE_HEADER * 4 + (images ? images : 1) * sizeof(render_image);
    out->image_pool = calloc(out->image_texels, sizeof(uint32_t));
    out->image_table = calloc(out->image_table_bytes, 1);
    if (!out->image_pool || !out->image_table)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "renderer: %llu texels of images", (unsigned long long)texels);
    float *lut = (float *)out->image_table;
    for (uint32_t b = 0; b < 256; b++) {
        lut[b] = cv_srgb_to_linear((uint8_t)b);
        lut[256 + b] = (float)b / 255.0f;
    }
    render_image *table = (render_image *)(out->image_table + RENDER_IMAGE_TABLE_HEADER);
    uint64_t at = 0;
    for (uint32_t i = 0; i < images; i++) {
        const cv_image *im = cv_scene_image(scene, i);
        table[i] = (render_image){ (uint32_t)at, im->width, im->height, im->levels };
        for (uint32_t l = 0; l < im->levels;
             l++) { /* levels packed one after the other, whatever the scene's spacing */
            uint64_t n = (uint64_t)cv_image_level_side(im->width, l) * cv_image_level_side(im->height, l);
            memcpy(&out->image_pool[at], im->texels + im->level_offset[l] * 4, n * 4);
            at += n;
        }
    }
    return CV_OK;
}

cv_result render_scene_data_build(const cv_scene *scene, render_scene_data *out) {
    memset(out, 0, sizeof(*out));
    uint64_t triangles = cv_scene_world_triangle_count(scene);
    if (triangles == 0)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "renderer: the scene has no triangles");
    out->vertex_count = triangles * 3;
    out->vertices = malloc(out->vertex_count * sizeof(render_vertex));
    out->uvs = calloc(out->vertex_count * 2, sizeof(float));
    out->material_count = cv_scene_material_count(scene) ? cv_scene_material_count(scene) : 1;
    out->materials = calloc(out->material_count, sizeof(render_material));
    out->instance_count = cv_scene_instance_count(scene);
    out->instance_first = calloc(out->instance_count + 1, sizeof(uint32_t));
    if (!out->vertices || !out->uvs || !out->materials || !out->instance_first) {
        render_scene_data_free(out);
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "renderer: %llu vertices", (unsigned long long)out->vertex_count);
    }
    uint64_t v = 0;
    for (uint32_t i = 0; i < cv_scene_instance_count(scene); i++) {
        const cv_instance *inst = cv_scene_instance(scene, i);
        const cv_mesh *mesh = cv_scene_mesh(scene, inst->mesh);
        float nm[3][3];
        normal_matrix(inst->transform, nm);
        uint32_t material = inst->material < out->material_count ? inst->material : 0;
        out->instance_first[i] = (uint32_t)(v / 3); /* < 2^31 triangles (the BVH builders' limit) */
        bool ok;
        float closed = mesh_closed(mesh, &ok) ? 1.0f : 0.0f;
        if (!ok) {
            render_scene_data_free(out);
            return cv_error(CV_ERROR_OUT_OF_MEMORY, "renderer: edges of mesh %u", inst->mesh);
        }
        for (uint32_t t = 0; t < mesh->triangle_count; t++) {
            float world[3][3];
            cv_scene_world_triangle(scene, i, t, world);
            for (int k = 0; k < 3; k++, v++) {
                render_vertex *rv = &out->vertices[v];
                memcpy(rv->position, world[k], sizeof(world[k]));
                rv->material = material;
                transform_normal(nm, &mesh->normals[3 * mesh->indices[3 * t + k]], rv->normal);
                rv->closed = closed;
                if (mesh->uvs)
                    memcpy(&out->uvs[2 * v], &mesh->uvs[2 * mesh->indices[3 * t + k]], 2 * sizeof(float));
            }
        }
    }
    for (uint32_t m = 0; m < out->material_count; m++) {
        cv_material mat = cv_scene_material_count(scene) ? *cv_scene_material(scene, m) : cv_material_default();
        render_material *rm = &out->materials[m];
        memcpy(rm->base_color_roughness, mat.base_color, sizeof(mat.base_color));
        rm->base_color_roughness[3] = mat.roughness;
        memcpy(rm->emission_metalness, mat.emission, sizeof(mat.emission));
        rm->emission_metalness[3] = mat.metalness;
        rm->base_color_image = mat.base_color_image;
        rm->metal_rough_image = mat.metal_rough_image;
        rm->normal_image = mat.normal_image;
        rm->emissive_image = mat.emissive_image;
        rm->alpha = mat.alpha;
        rm->alpha_mode = (uint32_t)mat.alpha_mode;
        rm->alpha_cutoff = mat.alpha_cutoff;
        rm->normal_scale = mat.normal_scale;
    }
    cv_result res = build_images(scene, out);
    if (res != CV_OK) {
        render_scene_data_free(out);
        return res;
    }
    /* The sun: the scene's first directional light, else a default one. */
    float dir[3] = { -0.3f, -1.0f, -0.2f }, color[3] = { 1.0f, 0.95f, 0.85f }, irradiance = 3.0f;
    bool have_sun = false;
    out->lights = calloc(cv_scene_light_count(scene) + 1, sizeof(render_light));
    if (!out->lights) {
        render_scene_data_free(out);
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "renderer: lights");
    }
    for (uint32_t l = 0; l < cv_scene_light_count(scene); l++) {
        const cv_light *light = cv_scene_light(scene, l);
        if (light->type == CV_LIGHT_DIRECTIONAL && !have_sun) {
            memcpy(dir, light->direction, sizeof(dir));
            memcpy(color, light->color, sizeof(color));
            irradiance = light->intensity;
            have_sun = true;
        } else if (light->type == CV_LIGHT_POINT) {
            render_light *rl = &out->lights[out->light_count++];
            memcpy(rl->position, light->position, sizeof(rl->position));
            memcpy(rl->color, light->color, sizeof(rl->color));
            rl->intensity = light->intensity;
        }
    }
    float len = sqrtf(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]);
    for (int k = 0; k < 3; k++) {
        out->sun_direction[k] = dir[k] / len;
        out->sun_color[k] = color[k];
    }
    out->sun_irradiance = irradiance;
    cv_scene_bounds(scene, out->bounds_min, out->bounds_max);
    /* In double: a side of 2e19 squared overflows a float. */
    double d2 = 0.0;
    for (int k = 0; k < 3; k++)
        d2 += ((double)out->bounds_max[k] - out->bounds_min[k]) * ((double)out->bounds_max[k] - out->bounds_min[k]);
    out->diagonal = (float)sqrt(d2);
    return CV_OK;
}

void render_scene_data_free(render_scene_data *d) {
    free(d->vertices);
    free(d->uvs);
    free(d->materials);
    free(d->image_table);
    free(d->image_pool);
    free(d->instance_first);
    free(d->lights);
    memset(d, 0, sizeof(*d));
}
