/* Ray-set generation. Every random number is drawn from a stream seeded by
 * (seed, kind, ray or pixel index), so a ray never depends on the others or
 * on the order of generation. */
#include "corvid/ray_sets.h"

#include <math.h>
#include <stdlib.h>

#include "det_math.h"
#include "prng.h"
#include "vec3.h"

#define TILE 4u

static const char *const kind_names[CV_RAY_KIND_COUNT] = {
    "primary", "shadow", "ao_short", "ao_long", "diffuse", "reflection", "random",
};

const char *cv_ray_kind_name(cv_ray_kind kind) {
    return (unsigned)kind < CV_RAY_KIND_COUNT ? kind_names[kind] : "unknown";
}

bool cv_ray_kind_is_occlusion(cv_ray_kind kind) {
    return kind == CV_RAYS_SHADOW || kind == CV_RAYS_AO_SHORT || kind == CV_RAYS_AO_LONG;
}

void cv_ray_set_free(cv_ray_set *set) {
    if (!set)
        return;
    free(set->rays);
    set->rays = NULL;
    set->count = 0;
}

/* The descriptor with defaults filled in. */
static cv_ray_set_desc resolve(const cv_scene *scene, const cv_ray_set_desc *in, cv_camera *camera_storage) {
    cv_ray_set_desc d = in ? *in : (cv_ray_set_desc){ 0 };
    if (!d.width)
        d.width = 256;
    if (!d.height)
        d.height = 256;
    if (!d.camera) {
        *camera_storage = cv_scene_camera_count(scene) ? *cv_scene_camera(scene, 0) : cv_scene_framing_camera(scene);
        d.camera = camera_storage;
    }
    if (v3_dot(d.sun_direction, d.sun_direction) == 0.0f) {
        v3_set(d.sun_direction, -0.3f, -1.0f, -0.2f);
        for (uint32_t i = 0; i < cv_scene_light_count(scene); i++) {
            const cv_light *l = cv_scene_light(scene, i);
            if (l->type == CV_LIGHT_DIRECTIONAL) {
                v3_copy(d.sun_direction, l->direction);
                break;
            }
        }
    }
    v3_normalize(d.sun_direction, d.sun_direction);
    if (d.ao_short_length == 0.0f)
        d.ao_short_length = 0.5f;
    if (!d.random_count)
        d.random_count = 65536;
    return d;
}

static cv_result make_primary(const cv_ray_set_desc *d, cv_ray_set *out) {
    const cv_camera *c = d->camera;
    float fwd[3], right[3], up[3];
    v3_sub(fwd, c->target, c->position);
    v3_normalize(fwd, fwd);
    v3_cross(right, fwd, c->up);
    v3_normalize(right, right);
    v3_cross(up, right, fwd);
    double s, co;
    cvs_sincos(0.5 * c->vertical_fov, &s, &co);
    const float tan_half = (float)(s / co), aspect = (float)d->width / (float)d->height;
    uint64_t count = (uint64_t)d->width * d->height;
    if (count > UINT32_MAX)
        return cv_error(CV_ERROR_LIMIT_EXCEEDED, "primary rays: %u x %u is over 2^32 rays", d->width, d->height);
    out->rays = malloc(count * sizeof(cv_ray));
    if (!out->rays)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "primary rays: no memory for %llu rays", (unsigned long long)count);
    uint32_t n = 0;
    for (uint32_t ty = 0; ty < d->height; ty += TILE) {
        for (uint32_t tx = 0; tx < d->width; tx += TILE) {
            for (uint32_t y = ty; y < ty + TILE && y < d->height; y++) {
                for (uint32_t x = tx; x < tx + TILE && x < d->width; x++) {
                    cvs_rng rng = cvs_rng_make(d->seed, (uint64_t)y * d->width + x);
                    float sx = (2.0f * ((float)x + cvs_rng_float(&rng)) / (float)d->width - 1.0f) * tan_half * aspect;
                    float sy = (1.0f - 2.0f * ((float)y + cvs_rng_float(&rng)) / (float)d->height) * tan_half;
                    cv_ray *r = &out->rays[n++];
                    float dir[3];
                    v3_madd(dir, fwd, right, sx);
                    v3_madd(dir, dir, up, sy);
                    v3_normalize(r->dir, dir);
                    v3_copy(r->origin, c->position);
                    r->tmin = 0.0f;
                    r->tmax = INFINITY;
                }
            }
        }
    }
    out->count = n;
    return CV_OK;
}

/* A unit vector uniform on the sphere. */
static void uniform_sphere(cvs_rng *rng, float out[3]) {
    double z = 1.0 - 2.0 * cvs_rng_float(rng), r = sqrt(fmax(0.0, 1.0 - z * z)), s, c;
    cvs_sincos(2.0 * CVS_PI * cvs_rng_float(rng), &s, &c);
    v3_set(out, (float)(r * c), (float)(r * s), (float)z);
}

static cv_result make_random(const cv_scene *scene, const cv_ray_set_desc *d, cv_ray_set *out) {
    float bmin[3], bmax[3], ext[3];
    cv_scene_bounds(scene, bmin, bmax);
    v3_sub(ext, bmax, bmin);
    out->rays = malloc((size_t)d->random_count * sizeof(cv_ray));
    if (!out->rays)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "random rays: no memory for %u rays", d->random_count);
    for (uint32_t i = 0; i < d->random_count; i++) {
        cvs_rng rng = cvs_rng_make(d->seed * 8ull + CV_RAYS_RANDOM, i);
        cv_ray *r = &out->rays[i];
        for (int k = 0; k < 3; k++)
            r->origin[k] = bmin[k] + ext[k] * cvs_rng_float(&rng);
        uniform_sphere(&rng, r->dir);
        r->tmin = 0.0f;
        r->tmax = INFINITY;
    }
    out->count = d->random_count;
    return CV_OK;
}

