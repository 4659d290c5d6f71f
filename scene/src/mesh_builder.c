/* Mesh builder and prop shapes. All angles go through det_math.h so the
 * shapes are bit-identical on every machine. */
#include "mesh_builder.h"

#include <stdlib.h>
#include <string.h>

#include "det_math.h"
#include "prng.h"
#include "vec3.h"

void cvs_mb_init(cvs_mesh_builder *b) { memset(b, 0, sizeof *b); }

void cvs_mb_free(cvs_mesh_builder *b) {
    free(b->positions);
    free(b->normals);
    free(b->uvs);
    free(b->indices);
    memset(b, 0, sizeof *b);
}

static bool reserve_vertex(cvs_mesh_builder *b) {
    if (b->vertex_count < b->vertex_cap)
        return true;
    uint32_t cap = b->vertex_cap ? b->vertex_cap * 2 : 64;
    float *p = realloc(b->positions, (size_t)cap * 3 * sizeof(float));
    if (p)
        b->positions = p;
    float *n = realloc(b->normals, (size_t)cap * 3 * sizeof(float));
    if (n)
        b->normals = n;
    float *t = realloc(b->uvs, (size_t)cap * 2 * sizeof(float));
    if (t)
        b->uvs = t;
    if (!p || !n || !t)
        return false;
    b->vertex_cap = cap;
    return true;
}

uint32_t cvs_mb_vertex(cvs_mesh_builder *b, const float p[3], const float n[3], float u, float v) {
    if (b->failed || !reserve_vertex(b)) {
        b->failed = true;
        return 0;
    }
    uint32_t i = b->vertex_count++;
    v3_copy(&b->positions[3 * i], p);
    v3_copy(&b->normals[3 * i], n);
    b->uvs[2 * i] = u;
    b->uvs[2 * i + 1] = v;
    return i;
}

void cvs_mb_triangle(cvs_mesh_builder *b, uint32_t a, uint32_t c, uint32_t d) {
    if (b->failed)
        return;
    if (b->triangle_count == b->triangle_cap) {
        uint32_t cap = b->triangle_cap ? b->triangle_cap * 2 : 64;
        uint32_t *p = realloc(b->indices, (size_t)cap * 3 * sizeof(uint32_t));
        if (!p) {
            b->failed = true;
            return;
        }
        b->indices = p;
        b->triangle_cap = cap;
    }
    uint32_t *t = &b->indices[3 * b->triangle_count++];
    t[0] = a;
    t[1] = c;
    t[2] = d;
}

void cvs_mb_flat_polygon(cvs_mesh_builder *b, const float (*pts)[3], int count) {
    float e1[3], e2[3], n[3], centroid[3] = { 0, 0, 0 };
    v3_sub(e1, pts[1], pts[0]);
    v3_sub(e2, pts[2], pts[0]);
    v3_cross(n, e1, e2);
    for (int i = 0; i < count; i++)
        v3_add(centroid, centroid, pts[i]);
    bool flip = v3_dot(n, centroid) < 0.0f;
    v3_normalize(n, n);
    if (flip)
        v3_scale(n, n, -1.0f);
    /* Planar uvs on the two axes the face spans most. */
    int axis = 0;
    for (int k = 1; k < 3; k++)
        if (fabsf(n[k]) > fabsf(n[axis]))
            axis = k;
    int ua = (axis + 1) % 3, va = (axis + 2) % 3;
    uint32_t idx[8];
    for (int i = 0; i < count; i++)
        idx[i] = cvs_mb_vertex(b, pts[i], n, pts[i][ua] + 0.5f, pts[i][va] + 0.5f);
    for (int i = 1; i + 1 < count; i++) {
        if (flip)
            cvs_mb_triangle(b, idx[0], idx[i + 1], idx[i]);
        else
            cvs_mb_triangle(b, idx[0], idx[i], idx[i + 1]);
    }
}

cv_result cvs_mb_add_to_scene(cvs_mesh_builder *b, cv_scene *scene, const char *name, uint32_t *out_index) {
    if (b->failed)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "procedural mesh '%s': out of memory after %u vertices", name,
                        b->vertex_count);
    cv_mesh_desc d = {
        .positions = b->positions,
        .normals = b->smooth ? NULL : b->normals,
        .uvs = b->uvs,
        .vertex_count = b->vertex_count,
        .indices = b->indices,
        .triangle_count = b->triangle_count,
        .name = name,
    };
    return cv_scene_add_mesh(scene, &d, out_index);
}

void cvs_shape_box(cvs_mesh_builder *b) { cvs_shape_beveled_box(b, 0.0f); }

