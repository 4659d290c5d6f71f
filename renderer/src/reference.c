/* The reference renderer (see renderer.h, cv_render_reference): the hybrid
 * renderer's image model evaluated on the CPU with scene/'s closest-hit and
 * any-hit traversal (cv_trace_ray), independent random samples and float32
 * accumulation. Materials are evaluated with cv_material_evaluate
 * (corvid/material_eval.h, the rules render_material.glsl follows): at a
 * camera hit with the pixel's uv footprint from ray differentials (the rays
 * through the centres of the pixel's pairs in its 2x2 quad meet the hit
 * triangle's plane; the differences of their uvs: what the G-buffer's
 * dFdxFine/dFdyFine measure),
 * the alpha mask cutting points away (the camera ray goes on to the next
 * hit), the normal image mapping the shading normal; at a reflection hit at
 * level 0, as render.reflect_shade. Shadow, AO and reflection rays (and the
 * shadow rays of reflection hits) follow renderer.h's alpha-mask rule as the
 * GPU's render.alpha_continue does (secondary_trace): through at most
 * CV_RENDER_ALPHA_LAYERS cut points, front to back, tmin = t + the ray-origin
 * offset. Rows are split over pthreads; every pixel's samples come from
 * its own random stream, so the result does not depend on the thread count. */
#include "corvid/renderer.h"

#include <math.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>

#include "corvid/material_eval.h"
#include "corvid/trace_cpu.h"
#include "output_derive.h"
#include "camera.h"
#include "reflect_model.h"
#include "scene_upload.h"

#define REF_PI 3.14159265358979f

typedef struct reference_job {
    const cv_scene *scene;
    cv_trace_target target;
    const render_scene_data *data;
    const uint64_t *first_vertex; /* per instance: its first vertex in data->vertices */
    cv_render_settings s;
    cv_camera camera;
    cv_material default_material; /* for a scene without materials */
    bool alpha_mask;              /* some material is alpha-masked: secondary rays follow the alpha-mask rule */
    uint32_t samples;
    cv_render_output *out;
    uint32_t next_row; /* guarded by lock */
    pthread_mutex_t lock;
} reference_job;

static float dot3(const float a[3], const float b[3]) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

static void normalize3(float v[3]) {
    float l = sqrtf(dot3(v, v));
    for (int k = 0; k < 3 && l > 0.0f; k++)
        v[k] /= l;
}

static void cross3(const float a[3], const float b[3], float o[3]) {
    o[0] = a[1] * b[2] - a[2] * b[1];
    o[1] = a[2] * b[0] - a[0] * b[2];
    o[2] = a[0] * b[1] - a[1] * b[0];
}

