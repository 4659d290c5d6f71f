/* Embree 3 scene building and tracing for bench_bvh_cpu. */
#include "embree_peer.h"

#include <embree3/rtcore.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bench_util.h"
#include "corvid/trace_cpu.h"

struct embree_peer {
    RTCDevice device;
    RTCGeometry *geoms; /* one per instance, kept to rebuild the scene */
    uint32_t geom_count;
    RTCScene scene;
    char description[128];
};

static RTCScene commit_scene(embree_peer *p, double *seconds) {
    RTCScene scene = rtcNewScene(p->device);
    for (uint32_t i = 0; i < p->geom_count; i++)
        rtcAttachGeometryByID(scene, p->geoms[i], i);
    double t0 = bench_now();
    rtcCommitScene(scene);
    *seconds = bench_now() - t0;
    return scene;
}

embree_peer *embree_peer_create(const cv_scene *scene, uint32_t threads, double *commit_seconds) {
    embree_peer *p = calloc(1, sizeof *p);
    char config[64];
    snprintf(config, sizeof config, "threads=%u", threads);
    if (p)
        p->device = rtcNewDevice(config);
    if (!p || !p->device) {
        fprintf(stderr, "embree: rtcNewDevice(\"%s\") failed (error %d)\n", config, (int)rtcGetDeviceError(NULL));
        free(p);
        return NULL;
    }
    p->geom_count = cv_scene_instance_count(scene);
    p->geoms = calloc((size_t)p->geom_count + 1, sizeof(RTCGeometry));
    for (uint32_t i = 0; p->geoms && i < p->geom_count; i++) {
        const cv_instance *inst = cv_scene_instance(scene, i);
        const cv_mesh *m = cv_scene_mesh(scene, inst->mesh);
        RTCGeometry g = rtcNewGeometry(p->device, RTC_GEOMETRY_TYPE_TRIANGLE);
        float *v = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float),
                                           m->vertex_count);
        unsigned *idx = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned),
                                                m->triangle_count);
        if (!v || !idx) {
            fprintf(stderr, "embree: no buffers for instance %u (error %d)\n", i, (int)rtcGetDeviceError(p->device));
            rtcReleaseGeometry(g);
            p->geom_count = i;
            embree_peer_destroy(p);
            return NULL;
        }
        for (uint32_t k = 0; k < m->vertex_count; k++)
            cv_transform_point(inst->transform, &m->positions[3 * k], &v[3 * k]);
        memcpy(idx, m->indices, (size_t)m->triangle_count * 3 * sizeof(unsigned));
        rtcCommitGeometry(g);
        p->geoms[i] = g;
    }
    p->scene = commit_scene(p, commit_seconds);
    snprintf(p->description, sizeof p->description, "Embree %s (native 16-wide packets: %s)", RTC_VERSION_STRING,
             rtcGetDeviceProperty(p->device, RTC_DEVICE_PROPERTY_NATIVE_RAY16_SUPPORTED) ? "yes" : "no");
    return p;
}

double embree_peer_rebuild(embree_peer *p) {
    double seconds;
    rtcReleaseScene(p->scene);
    p->scene = commit_scene(p, &seconds);
    return seconds;
}

void embree_peer_destroy(embree_peer *p) {
    if (!p)
        return;
    if (p->scene)
        rtcReleaseScene(p->scene);
    for (uint32_t i = 0; p->geoms && i < p->geom_count; i++)
        rtcReleaseGeometry(p->geoms[i]);
    free(p->geoms);
    rtcReleaseDevice(p->device);
    free(p);
}

const char *embree_peer_version(void) { return RTC_VERSION_STRING; }

const char *embree_peer_describe(const embree_peer *p) { return p->description; }

typedef struct job {
    embree_peer *peer;
    const cv_ray *rays;
    cv_hit *hits;
    uint32_t count;
    bool occlusion;
} job;

static void to_hit(const struct RTCRayHit *rh, cv_hit *h) {
    if (rh->hit.geomID == RTC_INVALID_GEOMETRY_ID) {
        *h = cv_hit_miss();
        return;
    }
    *h = (cv_hit){
        .t = rh->ray.tfar, .u = rh->hit.u, .v = rh->hit.v, .triangle = rh->hit.primID, .instance = rh->hit.geomID
    };
}