void cvs_shape_beveled_box(cvs_mesh_builder *b, float bevel) {
    const float h = 0.5f, in = 0.5f - bevel;
    /* Six faces, each the square at distance h along +-axis. */
    for (int axis = 0; axis < 3; axis++) {
        for (int s = -1; s <= 1; s += 2) {
            float q[4][3];
            const float corners[4][2] = { { -1, -1 }, { 1, -1 }, { 1, 1 }, { -1, 1 } };
            for (int i = 0; i < 4; i++) {
                q[i][axis] = (float)s * h;
                q[i][(axis + 1) % 3] = corners[i][0] * in;
                q[i][(axis + 2) % 3] = corners[i][1] * in;
            }
            cvs_mb_flat_polygon(b, (const float(*)[3])q, 4);
        }
    }
    if (bevel <= 0.0f)
        return;
    /* Twelve edge strips: along `axis`, between the faces of the two other axes. */
    for (int axis = 0; axis < 3; axis++) {
        int a1 = (axis + 1) % 3, a2 = (axis + 2) % 3;
        for (int s1 = -1; s1 <= 1; s1 += 2) {
            for (int s2 = -1; s2 <= 1; s2 += 2) {
                float q[4][3];
                for (int i = 0; i < 4; i++) {
                    q[i][axis] = (i == 0 || i == 3) ? -in : in;
                    bool on_face1 = i < 2;
                    q[i][a1] = (float)s1 * (on_face1 ? h : in);
                    q[i][a2] = (float)s2 * (on_face1 ? in : h);
                }
                cvs_mb_flat_polygon(b, (const float(*)[3])q, 4);
            }
        }
    }
    /* Eight corner triangles. */
    for (int c = 0; c < 8; c++) {
        float s[3] = { (c & 1) ? 1.0f : -1.0f, (c & 2) ? 1.0f : -1.0f, (c & 4) ? 1.0f : -1.0f };
        float t[3][3];
        for (int k = 0; k < 3; k++)
            for (int j = 0; j < 3; j++)
                t[k][j] = s[j] * (j == k ? h : in);
        cvs_mb_flat_polygon(b, (const float(*)[3])t, 3);
    }
}

void cvs_shape_sphere(cvs_mesh_builder *b, uint32_t slices, uint32_t stacks) {
    uint32_t base = b->vertex_count;
    for (uint32_t i = 0; i <= stacks; i++) {
        double theta = CVS_PI * (double)i / (double)stacks;
        double st, ct;
        cvs_sincos(theta, &st, &ct);
        for (uint32_t j = 0; j <= slices; j++) {
            double phi = 2.0 * CVS_PI * (double)(j % slices) / (double)slices;
            double sp, cp;
            cvs_sincos(phi, &sp, &cp);
            float n[3] = { (float)(st * cp), (float)ct, (float)(st * sp) };
            float p[3];
            v3_scale(p, n, 0.5f);
            cvs_mb_vertex(b, p, n, (float)j / (float)slices, (float)i / (float)stacks);
        }
    }
    uint32_t row = slices + 1;
    for (uint32_t i = 0; i < stacks; i++) {
        for (uint32_t j = 0; j < slices; j++) {
            uint32_t a = base + i * row + j, c = a + row;
            if (i > 0)
                cvs_mb_triangle(b, a, a + 1, c);
            if (i + 1 < stacks)
                cvs_mb_triangle(b, a + 1, c + 1, c);
        }
    }
}

/* A body of revolution around y from y = -0.5 (radius 0.5) to y = 0.5
 * (radius top_radius), with flat caps; hard edges between the sides. */