/* splitmix64: one stream per pixel. */
static float next_float(uint64_t *state) {
    uint64_t z = (*state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    z ^= z >> 31;
    return (float)(z >> 40) / 16777216.0f;
}

/* The same orthonormal basis as render_raygen.comp. */
static void basis(const float n[3], float t[3], float b[3]) {
    float s = n[2] >= 0.0f ? 1.0f : -1.0f, a = -1.0f / (s + n[2]), c = n[0] * n[1] * a;
    t[0] = 1.0f + s * n[0] * n[0] * a, t[1] = s * c, t[2] = -s * n[0];
    b[0] = c, b[1] = s + n[1] * n[1] * a, b[2] = -n[1];
}

/* Material m of the scene (a scene without materials: the default, as scene_upload.c). */
static const cv_material *material_of(const reference_job *j, uint32_t m) {
    return cv_scene_material_count(j->scene) ? cv_scene_material(j->scene, m) : &j->default_material;
}

/* n, the unit shading normal of triangle v (uvs uv[6]), tilted by the material's
 * normal image: the tangent-space normal `tn` (cv_material_evaluate's) carried
 * by the triangle's tangent frame; n as it is without an image or a frame. */
static void normal_image_apply(const cv_material *material, const render_vertex v[3], const float uv[6],
                               const float tn[3], float n[3]) {
    if (material->normal_image == CV_NO_IMAGE)
        return;
    float tp[3][3], tuv[3][2], t[3], b[3];
    for (int c = 0; c < 3; c++) {
        memcpy(tp[c], v[c].position, sizeof(tp[c]));
        memcpy(tuv[c], &uv[2 * c], sizeof(tuv[c]));
    }
    if (!cv_triangle_tangent_frame(tp, tuv, n, t, b))
        return;
    float mapped[3];
    for (int k = 0; k < 3; k++)
        mapped[k] = t[k] * tn[0] + b[k] * tn[1] + n[k] * tn[2];
    normalize3(mapped);
    memcpy(n, mapped, sizeof(mapped));
}

/* The alpha mask cuts the hit point away: its material is masked and its
 * alpha at the hit's uv, level 0, is below the cutoff (render_alpha_continue.comp's hit_cut). */
static bool hit_cut(const reference_job *j, const cv_hit *hit) {
    const render_scene_data *data = j->data;
    uint64_t first = j->first_vertex[hit->instance] + 3ull * hit->triangle;
    uint32_t m = data->vertices[first].material;
    const cv_material *material = material_of(j, m < data->material_count ? m : data->material_count - 1);
    if (material->alpha_mode != CV_ALPHA_MASK)
        return false;
    const float *uv = &data->uvs[2 * first];
    float w = 1.0f - hit->u - hit->v;
    cv_material_eval e;
    cv_material_evaluate(j->scene, material, uv[0] * w + uv[2] * hit->u + uv[4] * hit->v,
                         uv[1] * w + uv[3] * hit->u + uv[5] * hit->v, NULL, &e);
    return !e.present;
}

/* A secondary ray's hit under renderer.h's alpha-mask rule, as the GPU's
 * rounds (render_alpha_continue.comp) find it: a hit that is not cut stands;
 * an any-hit ray that stopped at a cut point is traced again closest-hit from
 * its own tmin; then front to back, each cut point passed with tmin = t +
 * the ray-origin offset, at most CV_RENDER_ALPHA_LAYERS of them (the next one
 * stands, as opaque). */
static bool secondary_trace(const reference_job *j, cv_ray ray, uint32_t flags, cv_hit *hit) {
    if (!cv_trace_ray(&j->target, &ray, flags, hit))
        return false;
    if (!j->alpha_mask || !hit_cut(j, hit))
        return true;
    if ((flags & CV_TRACE_ANY_HIT) && !cv_trace_ray(&j->target, &ray, CV_TRACE_CLOSEST, hit))
        return false;
    float offset = render_ray_offset(j->data);
    for (uint32_t passed = 0; passed < CV_RENDER_ALPHA_LAYERS && hit_cut(j, hit); passed++) {
        ray.tmin = hit->t + offset;
        if (!cv_trace_ray(&j->target, &ray, CV_TRACE_CLOSEST, hit))
            return false;
    }
    return true;
}

static bool occluded(const reference_job *j, const float o[3], const float d[3], float tmax) {
    cv_ray ray = { { o[0], o[1], o[2] }, 0.0f, { d[0], d[1], d[2] }, tmax };
    cv_hit hit;
    return secondary_trace(j, ray, CV_TRACE_ANY_HIT, &hit);
}

/* The camera ray through pixel (x, y)'s centre, unit (render_camera_view_proj's frame). */
static void camera_ray(const reference_job *j, float x, float y, float d[3]) {
    const cv_camera *cam = &j->camera;
    float f[3] = { cam->target[0] - cam->position[0], cam->target[1] - cam->position[1],
                   cam->target[2] - cam->position[2] },
          r[3], u[3];
    normalize3(f);
    cross3(f, cam->up, r);
    normalize3(r);
    cross3(r, f, u);
    float th = tanf(cam->vertical_fov * 0.5f), aspect = (float)j->s.width / (float)j->s.height;
    float sx = ((x + 0.5f) / j->s.width * 2.0f - 1.0f) * th * aspect,
          sy = (1.0f - (y + 0.5f) / j->s.height * 2.0f) * th;
    for (int k = 0; k < 3; k++)
        d[k] = f[k] + r[k] * sx + u[k] * sy;
    normalize3(d);
}

/* The uv where the ray (o, d) meets the plane of triangle v (uvs uv), by the
 * barycentrics of that point; false when the ray runs along the plane. */
static bool plane_uv(const render_vertex *v, const float *uv, const float o[3], const float d[3], float out[2]) {
    float e1[3], e2[3], ng[3], q[3];
    for (int k = 0; k < 3; k++) {
        e1[k] = v[1].position[k] - v[0].position[k];
        e2[k] = v[2].position[k] - v[0].position[k];
        q[k] = v[0].position[k] - o[k];
    }
    cross3(e1, e2, ng);
    float dn = dot3(d, ng);
    if (dn == 0.0f)
        return false;
    float t = dot3(q, ng) / dn;
    for (int k = 0; k < 3; k++)
        q[k] = o[k] + d[k] * t - v[0].position[k];
    float d00 = dot3(e1, e1), d01 = dot3(e1, e2), d11 = dot3(e2, e2), d20 = dot3(q, e1), d21 = dot3(q, e2);
    float den = d00 * d11 - d01 * d01;
    if (den == 0.0f)
        return false;
    float b1 = (d11 * d20 - d01 * d21) / den, b2 = (d00 * d21 - d01 * d20) / den;
    out[0] = uv[0] + (uv[2] - uv[0]) * b1 + (uv[4] - uv[0]) * b2;
    out[1] = uv[1] + (uv[3] - uv[1]) * b1 + (uv[5] - uv[1]) * b2;
    return isfinite(out[0]) && isfinite(out[1]);
}

/* The surface where ray (o, d) hit triangle v: the point x, the interpolated shading normal n and
 * the geometric normal ng (first turned to agree with the vertex normals), both turned to the ray's
 * side. Camera and reflection hits alike. */
static void surface_at(const render_vertex *v, const float o[3], const float d[3], const cv_hit *hit, float x[3],
                       float n[3], float ng[3]) {
    float e1[3], e2[3], w = 1.0f - hit->u - hit->v;
    for (int k = 0; k < 3; k++) {
        x[k] = o[k] + d[k] * hit->t;
        n[k] = v[0].normal[k] * w + v[1].normal[k] * hit->u + v[2].normal[k] * hit->v;
        e1[k] = v[1].position[k] - v[0].position[k];
        e2[k] = v[2].position[k] - v[0].position[k];
    }
    normalize3(n);
    cross3(e1, e2, ng);
    normalize3(ng);
    float nsum[3] = { v[0].normal[0] + v[1].normal[0] + v[2].normal[0],
                      v[0].normal[1] + v[1].normal[1] + v[2].normal[1],
                      v[0].normal[2] + v[1].normal[2] + v[2].normal[2] };
    if (dot3(ng, nsum) < 0.0f)
        for (int k = 0; k < 3; k++)
            ng[k] = -ng[k];
    if (dot3(ng, d) > 0.0f)
        for (int k = 0; k < 3; k++)
            ng[k] = -ng[k], n[k] = -n[k];
}

/* The radiance a reflection ray brings back, as render.reflect_shadow and
 * render.reflect_shade: the sky on a miss; on a hit, base color * sun
 * (Lambertian, a shadow ray toward the sun's centre from the hit, offset
 * along its geometric normal) + emission. */
static void reflected_radiance(const reference_job *j, const float o[3], const float d[3], float out[3]) {
    static const float sky[3] = { 0.12f, 0.15f, 0.2f };
    const render_scene_data *data = j->data;
    cv_ray ray = { { o[0], o[1], o[2] }, 0.0f, { d[0], d[1], d[2] }, 1e30f };
    cv_hit hit;
    if (!secondary_trace(j, ray, CV_TRACE_CLOSEST, &hit)) {
        memcpy(out, sky, sizeof(sky));
        return;
    }
    const render_vertex *v = &data->vertices[j->first_vertex[hit.instance] + 3ull * hit.triangle];
    float x[3], n[3], ng[3], w = 1.0f - hit.u - hit.v;
    surface_at(v, o, d, &hit, x, n, ng);
    float to_sun[3] = { -data->sun_direction[0], -data->sun_direction[1], -data->sun_direction[2] }, origin[3];
    float bias = render_ray_offset(data);
    for (int k = 0; k < 3; k++)
        origin[k] = x[k] + ng[k] * bias;
    bool visible = dot3(to_sun, ng) > 0.0f && dot3(to_sun, n) > 0.0f && !occluded(j, origin, to_sun, 1e30f);
    uint32_t m = v[0].material < data->material_count ? v[0].material : data->material_count - 1;
    /* The material at the hit's uv, level 0 (no footprint), whatever its alpha. */
    const float *uv = &data->uvs[2 * (j->first_vertex[hit.instance] + 3ull * hit.triangle)];
    cv_material_eval e;
    const cv_material *material = material_of(j, m);
    cv_material_evaluate(j->scene, material, uv[0] * w + uv[2] * hit.u + uv[4] * hit.v,
                         uv[1] * w + uv[3] * hit.u + uv[5] * hit.v, NULL, &e);
    /* The normal image tilts the normal the sun's cosine uses (level 0, the
     * triangle's tangent frame, as at camera hits); the visibility test above
     * keeps the interpolated normal, as render.reflect_shadow does. */
    normal_image_apply(material, v, uv, e.normal, n);
    float ndl = fmaxf(dot3(n, to_sun), 0.0f);
    for (int k = 0; k < 3; k++)
        out[k] = e.base_color[k] * data->sun_color[k] * data->sun_irradiance * ndl * (visible ? 1.0f : 0.0f) /
                     REF_PI +
                 e.emission[k];
}

/* The closest hit of pixel (x, y)'s camera ray that render.gbuffer keeps, with its material evaluated. */
typedef struct camera_hit {
    float d[3]; /* the ray's direction */
    cv_hit hit;
    const render_vertex *v; /* the hit triangle's vertices; NULL: the ray sees sky */
    const float *tri_uv;
    cv_material_eval me;
    uint32_t m; /* material index */
} camera_hit;

static void trace_camera(const reference_job *j, uint32_t x, uint32_t y, camera_hit *h) {
    const render_scene_data *data = j->data;
    const cv_camera *cam = &j->camera;
    /* The footprint as render.gbuffer's dFdxFine/dFdyFine measure it: within
     * the pixel's 2x2 quad, across its pair (the next pixel for an even
     * coordinate, the one before for an odd one). */
    float *d = h->d, dx[3], dy[3], dx0[3], dy0[3];
    camera_ray(j, (float)x, (float)y, d);
    camera_ray(j, (float)(x | 1u), (float)y, dx);
    camera_ray(j, (float)(x & ~1u), (float)y, dx0);
    camera_ray(j, (float)x, (float)(y | 1u), dy);
    camera_ray(j, (float)x, (float)(y & ~1u), dy0);
    cv_ray ray = { { cam->position[0], cam->position[1], cam->position[2] }, 0.0f, { d[0], d[1], d[2] }, INFINITY };
    h->v = NULL;
    /* The closest hit the G-buffer keeps: a point the alpha mask cuts away,
     * or a back face of a closed mesh (render.gbuffer discards both), lets
     * the ray go on. */
    for (uint32_t pass = 0; pass < 256; pass++) {
        if (!cv_trace_ray(&j->target, &ray, CV_TRACE_CLOSEST, &h->hit)) {
            h->v = NULL;
            return;
        }
        const cv_hit *hit = &h->hit;
        const render_vertex *v = h->v = &data->vertices[j->first_vertex[hit->instance] + 3ull * hit->triangle];
        const float *tri_uv = h->tri_uv = &data->uvs[2 * (j->first_vertex[hit->instance] + 3ull * hit->triangle)];
        float e1[3], e2[3], ng[3], nsum[3];
        for (int k = 0; k < 3; k++) {
            e1[k] = v[1].position[k] - v[0].position[k];
            e2[k] = v[2].position[k] - v[0].position[k];
            nsum[k] = v[0].normal[k] + v[1].normal[k] + v[2].normal[k];
        }
        cross3(e1, e2, ng);
        bool back = (dot3(ng, nsum) < 0.0f) != (dot3(ng, d) > 0.0f);
        h->m = v[0].material < data->material_count ? v[0].material : data->material_count - 1;
        float w = 1.0f - hit->u - hit->v, uv[2] = { tri_uv[0] * w + tri_uv[2] * hit->u + tri_uv[4] * hit->v,
                                                    tri_uv[1] * w + tri_uv[3] * hit->u + tri_uv[5] * hit->v };
        float ux0[2], ux[2], uy0[2], uy[2], duv[4];
        bool footprint = plane_uv(v, tri_uv, cam->position, dx0, ux0) && plane_uv(v, tri_uv, cam->position, dx, ux) &&
                         plane_uv(v, tri_uv, cam->position, dy0, uy0) && plane_uv(v, tri_uv, cam->position, dy, uy);
        if (footprint) {
            duv[0] = ux[0] - ux0[0], duv[1] = ux[1] - ux0[1], duv[2] = uy[0] - uy0[0], duv[3] = uy[1] - uy0[1];
        }
        cv_material_evaluate(j->scene, material_of(j, h->m), uv[0], uv[1], footprint ? duv : NULL, &h->me);
        if (h->me.present && !(back && v[0].closed != 0.0f))
            return;
        ray.tmin = nextafterf(hit->t, INFINITY);
    }
}

/* Sun visibility and ambient occlusion at a camera hit (origin, shading normal n, geometric normal ng):
 * `samples` samples of the sun's cone, each with ao_samples cosine AO rays, from pixel (x, y)'s stream. */
static void sun_and_ao(const reference_job *j, uint32_t x, uint32_t y, const float origin[3], const float n[3],
                       const float ng[3], float *sun_out, float *ao_out) {
    const render_scene_data *data = j->data;
    uint64_t rng = ((uint64_t)(y * j->s.width + x) << 20) ^ 0x5EEDull;
    float to_sun[3] = { -data->sun_direction[0], -data->sun_direction[1], -data->sun_direction[2] }, st[3], sb[3],
          nt[3], nb[3];
    basis(to_sun, st, sb);
    basis(n, nt, nb);
    float cone = j->s.sun_cone_degrees * REF_PI / 180.0f, sun = 0.0f, ao = 0.0f;
    for (uint32_t sample = 0; sample < j->samples; sample++) {
        float a = next_float(&rng), b = next_float(&rng);
        float ct = 1.0f - a * (1.0f - cosf(cone)), stt = sqrtf(fmaxf(0.0f, 1.0f - ct * ct)), ph = 2.0f * REF_PI * b,
              dir[3];
        for (int k = 0; k < 3; k++)
            dir[k] = st[k] * cosf(ph) * stt + sb[k] * sinf(ph) * stt + to_sun[k] * ct;
        normalize3(dir);
        if (dot3(dir, n) > 0.0f && dot3(dir, ng) > 0.0f && !occluded(j, origin, dir, 1e30f))
            sun += 1.0f;
        for (uint32_t k2 = 0; k2 < j->s.ao_samples; k2++) {
            float c = next_float(&rng), e = next_float(&rng), rr = sqrtf(c), an = 2.0f * REF_PI * e,
                  z = sqrtf(fmaxf(0.0f, 1.0f - c));
            for (int k = 0; k < 3; k++)
                dir[k] = nt[k] * rr * cosf(an) + nb[k] * rr * sinf(an) + n[k] * z;
            normalize3(dir);
            float below = dot3(dir, ng);
            if (below < 0.0f) {
                for (int k = 0; k < 3; k++)
                    dir[k] -= 2.0f * below * ng[k];
                normalize3(dir);
            }
            if (!occluded(j, origin, dir, j->s.ao_radius))
                ao += 1.0f;
        }
    }
    *sun_out = sun / (float)j->samples;
    *ao_out = ao / ((float)j->samples * (float)j->s.ao_samples);
}

/* Reflections: `samples` GGX samples (reflect_model.h) from their own stream,
 * so the shadow and AO samples are those of a render without. */
static void reflection_at(const reference_job *j, uint32_t x, uint32_t y, const float origin[3], const float view[3],
                          const float n[3], const float ng[3], float roughness, float reflection[3]) {
    uint64_t rng2 = ((uint64_t)(y * j->s.width + x) << 20) ^ 0x0EF1EC7ull;
    for (uint32_t sample = 0; sample < j->samples; sample++) {
        float uv[2] = { next_float(&rng2), next_float(&rng2) }, l[3], weight, radiance[3];
        if (!reflect_sample(view, n, ng, roughness, uv, l, &weight))
            continue;
        reflected_radiance(j, origin, l, radiance);
        for (int k = 0; k < 3; k++)
            reflection[k] += weight * radiance[k];
    }
    for (int k = 0; k < 3; k++)
        reflection[k] /= (float)j->samples;
}

static void shade_pixel(reference_job *j, uint32_t x, uint32_t y) {
    const render_scene_data *data = j->data;
    const cv_camera *cam = &j->camera;
    size_t i = ((size_t)y * j->s.width + x) * 4;
    cv_render_output *out = j->out;
    camera_hit h;
    trace_camera(j, x, y, &h);
    const render_vertex *v = h.v;
    const float *d = h.d;
    const cv_material_eval me = h.me;
    if (!v) {
        float sky[4] = { 0.12f, 0.15f, 0.2f, 0.0f };
        memcpy(&out->radiance[i], sky, sizeof(sky));
        out->visibility[i] = 1.0f, out->visibility[i + 1] = 1.0f;
        return;
    }
    float p[3], n[3], ng[3];
    surface_at(v, cam->position, d, &h.hit, p, n, ng); /* facing the camera, as render.gbuffer */
    const cv_material *material = material_of(j, h.m);
    normal_image_apply(material, v, h.tri_uv, me.normal, n); /* the normal image, in the triangle's tangent frame */
    float bias = render_ray_offset(data), origin[3];
    for (int k = 0; k < 3; k++)
        origin[k] = p[k] + ng[k] * bias;
    float to_sun[3] = { -data->sun_direction[0], -data->sun_direction[1], -data->sun_direction[2] }, sun, ao;
    sun_and_ao(j, x, y, origin, n, ng, &sun, &ao);
    float base_roughness[4] = { me.base_color[0], me.base_color[1], me.base_color[2], me.roughness };
    float reflection[3] = { 0.0f, 0.0f, 0.0f }, view[3] = { -d[0], -d[1], -d[2] };
    if (out->reflection) {
        reflection_at(j, x, y, origin, view, n, ng, base_roughness[3], reflection);
        memcpy(&out->reflection[i], reflection, sizeof(reflection));
        out->reflection[i + 3] = 1.0f;
    }
    float fresnel[3];
    reflect_fresnel(base_roughness, me.metalness, dot3(n, view), fresnel);
    /* render_composite.comp's model. */
    float albedo[3], color[3], ndl = fmaxf(dot3(n, to_sun), 0.0f), sky[3] = { 0.12f, 0.15f, 0.2f };
    for (int k = 0; k < 3; k++) {
        albedo[k] = me.base_color[k] * (1.0f - me.metalness);
        float local = 0.0f;
        for (uint32_t l = 0; l < data->light_count; l++) {
            const render_light *li = &data->lights[l];
            float tl[3] = { li->position[0] - p[0], li->position[1] - p[1], li->position[2] - p[2] };
            float d2 = fmaxf(dot3(tl, tl), 1e-4f), nd = fmaxf(dot3(n, tl) / sqrtf(d2), 0.0f);
            local += li->color[k] * li->intensity * nd / (d2 * REF_PI);
        }
        float direct = data->sun_color[k] * data->sun_irradiance * ndl * sun / REF_PI;
        color[k] = albedo[k] * (direct + sky[k] * ao + local * ao) + me.emission[k] + fresnel[k] * reflection[k];
    }
    memcpy(&out->radiance[i], color, sizeof(color));
    out->radiance[i + 3] = 1.0f;
    memcpy(&out->albedo[i], albedo, sizeof(albedo));
    out->albedo[i + 3] = 1.0f;
    memcpy(&out->normal[i], n, sizeof(n));
    out->normal[i + 3] = (float)h.m;
    memcpy(&out->position[i], p, sizeof(p));
    out->position[i + 3] = 1.0f;
    out->visibility[i] = sun, out->visibility[i + 1] = ao;
}

static void *reference_worker(void *arg) {
    reference_job *j = arg;
    for (;;) {
        pthread_mutex_lock(&j->lock);
        uint32_t y = j->next_row++;
        pthread_mutex_unlock(&j->lock);
        if (y >= j->s.height)
            return NULL;
        for (uint32_t x = 0; x < j->s.width; x++)
            shade_pixel(j, x, y);
    }
}

cv_result cv_render_reference(const cv_scene *scene, const cv_bvh *bvh, const cv_render_settings *settings,
                              uint32_t samples, uint32_t threads, cv_render_output *out) {
    if (!scene || !bvh || !out || samples == 0 || samples > CV_RENDER_REFERENCE_MAX_SAMPLES)
        return cv_error(CV_ERROR_INVALID_ARGUMENT,
                        "cv_render_reference: need a scene, its BVH, an output and 1..%u samples",
                        CV_RENDER_REFERENCE_MAX_SAMPLES);
    reference_job j = { .scene = scene,
                        .target = { .flat = bvh, .layout = CV_BVH_LAYOUT_NODE2 },
                        .s = cv_render_settings_resolve(settings, scene),
                        .default_material = cv_material_default(),
                        .samples = samples,
                        .out = out };
    cv_result res = cv_render_settings_check(&j.s);
    if (res == CV_OK)
        res = cv_render_camera_check(&j.s, scene);
    if (res != CV_OK)
        return res;
    /* The view of the GPU render's image: its last frame (cv_render_camera). */
    j.camera = cv_render_camera(&j.s, scene, j.s.first_frame + j.s.frames - 1);
    render_scene_data data;
    res = render_scene_data_build(scene, &data);
    if (res != CV_OK)
        return res;
    render_sun_direction(&j.s, data.sun_direction, data.sun_direction);
    j.data = &data;
    j.alpha_mask = render_scene_alpha_masked(&data);
    uint64_t *first = malloc((cv_scene_instance_count(scene) + 1) * sizeof(uint64_t));
    size_t n = (size_t)j.s.width * j.s.height * 4;
    cv_render_output o = { .width = j.s.width, .height = j.s.height };
    float **planes[6] = { &o.radiance, &o.albedo, &o.normal, &o.position, &o.visibility, &o.reflection };
    int plane_count = j.s.reflections == 1 ? 6 : 5;
    bool ok = first != NULL;
    for (int p = 0; p < plane_count; p++)
        ok = (*planes[p] = calloc(n, sizeof(float))) && ok;
    if (!ok) {
        free(first);
        cv_render_output_free(&o);
        render_scene_data_free(&data);
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "cv_render_reference: %ux%u output", j.s.width, j.s.height);
    }
    for (uint32_t in = 0, acc = 0; in < cv_scene_instance_count(scene); in++) {
        first[in] = (uint64_t)acc * 3;
        acc += cv_scene_mesh(scene, cv_scene_instance(scene, in)->mesh)->triangle_count;
    }
    j.first_vertex = first;
    j.out = &o;
    pthread_mutex_init(&j.lock, NULL);
    if (threads == 0)
        threads = 2;
    pthread_t tid[64];
    uint32_t started = 0;
    for (; started < threads && started < 64; started++)
        if (pthread_create(&tid[started], NULL, reference_worker, &j) != 0)
            break;
    if (started == 0)
        reference_worker(&j);
    for (uint32_t t = 0; t < started; t++)
        pthread_join(tid[t], NULL);
    pthread_mutex_destroy(&j.lock);
    free(first);
    cv_result derived = render_output_derive(&o, j.camera.position, &data); /* depth and direct, as the GPU's */
    render_scene_data_free(&data);
    if (derived != CV_OK) {
        cv_render_output_free(&o);
        return derived;
    }
    *out = o;
    return CV_OK;
}