static void trace1(void *ctx, size_t begin, size_t end) {
    job *j = ctx;
    struct RTCIntersectContext ic;
    rtcInitIntersectContext(&ic);
    for (size_t i = begin; i < end; i++) {
        const cv_ray *r = &j->rays[i];
        struct RTCRayHit rh = { 0 };
        rh.ray.org_x = r->origin[0];
        rh.ray.org_y = r->origin[1];
        rh.ray.org_z = r->origin[2];
        rh.ray.tnear = r->tmin;
        rh.ray.dir_x = r->dir[0];
        rh.ray.dir_y = r->dir[1];
        rh.ray.dir_z = r->dir[2];
        rh.ray.tfar = r->tmax;
        rh.ray.mask = 0xFFFFFFFFu;
        rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
        rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
        if (j->occlusion) {
            rtcOccluded1(j->peer->scene, &ic, &rh.ray);
            j->hits[i] = rh.ray.tfar == -INFINITY ? (cv_hit){ .t = 0.0f } : cv_hit_miss();
        } else {
            rtcIntersect1(j->peer->scene, &ic, &rh);
            to_hit(&rh, &j->hits[i]);
        }
    }
}

static void trace16(void *ctx, size_t begin, size_t end) {
    job *j = ctx;
    struct RTCIntersectContext ic;
    rtcInitIntersectContext(&ic);
    for (size_t base = begin; base < end; base += 16) {
        RTC_ALIGN(64) int valid[16];
        RTC_ALIGN(64) struct RTCRayHit16 rh;
        memset(&rh, 0, sizeof rh);
        for (int k = 0; k < 16; k++) {
            size_t i = base + (size_t)k;
            valid[k] = i < end ? -1 : 0;
            const cv_ray *r = &j->rays[i < end ? i : begin];
            rh.ray.org_x[k] = r->origin[0];
            rh.ray.org_y[k] = r->origin[1];
            rh.ray.org_z[k] = r->origin[2];
            rh.ray.tnear[k] = r->tmin;
            rh.ray.dir_x[k] = r->dir[0];
            rh.ray.dir_y[k] = r->dir[1];
            rh.ray.dir_z[k] = r->dir[2];
            rh.ray.tfar[k] = r->tmax;
            rh.ray.mask[k] = 0xFFFFFFFFu;
            rh.hit.geomID[k] = RTC_INVALID_GEOMETRY_ID;
            rh.hit.instID[0][k] = RTC_INVALID_GEOMETRY_ID;
        }
        if (j->occlusion)
            rtcOccluded16(valid, j->peer->scene, &ic, &rh.ray);
        else
            rtcIntersect16(valid, j->peer->scene, &ic, &rh);
        for (int k = 0; k < 16 && base + (size_t)k < end; k++) {
            cv_hit *h = &j->hits[base + (size_t)k];
            if (j->occlusion)
                *h = rh.ray.tfar[k] == -INFINITY ? (cv_hit){ .t = 0.0f } : cv_hit_miss();
            else if (rh.hit.geomID[k] == RTC_INVALID_GEOMETRY_ID)
                *h = cv_hit_miss();
            else
                *h = (cv_hit){ .t = rh.ray.tfar[k],
                               .u = rh.hit.u[k],
                               .v = rh.hit.v[k],
                               .triangle = rh.hit.primID[k],
                               .instance = rh.hit.geomID[k] };
        }
    }
}

void embree_peer_trace(embree_peer *p, const cv_ray *rays, uint32_t count, bool occlusion, int width,
                       uint32_t threads, cv_hit *hits) {
    job j = { .peer = p, .rays = rays, .hits = hits, .count = count, .occlusion = occlusion };
    /* Chunks of 256 keep 16-ray packets on 16-ray boundaries (4x4 pixel tiles). */
    bench_parallel(threads, count, 256, width == 16 ? trace16 : trace1, &j);
}
