/* The hybrid renderer against ground truth (issue 11), on lavapipe with
 * validation on, at small sizes:
 *  - accumulation has no bias: 256 frames of 1 AO ray at 64x36, accumulated on
 *    the GPU, equal the mean of the same 256 frames rendered one at a time
 *    (first_frame = f) and accumulated in double on the host;
 *  - the G-buffer shows the side of each surface the camera sees: at every
 *    covered pixel, the CPU's closest hit from the camera through the G-buffer
 *    position is at that position and its triangle's geometric normal, turned
 *    toward the camera, agrees with the G-buffer normal (no back face wins at
 *    silhouettes and creases);
 *  - AO rays leave from the geometric surface: a low-poly sphere alone in
 *    open space is unoccluded (AO 1) everywhere;
 *  - the GPU's converged, unfiltered shadow and AO match the CPU reference
 *    (cv_render_reference) on the room;
 *  - the filter (variance-guided a-trous) keeps contact-shadow umbrae dark,
 *    brings one frame closer to the reference, and leaves a converged
 *    accumulation as it is;
 *  - with more rays a frame (16 AO, 4 shadow) one filtered frame comes
 *    closer still: the AO's local linear fit has no bias at creases, and
 *    several shadow rays cut the penumbrae's noise;
 *  - the blue-noise mask render.raygen's sample points come from is a
 *    permutation of ranks with blue noise's spectrum, the same bytes on every
 *    host. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "test_adapter.h"
#include "corvid/blue_noise.h"
#include "corvid/image_metrics.h"
#include "corvid/renderer.h"
#include "corvid/scene_procedural.h"
#include "corvid/trace_cpu.h"
#include "corvid/vulkan.h"

/* One lavapipe device and a renderer on it for a scene. */
typedef struct rig {
    cv_context *ctx;
    cv_device *device;
    cv_renderer *renderer;
} rig;

static cv_result rig_open(const cv_scene *scene, const cv_bvh *bvh, rig *g) {
    memset(g, 0, sizeof(*g));
    cv_vulkan_gpu_table table;
    cv_result res = cv_context_create(NULL, &g->ctx);
    if (res == CV_OK)
        res = cv_vulkan_gpu_table_build(&(cv_vulkan_gpu_config){ .total = 1, .adapters = cv_test_adapter() }, &table);
    if (res == CV_OK)
        res = cv_vulkan_create_devices(g->ctx, &table, true, &g->device);
    if (res == CV_OK)
        res = cv_renderer_create(&g->device, 1, scene, bvh, &g->renderer);
    return res;
}

static void rig_close(rig *g) {
    cv_renderer_destroy(g->renderer);
    cv_context_destroy(g->ctx);
    memset(g, 0, sizeof(*g));
}

/* Defect 1: the history was RGBA16F updated as h + (c - h) / (frame + 1); once
 * 1 / (frame + 1) is below half a half-float step of h, small updates round
 * away and occluded pixels drift dark (-0.034 at 256 frames). Tolerance: the
 * GPU's float32 running mean differs from the double mean by rounding only
 * (~256 * 2^-24 per pixel); 1e-4 on the mean over occluded pixels and 1e-3 on
 * any pixel. Sanitizer builds: 64 frames (the defect is -0.008 there, still
 * 80 times the tolerance). */
static void check_accumulation_unbiased(const cv_scene *scene, const cv_bvh *bvh) {
    enum { AW = 64, AH = 36, FRAMES = CV_TEST_REPEATS(256, 64) };
    rig g;
    CHECK_OK(rig_open(scene, bvh, &g));
    if (!g.renderer) {
        rig_close(&g);
        return;
    }
    cv_render_settings s = {
        .width = AW, .height = AH, .frames = 1, .ao_samples = 1, .sun_cone_degrees = 1.5f, .filter_iterations = -1
    };
    double *sum = calloc((size_t)AW * AH * 2, sizeof(double));
    cv_render_output o = { 0 };
    for (uint32_t f = 0; f < FRAMES && sum; f++) {
        s.first_frame = f;
        if (cv_renderer_render(g.renderer, &s, &o, NULL, NULL, NULL) != CV_OK) {
            CHECK_OK(CV_ERROR_BACKEND);
            break;
        }
        for (uint32_t i = 0; i < AW * AH; i++) {
            sum[i * 2] += o.visibility[i * 4];
            sum[i * 2 + 1] += o.visibility[i * 4 + 1];
        }
        cv_render_output_free(&o);
    }
    s.first_frame = 0;
    s.frames = FRAMES;
    CHECK_OK(cv_renderer_render(g.renderer, &s, &o, NULL, NULL, NULL));
    if (o.visibility && sum) {
        double bias[2] = { 0, 0 }, worst = 0.0;
        uint32_t occluded[2] = { 0, 0 };
        for (uint32_t i = 0; i < AW * AH; i++) {
            if (o.position[i * 4 + 3] == 0.0f)
                continue;
            for (int c = 0; c < 2; c++) {
                double want = sum[i * 2 + c] / FRAMES, got = o.visibility[i * 4 + c];
                worst = fmax(worst, fabs(got - want));
                if (want < 0.999 && want > 0.0) { /* partly occluded: where the drift shows */
                    bias[c] += got - want;
                    occluded[c]++;
                }
            }
        }
        for (int c = 0; c < 2; c++)
            bias[c] /= occluded[c] ? occluded[c] : 1;
        fprintf(stderr,
                "accumulation, %u frames: bias over partly occluded pixels: shadow %.6f (%u px), AO %.6f "
                "(%u px); worst pixel %.6f\n",
                FRAMES, bias[0], occluded[0], bias[1], occluded[1], worst);
        CHECK(occluded[1] > 200);
        CHECK(fabs(bias[0]) < 1e-4 && fabs(bias[1]) < 1e-4);
        CHECK(worst < 1e-3);
    }
    cv_render_output_free(&o);
    free(sum);
    rig_close(&g);
}

