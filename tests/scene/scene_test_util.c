/* Scene test helpers: hashing, brute-force tracing, model paths. */
#include "scene_test_util.h"

#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <unistd.h>

#include "check.h"
#include "corvid/trace_cpu.h"

uint64_t fnv1a(uint64_t h, const void *data, size_t size) {
    const unsigned char *p = data;
    for (size_t i = 0; i < size; i++) {
        h ^= p[i];
        h *= 0x100000001B3ull;
    }
    return h;
}

/* Field by field, so padding (none today) could never matter. */
static uint64_t hash_material(uint64_t h, const cv_material *m) {
    uint32_t mode = (uint32_t)m->alpha_mode;
    h = fnv1a(h, m->base_color, sizeof m->base_color);
    h = fnv1a(h, &m->roughness, sizeof m->roughness);
    h = fnv1a(h, &m->metalness, sizeof m->metalness);
    h = fnv1a(h, m->emission, sizeof m->emission);
    h = fnv1a(h, &m->transmission, sizeof m->transmission);
    h = fnv1a(h, &m->ior, sizeof m->ior);
    h = fnv1a(h, &m->alpha, sizeof m->alpha);
    h = fnv1a(h, &mode, sizeof mode);
    h = fnv1a(h, &m->alpha_cutoff, sizeof m->alpha_cutoff);
    h = fnv1a(h, &m->base_color_image, sizeof m->base_color_image);
    h = fnv1a(h, &m->metal_rough_image, sizeof m->metal_rough_image);
    h = fnv1a(h, &m->normal_image, sizeof m->normal_image);
    h = fnv1a(h, &m->normal_scale, sizeof m->normal_scale);
    h = fnv1a(h, &m->emissive_image, sizeof m->emissive_image);
    return h;
}

uint64_t scene_hash(const cv_scene *s) {
    uint64_t h = 0xCBF29CE484222325ull;
    for (uint32_t i = 0; i < cv_scene_mesh_count(s); i++) {
        const cv_mesh *m = cv_scene_mesh(s, i);
        h = fnv1a(h, m->positions, (size_t)m->vertex_count * 3 * sizeof(float));
        h = fnv1a(h, m->normals, (size_t)m->vertex_count * 3 * sizeof(float));
        if (m->uvs)
            h = fnv1a(h, m->uvs, (size_t)m->vertex_count * 2 * sizeof(float));
        h = fnv1a(h, m->indices, (size_t)m->triangle_count * 3 * sizeof(uint32_t));
        h = fnv1a(h, m->name, sizeof m->name);
    }
    for (uint32_t i = 0; i < cv_scene_material_count(s); i++)
        h = hash_material(h, cv_scene_material(s, i));
    for (uint32_t i = 0; i < cv_scene_image_count(s); i++) {
        const cv_image *im = cv_scene_image(s, i);
        h = fnv1a(h, &im->width, sizeof im->width);
        h = fnv1a(h, &im->height, sizeof im->height);
        h = fnv1a(h, im->texels, (size_t)im->texel_count * 4);
        h = fnv1a(h, im->name, sizeof im->name);
    }
    for (uint32_t i = 0; i < cv_scene_instance_count(s); i++)
        h = fnv1a(h, cv_scene_instance(s, i), sizeof(cv_instance));
    for (uint32_t i = 0; i < cv_scene_camera_count(s); i++)
        h = fnv1a(h, cv_scene_camera(s, i), sizeof(cv_camera));
    for (uint32_t i = 0; i < cv_scene_light_count(s); i++)
        h = fnv1a(h, cv_scene_light(s, i), sizeof(cv_light));
    return h;
}