static void revolve(cvs_mesh_builder *b, uint32_t segments, float top_radius) {
    for (uint32_t j = 0; j < segments; j++) {
        double p0s, p0c, p1s, p1c;
        cvs_sincos(2.0 * CVS_PI * j / segments, &p0s, &p0c);
        cvs_sincos(2.0 * CVS_PI * (j + 1) / segments, &p1s, &p1c);
        float bot0[3] = { 0.5f * (float)p0c, -0.5f, 0.5f * (float)p0s };
        float bot1[3] = { 0.5f * (float)p1c, -0.5f, 0.5f * (float)p1s };
        float top0[3] = { top_radius * (float)p0c, 0.5f, top_radius * (float)p0s };
        float top1[3] = { top_radius * (float)p1c, 0.5f, top_radius * (float)p1s };
        float centre_bot[3] = { 0.0f, -0.5f, 0.0f }, centre_top[3] = { 0.0f, 0.5f, 0.0f };
        if (top_radius > 0.0f) {
            const float side[4][3] = { { bot0[0], bot0[1], bot0[2] },
                                       { bot1[0], bot1[1], bot1[2] },
                                       { top1[0], top1[1], top1[2] },
                                       { top0[0], top0[1], top0[2] } };
            cvs_mb_flat_polygon(b, side, 4);
            const float cap[3][3] = { { centre_top[0], centre_top[1], centre_top[2] },
                                      { top0[0], top0[1], top0[2] },
                                      { top1[0], top1[1], top1[2] } };
            cvs_mb_flat_polygon(b, cap, 3);
        } else {
            const float side[3][3] = { { bot0[0], bot0[1], bot0[2] },
                                       { bot1[0], bot1[1], bot1[2] },
                                       { top0[0], top0[1], top0[2] } };
            cvs_mb_flat_polygon(b, side, 3);
        }
        const float cap[3][3] = { { centre_bot[0], centre_bot[1], centre_bot[2] },
                                  { bot0[0], bot0[1], bot0[2] },
                                  { bot1[0], bot1[1], bot1[2] } };
        cvs_mb_flat_polygon(b, cap, 3);
    }
}

void cvs_shape_cylinder(cvs_mesh_builder *b, uint32_t segments) { revolve(b, segments, 0.5f); }
void cvs_shape_cone(cvs_mesh_builder *b, uint32_t segments) { revolve(b, segments, 0.0f); }

void cvs_shape_blob(cvs_mesh_builder *b, uint32_t triangle_count, uint64_t seed) {
    uint32_t slices = 3;
    while ((uint64_t)slices * slices < triangle_count)
        slices++;
    uint32_t stacks = 2 + (triangle_count - 1) / (2 * slices);
    /* Three waves; integer frequencies around y keep the seam closed. */
    cvs_rng rng = cvs_rng_make(seed, 0xB10B);
    double amp[3], ft[3], fp[3], pt[3], pp[3];
    for (int k = 0; k < 3; k++) {
        amp[k] = cvs_rng_range(&rng, 0.03f, 0.1f);
        ft[k] = (double)(1 + cvs_rng_below(&rng, 4));
        fp[k] = (double)(1 + cvs_rng_below(&rng, 4));
        pt[k] = cvs_rng_range(&rng, 0.0f, 6.2831853f);
        pp[k] = cvs_rng_range(&rng, 0.0f, 6.2831853f);
    }
    b->smooth = true;
    const float up[3] = { 0.0f, 1.0f, 0.0f };
    uint32_t base = b->vertex_count;
    for (uint32_t i = 0; i <= stacks; i++) {
        double theta = CVS_PI * (double)i / (double)stacks;
        double st, ct;
        cvs_sincos(theta, &st, &ct);
        uint32_t ring = (i == 0 || i == stacks) ? 1 : slices;
        for (uint32_t j = 0; j < ring; j++) {
            double phi = 2.0 * CVS_PI * (double)j / (double)slices;
            double sp, cp;
            cvs_sincos(phi, &sp, &cp);
            double r = 0.5;
            for (int k = 0; k < 3; k++) {
                double s1 = cvs_sinf(ft[k] * theta + pt[k]), s2 = cvs_sinf(fp[k] * phi + pp[k]);
                r += amp[k] * s1 * s2;
            }
            float p[3] = { (float)(r * st * cp), (float)(r * ct), (float)(r * st * sp) };
            cvs_mb_vertex(b, p, up, (float)j / (float)slices, (float)i / (float)stacks);
        }
    }
    /* Vertex of ring i (1..stacks-1), slice j; the poles are single vertices. */
#define RING(i, j) (base + 1 + ((i)-1) * slices + ((j) % slices))
    uint32_t north = base, south = base + 1 + (stacks - 1) * slices;
    uint32_t emitted = 0;
    for (uint32_t i = 0; i < stacks && emitted < triangle_count; i++) {
        for (uint32_t j = 0; j < slices && emitted < triangle_count; j++) {
            if (i == 0) {
                cvs_mb_triangle(b, north, RING(1, j + 1), RING(1, j));
                emitted++;
            } else if (i + 1 == stacks) {
                cvs_mb_triangle(b, RING(i, j), RING(i, j + 1), south);
                emitted++;
            } else {
                cvs_mb_triangle(b, RING(i, j), RING(i, j + 1), RING(i + 1, j + 1));
                if (++emitted < triangle_count) {
                    cvs_mb_triangle(b, RING(i, j), RING(i + 1, j + 1), RING(i + 1, j));
                    emitted++;
                }
            }
        }
    }
#undef RING
}