static void triangle_normal(const cv_scene *scene, const cv_hit *hit, float n[3]) {
    float v[3][3];
    cv_scene_world_triangle(scene, hit->instance, hit->triangle, v);
    float a[3], b[3];
    for (int k = 0; k < 3; k++) {
        a[k] = v[1][k] - v[0][k];
        b[k] = v[2][k] - v[0][k];
    }
    n[0] = a[1] * b[2] - a[2] * b[1];
    n[1] = a[2] * b[0] - a[0] * b[2];
    n[2] = a[0] * b[1] - a[1] * b[0];
    float l = sqrtf(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    for (int k = 0; k < 3; k++)
        n[k] /= l > 0.0f ? l : 1.0f;
}

/* Defect 2: a near plane at 1e-4 of the diagonal with float depth and LESS, no
 * culling and normals flipped toward the camera let back faces of closed
 * meshes win within a depth step: their flipped normal points into the solid.
 * At every covered pixel the CPU finds the triangle the G-buffer point lies on
 * (closest hit within 1e-4 of its distance along the camera ray); its
 * geometric normal (winding; the room's meshes are closed and wound outward)
 * must face the camera: zero back faces. Pixels whose point lies within
 * barycentric 1e-4 of a triangle edge are not counted (two triangles there).
 * Also reported: pixels where the CPU sees a nearer surface (silhouettes:
 * rasterization and ray tests differ by sub-pixel amounts), at most 0.05%,
 * and where it finds no triangle at the point, at most 0.01%. */
static void check_gbuffer_facing(const cv_scene *scene, const cv_bvh *bvh) {
    enum { GW = 320, GH = 180 };
    rig g;
    CHECK_OK(rig_open(scene, bvh, &g));
    cv_render_output o = { 0 };
    cv_render_settings s = { .width = GW, .height = GH, .frames = 1, .ao_samples = 1, .filter_iterations = -1 };
    if (g.renderer)
        CHECK_OK(cv_renderer_render(g.renderer, &s, &o, NULL, NULL, NULL));
    if (o.position) {
        cv_camera cam = *cv_scene_camera(scene, 0);
        cv_trace_target target = { .flat = bvh, .layout = CV_BVH_LAYOUT_NODE2 };
        uint32_t covered = 0, back = 0, off_surface = 0, edge = 0, nearer = 0;
        for (uint32_t i = 0; i < GW * GH; i++) {
            const float *p = &o.position[i * 4];
            if (p[3] == 0.0f)
                continue;
            covered++;
            float d[3] = { p[0] - cam.position[0], p[1] - cam.position[1], p[2] - cam.position[2] };
            float dist = sqrtf(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
            cv_ray ray = { { cam.position[0], cam.position[1], cam.position[2] },
                           0.0f,
                           { d[0] / dist, d[1] / dist, d[2] / dist },
                           dist * 1.0001f };
            cv_hit hit;
            if (cv_trace_ray(&target, &ray, 0, &hit) && hit.t < dist * 0.9999f)
                nearer++;
            ray.tmin = dist * 0.9999f;
            if (!cv_trace_ray(&target, &ray, 0, &hit)) {
                off_surface++;
                continue;
            }
            if (fminf(fminf(hit.u, hit.v), 1.0f - hit.u - hit.v) < 1e-4f) {
                edge++;
                continue;
            }
            float ng[3];
            triangle_normal(scene, &hit, ng);
            back += ng[0] * ray.dir[0] + ng[1] * ray.dir[1] + ng[2] * ray.dir[2] >= 0.0f;
        }
        fprintf(stderr,
                "gbuffer facing at %ux%u: %u covered pixels, %u on back faces, %u off any surface, %u on "
                "edges (not counted); %u where the CPU sees a nearer surface\n",
                GW, GH, covered, back, off_surface, edge, nearer);
        CHECK(covered > GW * GH / 2);
        CHECK_EQ_INT(back, 0);
        CHECK(off_surface <= covered / 10000); /* a ray through a shared edge may miss both triangles */
        CHECK(nearer <= covered / 2000);
    }
    cv_render_output_free(&o);
    rig_close(&g);
}

/* A UV sphere of radius 1 at the origin, `seg` segments and `rings` rings,
 * smooth normals, with a camera 4 units away and a sun. */
static cv_result make_sphere_scene(uint32_t seg, uint32_t rings, cv_scene **out) {
    uint32_t nv = (rings + 1) * (seg + 1), nt = rings * seg * 2;
    float *pos = malloc(nv * 3 * sizeof(float));
    uint32_t *idx = malloc(nt * 3 * sizeof(uint32_t));
    cv_scene *scene = NULL;
    cv_result res = pos && idx ? cv_scene_create(&scene) : CV_ERROR_OUT_OF_MEMORY;
    for (uint32_t r = 0; res == CV_OK && r <= rings; r++)
        for (uint32_t k = 0; k <= seg; k++) {
            float th = 3.14159265f * r / rings, ph = 6.28318531f * k / seg;
            float *p = &pos[(r * (seg + 1) + k) * 3];
            p[0] = sinf(th) * cosf(ph);
            p[1] = cosf(th);
            p[2] = -sinf(th) * sinf(ph);
        }
    uint32_t t = 0;
    for (uint32_t r = 0; res == CV_OK && r < rings; r++)
        for (uint32_t k = 0; k < seg; k++) {
            uint32_t a = r * (seg + 1) + k, b = a + 1, c = a + seg + 1, d = c + 1;
            uint32_t tri[6] = { a, c, b, b, c, d };
            memcpy(&idx[t * 3], tri, sizeof(tri));
            t += 2;
        }
    uint32_t mesh = 0;
    if (res == CV_OK)
        res = cv_scene_add_mesh(scene,
                                &(cv_mesh_desc){ .positions = pos,
                                                 .normals = pos,
                                                 .vertex_count = nv,
                                                 .indices = idx,
                                                 .triangle_count = nt,
                                                 .name = "sphere" },
                                &mesh);
    cv_material m = cv_material_default();
    if (res == CV_OK)
        res = cv_scene_add_material(scene, &m, NULL);
    cv_instance inst = { .mesh = mesh, .material = 0 };
    cv_transform_identity(inst.transform);
    if (res == CV_OK)
        res = cv_scene_add_instance(scene, &inst, NULL);
    if (res == CV_OK)
        res = cv_scene_add_camera(scene, &(cv_camera){ { 1.0f, 1.5f, 4.0f }, { 0, 0, 0 }, { 0, 1, 0 }, 0.8f }, NULL);
    if (res == CV_OK)
        res = cv_scene_add_light(scene,
                                 &(cv_light){ .type = CV_LIGHT_DIRECTIONAL,
                                              .direction = { -0.3f, -0.9f, -0.3f },
                                              .color = { 1, 1, 1 },
                                              .intensity = 3.0f },
                                 NULL);
    free(pos);
    free(idx);
    if (res != CV_OK) {
        cv_scene_destroy(scene);
        scene = NULL;
    }
    *out = scene;
    return res;
}

/* Defect 4: AO rays left from the interpolated normal's side and spanned its
 * hemisphere, so on a smooth low-poly mesh some went below the flat triangle
 * and hit the neighbouring facets. A convex sphere (12 x 6) alone: every
 * covered pixel's AO must be 1 within 1e-3 (256 rays per pixel, AO radius half
 * the sphere's radius), and every sunward pixel facing the sun's cone lit. */
static void check_sphere_unoccluded(void) {
    enum { SW = 96, SH = 54 };
    cv_scene *scene = NULL;
    cv_bvh *bvh = NULL;
    CHECK_OK(make_sphere_scene(12, 6, &scene));
    if (scene)
        CHECK_OK(cv_bvh_build_flat(scene, NULL, &bvh));
    rig g = { 0 };
    cv_render_output o = { 0 };
    if (bvh)
        CHECK_OK(rig_open(scene, bvh, &g));
    cv_render_settings s = { .width = SW,
                             .height = SH,
                             .frames = 32,
                             .ao_samples = 8,
                             .ao_radius = 0.5f,
                             .sun_cone_degrees = -1,
                             .filter_iterations = -1 };
    if (g.renderer)
        CHECK_OK(cv_renderer_render(g.renderer, &s, &o, NULL, NULL, NULL));
    if (o.visibility) {
        uint32_t covered = 0, occluded = 0;
        double sum = 0.0, least = 1.0;
        for (uint32_t i = 0; i < SW * SH; i++) {
            if (o.position[i * 4 + 3] == 0.0f)
                continue;
            covered++;
            float ao = o.visibility[i * 4 + 1];
            sum += ao;
            least = fmin(least, ao);
            occluded += ao < 0.999f;
        }
        fprintf(stderr, "sphere 12x6 in open space: %u covered pixels, mean AO %.5f, least %.4f, %u below 0.999\n",
                covered, sum / (covered ? covered : 1), least, occluded);
        CHECK(covered > 500);
        CHECK_EQ_INT(occluded, 0);
    }
    cv_render_output_free(&o);
    rig_close(&g);
    cv_bvh_destroy(bvh);
    cv_scene_destroy(scene);
}

/* GPU (64 frames x 4 AO rays, unfiltered) against the CPU reference (64
 * samples x 4 AO rays) on the room at 128x72, over pixels both cover at the
 * same point: mean bias of shadow and AO within 0.01 (sampling noise of the
 * means is ~0.002), RMSE below 0.1 (per-pixel noise of both ~0.03-0.05). */
static void check_against_reference(const cv_scene *scene, const cv_bvh *bvh) {
    enum { RW = 128, RH = 72 };
    cv_render_settings s = { .width = RW, .height = RH, .frames = 64, .ao_samples = 4, .filter_iterations = -1 };
    cv_render_output gpu = { 0 }, ref = { 0 };
    rig g;
    CHECK_OK(rig_open(scene, bvh, &g));
    if (g.renderer)
        CHECK_OK(cv_renderer_render(g.renderer, &s, &gpu, NULL, NULL, NULL));
    rig_close(&g);
    CHECK_OK(cv_render_reference(scene, bvh, &s, 64, 2, &ref));
    if (gpu.visibility && ref.visibility) {
        double bias[2] = { 0, 0 }, sq[2] = { 0, 0 };
        uint32_t both = 0, covered = 0;
        for (uint32_t i = 0; i < RW * RH; i++) {
            if (gpu.position[i * 4 + 3] == 0.0f)
                continue;
            covered++;
            const float *a = &gpu.position[i * 4], *b = &ref.position[i * 4];
            float dd = fabsf(a[0] - b[0]) + fabsf(a[1] - b[1]) + fabsf(a[2] - b[2]);
            if (b[3] == 0.0f || dd > 1e-3f)
                continue;
            both++;
            for (int c = 0; c < 2; c++) {
                double e = (double)gpu.visibility[i * 4 + c] - ref.visibility[i * 4 + c];
                bias[c] += e;
                sq[c] += e * e;
            }
        }
        for (int c = 0; c < 2; c++) {
            bias[c] /= both ? both : 1;
            sq[c] = sqrt(sq[c] / (both ? both : 1));
        }
        fprintf(stderr,
                "vs reference at %ux%u: %u of %u pixels at the same point; shadow bias %.5f RMSE %.4f, "
                "AO bias %.5f RMSE %.4f\n",
                RW, RH, both, covered, bias[0], sq[0], bias[1], sq[1]);
        CHECK(both >= covered * 0.99);
        CHECK(fabs(bias[0]) < 0.01 && fabs(bias[1]) < 0.01);
        CHECK(sq[0] < 0.1 && sq[1] < 0.1);
    }
    cv_render_output_free(&gpu);
    cv_render_output_free(&ref);
}

/* Shadow (c = 0) or AO (c = 1) of `a` against the reference `ref` over pixels
 * both cover at the same point and, if `only` is set, where only[i]: RMSE,
 * bias (a - ref), pixels. */
typedef struct vis_error {
    double rmse, bias;
    uint32_t pixels;
} vis_error;
static uint8_t same_point(const cv_render_output *a, const cv_render_output *ref, uint32_t i) {
    const float *p = &a->position[i * 4], *q = &ref->position[i * 4];
    return p[3] != 0.0f && q[3] != 0.0f && fabsf(p[0] - q[0]) + fabsf(p[1] - q[1]) + fabsf(p[2] - q[2]) <= 1e-3f;
}
static vis_error vis_compare(const cv_render_output *a, const cv_render_output *ref, int c, const uint8_t *only) {
    vis_error e = { 0 };
    for (uint32_t i = 0; i < a->width * a->height; i++) {
        if (!same_point(a, ref, i) || (only && !only[i]))
            continue;
        double d = (double)a->visibility[i * 4 + c] - ref->visibility[i * 4 + c];
        e.bias += d;
        e.rmse += d * d;
        e.pixels++;
    }
    if (e.pixels) {
        e.bias /= e.pixels;
        e.rmse = sqrt(e.rmse / e.pixels);
    }
    return e;
}

static cv_result render_once(const cv_scene *scene, const cv_bvh *bvh, const cv_render_settings *s,
                             cv_render_output *out) {
    rig g;
    cv_result res = rig_open(scene, bvh, &g);
    if (res == CV_OK)
        res = cv_renderer_render(g.renderer, s, out, NULL, NULL, NULL);
    rig_close(&g);
    return res;
}

/* Defect 5, contact shadows: the a-trous filter weighted by normal and
 * position only spread the lit floor into the thin umbrae at the foot of the
 * room's boxes. Umbra pixels: reference sun visibility <= 0.02 (256 samples)
 * with a pixel of visibility >= 0.5 within 2 pixels (the thin, edge-near part
 * a blur lifts). Mean bias of the filtered shadow there, against the
 * reference, after 1 and 64 frames at 128x72 (4 AO rays, 3 iterations):
 * measured +0.0052 and +0.0048 with the position/normal-only filter
 * (not the issue's +0.15: at this size and sun cone the room's umbrae are
 * wider than the old filter's reach across surfaces), +0.0030 and +0.0000
 * with the variance-guided one, +0.0010 and +0.0000 with its penumbra-aware
 * shadow kernel. Tolerances: 0.01 after 1 frame, 0.002
 * after 64 (where the old filter's +0.005 fails). */
#define UMBRA_TOLERANCE_1 0.01
#define UMBRA_TOLERANCE_64 0.002
static void check_filter_keeps_umbra(const cv_scene *scene, const cv_bvh *bvh) {
    enum { UW = 128, UH = 72 };
    cv_render_settings s = { .width = UW, .height = UH, .frames = 1, .ao_samples = 4 };
    cv_render_output ref = { 0 }, out[3] = { { 0 } };
    CHECK_OK(cv_render_reference(scene, bvh, &s, 256, 2, &ref));
    CHECK_OK(render_once(scene, bvh, &s, &out[0]));
    s.frames = 64;
    CHECK_OK(render_once(scene, bvh, &s, &out[1]));
    s.frames = 1;
    s.filter_iterations = -1;
    CHECK_OK(render_once(scene, bvh, &s, &out[2]));
    uint8_t *umbra = calloc(UW * UH, 1);
    if (ref.visibility && out[0].visibility && out[1].visibility && out[2].visibility && umbra) {
        uint32_t count = 0;
        for (int y = 0; y < UH; y++)
            for (int x = 0; x < UW; x++) {
                if (ref.position[(y * UW + x) * 4 + 3] == 0.0f || ref.visibility[(y * UW + x) * 4] > 0.02f)
                    continue;
                for (int dy = -2; dy <= 2; dy++)
                    for (int dx = -2; dx <= 2; dx++) {
                        int qx = x + dx, qy = y + dy;
                        if (qx >= 0 && qy >= 0 && qx < UW && qy < UH &&
                            ref.position[(qy * UW + qx) * 4 + 3] != 0.0f &&
                            ref.visibility[(qy * UW + qx) * 4] >= 0.5f)
                            umbra[y * UW + x] = 1;
                    }
                count += umbra[y * UW + x];
            }
        vis_error e1 = vis_compare(&out[0], &ref, 0, umbra), e64 = vis_compare(&out[1], &ref, 0, umbra),
                  raw = vis_compare(&out[2], &ref, 0, umbra);
        fprintf(stderr,
                "umbra near lit pixels at %ux%u (%u px): shadow bias vs reference: 1 frame filtered %+.4f "
                "(unfiltered %+.4f), 64 frames filtered %+.4f\n",
                UW, UH, e1.pixels, e1.bias, raw.bias, e64.bias);
        CHECK(count > 40);
        CHECK(e1.bias < UMBRA_TOLERANCE_1);
        CHECK(e64.bias < UMBRA_TOLERANCE_64);
    }
    free(umbra);
    for (int k = 0; k < 3; k++)
        cv_render_output_free(&out[k]);
    cv_render_output_free(&ref);
}

/* Defect 5, one frame: at 64x36, 4 AO rays, the filtered shadow and AO after
 * one frame against a 256-sample reference (converged to ~0.03 per pixel at
 * worst): RMSE below the unfiltered frame's and below ONE_FRAME_RMSE_*
 * (measured 0.0289 and 0.0638 before the penumbra-aware shadow kernel, 0.0239
 * and 0.0630 with it; unfiltered 0.0304 and 0.0669; with the blue-noise
 * sample points 0.0212 and 0.0524, unfiltered 0.0335 and 0.0560; with the
 * kernels from the pixel footprint 0.0223 and 0.0510: the shadow's kernel
 * trades this size for the larger ones, docs/renderer-quality.md; with the
 * AO's local linear fit 0.0224 and 0.0505), mean bias within 0.01. */
#define ONE_FRAME_RMSE_SHADOW 0.025
#define ONE_FRAME_RMSE_AO 0.056
static void check_filter_one_frame(const cv_scene *scene, const cv_bvh *bvh) {
    enum { OW = 64, OH = 36 };
    cv_render_settings s = { .width = OW, .height = OH, .frames = 1, .ao_samples = 4 };
    cv_render_output ref = { 0 }, filtered = { 0 }, raw = { 0 };
    CHECK_OK(cv_render_reference(scene, bvh, &s, 256, 2, &ref));
    CHECK_OK(render_once(scene, bvh, &s, &filtered));
    s.filter_iterations = -1;
    CHECK_OK(render_once(scene, bvh, &s, &raw));
    if (ref.visibility && filtered.visibility && raw.visibility) {
        vis_error f[2], r[2];
        for (int c = 0; c < 2; c++) {
            f[c] = vis_compare(&filtered, &ref, c, NULL);
            r[c] = vis_compare(&raw, &ref, c, NULL);
        }
        fprintf(stderr,
                "1 frame at %ux%u vs 256-sample reference (%u px): shadow RMSE filtered %.4f (unfiltered "
                "%.4f) bias %+.4f; AO RMSE filtered %.4f (unfiltered %.4f) bias %+.4f\n",
                OW, OH, f[0].pixels, f[0].rmse, r[0].rmse, f[0].bias, f[1].rmse, r[1].rmse, f[1].bias);
        CHECK(f[0].pixels > OW * OH / 2);
        CHECK(f[0].rmse < ONE_FRAME_RMSE_SHADOW && f[0].rmse < r[0].rmse);
        CHECK(f[1].rmse < ONE_FRAME_RMSE_AO && f[1].rmse < r[1].rmse);
        CHECK(fabs(f[0].bias) < 0.01 && fabs(f[1].bias) < 0.01);
    }
    cv_render_output_free(&ref);
    cv_render_output_free(&filtered);
    cv_render_output_free(&raw);
}

/* Defect 5, converged: after 1024 frames (1 AO ray) every pixel's variance of
 * the mean is below the filter's threshold (a binary shadow ray: at most
 * 0.25 / 1024), so the filter leaves the accumulation as it is: filtered
 * equals unfiltered within 1e-4 on every pixel. And issue 11's goal for the
 * unfiltered accumulation: its mean bias against a 1024-sample reference (1
 * AO ray, as the frames) is below 0.002 for shadow and AO (measured with the
 * blue-noise sample points: shadow -0.00000, AO -0.00016). */
static void check_filter_converged(const cv_scene *scene, const cv_bvh *bvh) {
    enum { CW = 64, CH = 36 };
    cv_render_settings s = { .width = CW, .height = CH, .frames = 1024, .ao_samples = 1 };
    cv_render_output filtered = { 0 }, raw = { 0 };
    CHECK_OK(render_once(scene, bvh, &s, &filtered));
    s.filter_iterations = -1;
    CHECK_OK(render_once(scene, bvh, &s, &raw));
    if (filtered.visibility && raw.visibility) {
        double worst = 0.0;
        uint32_t over = 0;
        for (uint32_t i = 0; i < CW * CH * 4; i++) {
            double d = fabs((double)filtered.visibility[i] - raw.visibility[i]);
            worst = fmax(worst, d);
            over += d > 1e-4;
        }
        fprintf(stderr, "1024 frames at %ux%u: filtered vs unfiltered: worst %.2e, %u values over 1e-4\n", CW, CH,
                worst, over);
        CHECK(worst <= 1e-4);
    }
    cv_render_output ref = { 0 };
    CHECK_OK(cv_render_reference(scene, bvh, &s, 1024, 2, &ref));
    if (raw.visibility && ref.visibility) {
        vis_error e[2] = { vis_compare(&raw, &ref, 0, NULL), vis_compare(&raw, &ref, 1, NULL) };
        fprintf(stderr, "1024 frames unfiltered vs 1024 samples (%u px): bias shadow %+.5f, AO %+.5f\n", e[0].pixels,
                e[0].bias, e[1].bias);
        CHECK(e[0].pixels > CW * CH / 2);
        CHECK(fabs(e[0].bias) < 0.002 && fabs(e[1].bias) < 0.002);
    }
    /* 4 shadow rays a frame walk the same sequence of points in the sun's
     * cone, 4 a frame: 256 frames unfiltered have no bias either. */
    cv_render_output four = { 0 };
    s.frames = 256, s.shadow_samples = 4;
    CHECK_OK(render_once(scene, bvh, &s, &four));
    if (four.visibility && ref.visibility) {
        vis_error e = vis_compare(&four, &ref, 0, NULL);
        fprintf(stderr, "256 frames x 4 shadow rays unfiltered vs 1024 samples (%u px): shadow bias %+.5f\n",
                e.pixels, e.bias);
        CHECK(e.pixels > CW * CH / 2);
        CHECK(fabs(e.bias) < 0.002);
    }
    cv_render_output_free(&four);
    cv_render_output_free(&ref);
    cv_render_output_free(&filtered);
    cv_render_output_free(&raw);
}

/* Issue 11's one-frame goals on the room at 160x90 (4 AO rays, 3 filter
 * iterations): the filtered shadow and AO of one frame against the reference,
 * over the pixels both cover at the same point, with cv_image_metrics (what
 * corvid-compare prints). The reference here has ROOM_REFERENCE_SAMPLES = 256
 * samples (the figures in docs/renderer-quality.md are against 4096; 1024
 * took the test past its 300 s under ASan).
 * Pixels whose G-buffer point is not the reference's (silhouettes, raster vs
 * ray) are left out, which corvid-compare does not do. Measured: shadow RMSE
 * 0.0207, SSIM 0.9929; AO RMSE 0.0461, SSIM 0.9299 (against 1024 samples
 * 0.0204 / 0.9930 and 0.0458 / 0.9308; before the penumbra-aware shadow
 * kernel and sigma_l 8 in the first frames, against 1024: 0.0245 / 0.9922 and
 * 0.0467 / 0.9292). With the AO samples' spatially decorrelated rotation
 * (R2 dither / interleaved gradient noise instead of a per-pixel hash,
 * render_raygen.comp): AO RMSE 0.0434, SSIM 0.9379 (shadow unchanged).
 * With sample points from the blue-noise mask (AO: a Sobol block xor-shifted
 * by the mask; shadow: the mask plus R2 of the frame): shadow RMSE 0.0201,
 * SSIM 0.9949; AO RMSE 0.0394, SSIM 0.9419 (against 4096 samples, all
 * covered pixels: 0.0219 / 0.9939 and 0.0389 / 0.9418). With the AO's
 * local linear fit (and the footprint kernels before it): shadow 0.0204 /
 * 0.9952, AO 0.0389 / 0.9408.
 * Goals RMSE 0.02, SSIM 0.97:
 * shadow meets SSIM and comes within 0.0001 of the RMSE here (0.002 with
 * the silhouettes, against 4096); AO meets neither.
 * The tolerances are a little looser than measured, so a regression fails. */
#define ROOM_REFERENCE_SAMPLES 256
#define ROOM_SHADOW_RMSE 0.021
#define ROOM_SHADOW_SSIM 0.993
#define ROOM_AO_RMSE 0.041
#define ROOM_AO_SSIM 0.938
static void check_room_one_frame(const cv_scene *scene, const cv_bvh *bvh) {
    enum { RW = 160, RH = 90 };
    cv_render_settings s = { .width = RW, .height = RH, .frames = 1 };
    cv_render_output ref = { 0 }, out = { 0 };
    CHECK_OK(cv_render_reference(scene, bvh, &s, ROOM_REFERENCE_SAMPLES, 2, &ref));
    CHECK_OK(render_once(scene, bvh, &s, &out));
    uint8_t *mask = calloc(RW * RH, 1);
    float *a = malloc(RW * RH * sizeof(float)), *b = malloc(RW * RH * sizeof(float));
    if (ref.visibility && out.visibility && mask && a && b) {
        for (uint32_t i = 0; i < RW * RH; i++)
            mask[i] = same_point(&out, &ref, i);
        cv_image_metrics m[2];
        for (int c = 0; c < 2; c++) {
            for (uint32_t i = 0; i < RW * RH; i++)
                a[i] = ref.visibility[i * 4 + c], b[i] = out.visibility[i * 4 + c];
            CHECK_OK(cv_image_metrics_f32(a, b, mask, RW, RH, 1.0, &m[c]));
        }
        fprintf(stderr,
                "room %ux%u, 1 frame filtered vs %u samples (%llu px): shadow RMSE %.4f SSIM %.4f bias %+.4f; "
                "AO RMSE %.4f SSIM %.4f bias %+.4f\n",
                RW, RH, ROOM_REFERENCE_SAMPLES, (unsigned long long)m[0].pixels, m[0].rmse, m[0].ssim, m[0].bias,
                m[1].rmse, m[1].ssim, m[1].bias);
        CHECK(m[0].pixels > RW * RH / 2);
        CHECK(m[0].rmse < ROOM_SHADOW_RMSE && m[0].ssim > ROOM_SHADOW_SSIM);
        CHECK(m[1].rmse < ROOM_AO_RMSE && m[1].ssim > ROOM_AO_SSIM);
        CHECK(fabs(m[0].bias) < 0.005 && fabs(m[1].bias) < 0.005);
    }
    free(mask);
    free(a);
    free(b);
    cv_render_output_free(&ref);
    cv_render_output_free(&out);
}

/* One frame with more rays (room 160x90, 16 AO rays, reflections off)
 * against a 256-sample reference with 16 AO rays a sample, over the pixels
 * both cover at the same point:
 *  - AO, the local linear fit (render_filter.comp): the a-trous weighted mean
 *    it replaced was one-sided at creases, a bias that more rays do not
 *    remove. Measured here 0.0192; the weighted mean, measured with
 *    corvid-render and corvid-compare over all covered pixels (this test
 *    leaves silhouettes out), 0.0251 against the fit's 0.0198. Tolerance 0.022.
 *  - shadow_samples 4: every unfiltered value is a multiple of 1/4 (the
 *    visibility texel's 32nds), penumbra pixels are partly lit (71 here),
 *    and the filtered shadow's RMSE falls from 0.0206 (1 ray) to 0.0094
 *    (unfiltered 0.0117). Tolerances: under 0.013 and under 0.8 times the
 *    one-ray frame's. */
#define MORE_RAYS_AO_RMSE 0.022
#define MORE_RAYS_SHADOW_RMSE 0.013
static void check_more_rays_one_frame(const cv_scene *scene, const cv_bvh *bvh) {
    enum { MW = 160, MH = 90 };
    cv_render_settings s = { .width = MW, .height = MH, .frames = 1, .ao_samples = 16, .reflections = -1 };
    cv_render_output ref = { 0 }, out[3] = { { 0 } };
    CHECK_OK(cv_render_reference(scene, bvh, &s, 256, 2, &ref));
    CHECK_OK(render_once(scene, bvh, &s, &out[0])); /* 1 shadow ray */
    s.shadow_samples = 4;
    CHECK_OK(render_once(scene, bvh, &s, &out[1]));
    s.filter_iterations = -1;
    CHECK_OK(render_once(scene, bvh, &s, &out[2]));
    if (ref.visibility && out[0].visibility && out[1].visibility && out[2].visibility) {
        vis_error one = vis_compare(&out[0], &ref, 0, NULL), four = vis_compare(&out[1], &ref, 0, NULL),
                  raw = vis_compare(&out[2], &ref, 0, NULL), ao = vis_compare(&out[1], &ref, 1, NULL);
        uint32_t off_grid = 0, partly = 0;
        for (uint32_t i = 0; i < MW * MH; i++) {
            float v = out[2].visibility[i * 4] * 4.0f;
            off_grid += v != floorf(v) || v < 0.0f || v > 4.0f;
            partly += v > 0.0f && v < 4.0f;
        }
        fprintf(stderr,
                "room %ux%u, 1 frame, 16 AO rays vs 256 samples (%u px): AO RMSE %.4f; shadow RMSE 1 ray %.4f, "
                "4 rays %.4f (unfiltered %.4f: %u px partly lit, %u off the 1/4 grid)\n",
                MW, MH, ao.pixels, ao.rmse, one.rmse, four.rmse, raw.rmse, partly, off_grid);
        CHECK(ao.pixels > MW * MH / 2);
        CHECK(ao.rmse < MORE_RAYS_AO_RMSE);
        CHECK(four.rmse < MORE_RAYS_SHADOW_RMSE && four.rmse < 0.8 * one.rmse);
        CHECK(off_grid == 0);
        CHECK(partly > 40);
    }
    for (int k = 0; k < 3; k++)
        cv_render_output_free(&out[k]);
    cv_render_output_free(&ref);
}

/* Fraction of the energy of a 64x64 mask of ranks (as values in (0, 1), mean
 * removed) at spatial frequencies below 1/8 cycle per cell (radius 8 of 64 in
 * the DFT), of all but the DC term. White noise puts ~ pi 8^2 / 4095 = 4.9%
 * there (an equal share per frequency); blue noise next to nothing. */
#define MASK_PI 3.14159265358979323846
static double low_frequency_share(const uint16_t *ranks) {
    enum { S = CV_BLUE_NOISE_SIZE };
    static double re[S][S], im[S][S]; /* row transforms */
    for (int y = 0; y < S; y++)
        for (int u = 0; u < S; u++) {
            re[y][u] = im[y][u] = 0.0;
            for (int x = 0; x < S; x++) {
                double v = (ranks[y * S + x] + 0.5) / (S * S) - 0.5, a = -2.0 * MASK_PI * u * x / S;
                re[y][u] += v * cos(a);
                im[y][u] += v * sin(a);
            }
        }
    double low = 0.0, all = 0.0;
    for (int u = 0; u < S; u++)
        for (int w = 0; w < S; w++) {
            double cr = 0.0, ci = 0.0;
            for (int y = 0; y < S; y++) {
                double a = -2.0 * MASK_PI * w * y / S, c = cos(a), s = sin(a);
                cr += re[y][u] * c - im[y][u] * s;
                ci += re[y][u] * s + im[y][u] * c;
            }
            int fu = u < S / 2 ? u : u - S, fw = w < S / 2 ? w : w - S;
            if (fu == 0 && fw == 0)
                continue;
            double e = cr * cr + ci * ci;
            all += e;
            low += fu * fu + fw * fw < 64 ? e : 0.0;
        }
    return low / all;
}

/* The blue-noise rank mask (corvid/blue_noise.h), which render.raygen reads
 * (the renderer loads it as a buffer): its 4096 ranks are a
 * permutation; its low-frequency energy share is far below white noise's
 * (measured 0.00002 vs 0.0474 for a hashed permutation; asserted
 * below a tenth of the white mask's); the 10% of cells of lowest rank (a
 * dither threshold) lie at least 2 cells apart on the torus; two calls give
 * the same bytes, and these bytes (FNV-1a 64 MASK_FNV) on every host: the
 * mask is computed in integers. */
#define MASK_FNV 0xe28fb7b868918191ull
static void check_blue_noise_mask(void) {
    enum { S = CV_BLUE_NOISE_SIZE, CELLS = CV_BLUE_NOISE_CELLS };
    static uint16_t ranks[CELLS], again[CELLS], white[CELLS];
    static uint8_t seen[CELLS];
    cv_blue_noise_ranks(ranks);
    cv_blue_noise_ranks(again);
    CHECK(memcmp(ranks, again, sizeof(ranks)) == 0);
    uint32_t distinct = 0;
    for (uint32_t i = 0; i < CELLS; i++)
        if (ranks[i] < CELLS && !seen[ranks[i]]++)
            distinct++;
    CHECK_EQ_INT(distinct, CELLS);
    uint64_t fnv = 0xcbf29ce484222325ull;
    for (uint32_t i = 0; i < CELLS; i++)
        for (int b = 0; b < 2; b++)
            fnv = (fnv ^ ((ranks[i] >> (8 * b)) & 0xFFu)) * 0x100000001b3ull;
    /* White noise: a Fisher-Yates shuffle driven by an integer hash. */
    for (uint32_t i = 0; i < CELLS; i++)
        white[i] = (uint16_t)i;
    for (uint32_t i = CELLS - 1, h = 12345u; i > 0; i--) {
        h = h * 1664525u + 1013904223u;
        uint32_t j = (h >> 8) % (i + 1);
        uint16_t t = white[i];
        white[i] = white[j];
        white[j] = t;
    }
    double blue_low = low_frequency_share(ranks), white_low = low_frequency_share(white);
    int closest = 1 << 30;
    for (uint32_t i = 0; i < CELLS; i++)
        for (uint32_t j = i + 1; j < CELLS; j++) {
            if (ranks[i] >= CELLS / 10 || ranks[j] >= CELLS / 10)
                continue;
            int dx = abs((int)(i % S) - (int)(j % S)), dy = abs((int)(i / S) - (int)(j / S));
            dx = dx < S - dx ? dx : S - dx;
            dy = dy < S - dy ? dy : S - dy;
            closest = dx * dx + dy * dy < closest ? dx * dx + dy * dy : closest;
        }
    fprintf(stderr,
            "blue-noise mask %ux%u: %u distinct ranks, low-frequency energy share %.5f (white %.5f), lowest 10%% "
            "at least %.2f cells apart, FNV-1a %016llx\n",
            S, S, distinct, blue_low, white_low, sqrt(closest), (unsigned long long)fnv);
    CHECK(white_low > 0.03);
    CHECK(blue_low < white_low / 10);
    CHECK(closest >= 4);
    CHECK(fnv == MASK_FNV);
}

int main(void) {
    cv_scene *scene = NULL;
    cv_bvh *bvh = NULL;
    CHECK_OK(cv_scene_make_room(1, &scene));
    CHECK_OK(cv_bvh_build_flat(scene, NULL, &bvh));
    if (scene && bvh) {
        check_gbuffer_facing(scene, bvh);
        check_accumulation_unbiased(scene, bvh);
        check_against_reference(scene, bvh);
        check_filter_keeps_umbra(scene, bvh);
        check_filter_one_frame(scene, bvh);
        check_filter_converged(scene, bvh);
        check_room_one_frame(scene, bvh);
        check_more_rays_one_frame(scene, bvh);
    }
    check_sphere_unoccluded();
    check_blue_noise_mask();
    CHECK_EQ_INT(cv_vulkan_validation_message_count(), 0);
    cv_bvh_destroy(bvh);
    cv_scene_destroy(scene);
    CHECK_NOTHING_LIVE();
    return check_report("renderer quality");
}