cv_result cv_ray_set_make(const cv_scene *scene, cv_ray_kind kind, const cv_ray_set_desc *desc, cv_ray_set *out) {
    if (!scene || !out)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_ray_set_make: scene or out is NULL");
    if (kind != CV_RAYS_PRIMARY && kind != CV_RAYS_RANDOM)
        return cv_error(CV_ERROR_INVALID_ARGUMENT,
                        "cv_ray_set_make: %s rays need primary hits "
                        "(cv_ray_set_make_secondary)",
                        cv_ray_kind_name(kind));
    cv_camera cam;
    cv_ray_set_desc d = resolve(scene, desc, &cam);
    cv_ray_set set = { .kind = kind };
    cv_result r = kind == CV_RAYS_PRIMARY ? make_primary(&d, &set) : make_random(scene, &d, &set);
    if (r == CV_OK)
        *out = set;
    return r;
}

/* Cosine-weighted direction around unit n (Duff et al.'s orthonormal basis). */
static void cosine_hemisphere(cvs_rng *rng, const float n[3], float out[3]) {
    float u1 = cvs_rng_float(rng), u2 = cvs_rng_float(rng);
    double s, c;
    cvs_sincos(2.0 * CVS_PI * u2, &s, &c);
    float r = sqrtf(u1), x = r * (float)c, y = r * (float)s, z = sqrtf(fmaxf(0.0f, 1.0f - u1));
    float sign = copysignf(1.0f, n[2]);
    float a = -1.0f / (sign + n[2]), b = n[0] * n[1] * a;
    const float t[3] = { 1.0f + sign * n[0] * n[0] * a, sign * b, -sign * n[0] };
    const float bt[3] = { b, sign + n[1] * n[1] * a, -n[1] };
    float d[3];
    v3_scale(d, n, z);
    v3_madd(d, d, t, x);
    v3_madd(d, d, bt, y);
    v3_normalize(out, d);
}

cv_result cv_ray_set_make_secondary(const cv_scene *scene, cv_ray_kind kind, const cv_ray_set_desc *desc,
                                    const cv_ray_set *primary, const cv_hit *hits, cv_ray_set *out) {
    if (!scene || !primary || !out || (primary->count && (!primary->rays || !hits)))
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_ray_set_make_secondary: scene, primary, hits or out is NULL");
    if (kind == CV_RAYS_PRIMARY || kind == CV_RAYS_RANDOM || (unsigned)kind >= CV_RAY_KIND_COUNT)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_ray_set_make_secondary: %s is not a secondary ray kind",
                        cv_ray_kind_name(kind));
    for (uint32_t i = 0; i < primary->count; i++) {
        if (hits[i].triangle == CV_BVH_INVALID)
            continue;
        const cv_instance *inst = cv_scene_instance(scene, hits[i].instance);
        if (!inst || hits[i].triangle >= cv_scene_mesh(scene, inst->mesh)->triangle_count)
            return cv_error(CV_ERROR_INVALID_ARGUMENT,
                            "cv_ray_set_make_secondary: hit %u names instance %u triangle "
                            "%u, not in the scene",
                            i, hits[i].instance, hits[i].triangle);
    }
    cv_camera cam;
    cv_ray_set_desc d = resolve(scene, desc, &cam);
    cv_ray_set set = { .kind = kind, .rays = malloc((size_t)primary->count * sizeof(cv_ray) + 1) };
    if (!set.rays)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "%s rays: no memory for %u rays", cv_ray_kind_name(kind),
                        primary->count);
    float to_sun[3];
    v3_scale(to_sun, d.sun_direction, -1.0f);
    for (uint32_t i = 0; i < primary->count; i++) {
        const cv_hit *h = &hits[i];
        if (h->triangle == CV_BVH_INVALID)
            continue;
        const cv_ray *in = &primary->rays[i];
        float v[3][3], e1[3], e2[3], n[3], p[3];
        cv_scene_world_triangle(scene, h->instance, h->triangle, v);
        v3_sub(e1, v[1], v[0]);
        v3_sub(e2, v[2], v[0]);
        v3_cross(n, e1, e2);
        v3_normalize(n, n);
        if (v3_dot(n, in->dir) > 0.0f)
            v3_scale(n, n, -1.0f);
        v3_madd(p, in->origin, in->dir, h->t);
        cv_ray *r = &set.rays[set.count];
        v3_copy(r->origin, p);
        r->tmin = fmaxf(1.0f, v3_length(p)) * 1e-3f;
        r->tmax = INFINITY;
        cvs_rng rng = cvs_rng_make(d.seed * 8ull + (uint64_t)kind, i);
        switch (kind) {
        case CV_RAYS_SHADOW:
            if (!(v3_dot(n, to_sun) > 0.0f))
                continue;
            v3_copy(r->dir, to_sun);
            break;
        case CV_RAYS_AO_SHORT:
            cosine_hemisphere(&rng, n, r->dir);
            r->tmax = d.ao_short_length;
            break;
        case CV_RAYS_AO_LONG:
        case CV_RAYS_DIFFUSE: cosine_hemisphere(&rng, n, r->dir); break;
        default: {
            float refl[3];
            v3_madd(refl, in->dir, n, -2.0f * v3_dot(in->dir, n));
            v3_normalize(r->dir, refl);
            break;
        }
        }
        set.count++;
    }
    *out = set;
    return CV_OK;
}