cv_bvh_tri *brute_force_triangles(const cv_scene *scene, uint32_t *count) {
    cv_bvh_tri *tris = malloc((size_t)cv_scene_world_triangle_count(scene) * sizeof(cv_bvh_tri) + 1);
    uint32_t n = 0;
    for (uint32_t i = 0; tris && i < cv_scene_instance_count(scene); i++) {
        uint32_t mesh_tris = cv_scene_mesh(scene, cv_scene_instance(scene, i)->mesh)->triangle_count;
        for (uint32_t t = 0; t < mesh_tris; t++) {
            float v[3][3];
            cv_scene_world_triangle(scene, i, t, v);
            tris[n++] = cv_bvh_tri_make(v, t, i);
        }
    }
    *count = n;
    return tris;
}

bool brute_force_trace(const cv_bvh_tri *tris, uint32_t count, const cv_ray *ray, uint32_t flags, cv_hit *hit) {
    *hit = cv_hit_miss();
    float limit = ray->tmax;
    bool cull = (flags & CV_TRACE_CULL_BACK_FACES) != 0;
    for (uint32_t k = 0; k < count; k++) {
        float t, u, v;
        if (!cv_intersect_triangle(&tris[k], ray, limit, cull, &t, &u, &v))
            continue;
        *hit = (cv_hit){ .t = t, .u = u, .v = v, .triangle = tris[k].prim, .instance = tris[k].instance };
        limit = t;
        if (flags & CV_TRACE_ANY_HIT)
            return true;
    }
    return hit->triangle != CV_BVH_INVALID;
}

typedef struct brute_job {
    const cv_bvh_tri *tris;
    uint32_t count;
    const cv_ray *rays;
    uint32_t begin, end, flags, hits;
    cv_hit *out;
} brute_job;

static void *brute_range(void *arg) {
    brute_job *j = arg;
    for (uint32_t i = j->begin; i < j->end; i++)
        j->hits += brute_force_trace(j->tris, j->count, &j->rays[i], j->flags, &j->out[i]);
    return NULL;
}

uint32_t brute_force_batch(const cv_bvh_tri *tris, uint32_t count, const cv_ray *rays, uint32_t n, uint32_t flags,
                           cv_hit *hits) {
    enum { JOBS = 8 };
    long cpus = sysconf(_SC_NPROCESSORS_ONLN);
    uint32_t threads = cpus < 1 ? 1 : cpus > JOBS ? JOBS : (uint32_t)cpus;
    brute_job jobs[JOBS];
    pthread_t tids[JOBS];
    bool started[JOBS] = { false };
    for (uint32_t t = 0; t < threads; t++)
        jobs[t] = (brute_job){
            tris,  count, rays, (uint32_t)((uint64_t)n * t / threads), (uint32_t)((uint64_t)n * (t + 1) / threads),
            flags, 0,     hits
        };
    for (uint32_t t = 1; t < threads; t++)
        started[t] = pthread_create(&tids[t], NULL, brute_range, &jobs[t]) == 0;
    for (uint32_t t = 0; t < threads; t++)
        if (!started[t])
            brute_range(&jobs[t]);
    uint32_t total = 0;
    for (uint32_t t = 0; t < threads; t++) {
        if (started[t])
            pthread_join(tids[t], NULL);
        total += jobs[t].hits;
    }
    return total;
}

const char *model_path(const char *relative) {
    static char path[1024];
    snprintf(path, sizeof path, "%s/%s", CORVID_ASSIMP_MODELS, relative);
    return path;
}

bool file_exists(const char *path) {
    struct stat st;
    return stat(path, &st) == 0;
}

void write_whole_file(const char *path, const void *data, size_t size) {
    FILE *f = fopen(path, "wb");
    CHECK(f != NULL);
    if (!f)
        return;
    CHECK(fwrite(data, 1, size, f) == size);
    fclose(f);
}

void *read_whole_file(const char *path, size_t *size) {
    *size = 0;
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    void *data = n >= 0 ? malloc((size_t)n + 1) : NULL;
    if (data && fread(data, 1, (size_t)n, f) != (size_t)n) {
        free(data);
        data = NULL;
    }
    fclose(f);
    if (data)
        *size = (size_t)n;
    return data;
}
