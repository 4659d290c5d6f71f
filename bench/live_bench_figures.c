/* bench_live's figures (live_bench_viewer.h): per-frame records and
 * motion-to-photon samples of a run, their row; the orbit input and the size
 * of the raw planes. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "live_bench_viewer.h"

void viewer_figures_init(viewer_figures *f, const char *name) { *f = (viewer_figures){ .name = name }; }

void viewer_figures_add(viewer_figures *f, const viewer_frame *frame) {
    if (f->frames == f->capacity) {
        size_t cap = f->capacity ? 2 * f->capacity : 256;
        viewer_frame *p = realloc(f->frame, cap * sizeof(*p));
        if (!p) {
            f->failed = true;
            return;
        }
        f->frame = p;
        f->capacity = cap;
    }
    f->frame[f->frames++] = *frame;
}

void viewer_figures_m2p(viewer_figures *f, double ms) {
    if (f->m2p_count == f->m2p_capacity) {
        size_t cap = f->m2p_capacity ? 2 * f->m2p_capacity : 64;
        double *p = realloc(f->m2p, cap * sizeof(*p));
        if (!p) {
            f->failed = true;
            return;
        }
        f->m2p = p;
        f->m2p_capacity = cap;
    }
    f->m2p[f->m2p_count++] = ms;
}

double viewer_warmup_ms(double seconds) { return seconds * 200.0 < 1000.0 ? seconds * 200.0 : 1000.0; }

static int by_value(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

void viewer_figures_print_header(void) {
    printf("%-12s %7s %7s %7s %7s %9s %7s %7s %7s %8s %7s %8s %s\n", "path", "fps", "m2p", "p95", "max", "kB/frame",
           "render", "read", "encode", "transfer", "decode", "Mbit/s", "rendered/presented/spoiled");
}

void viewer_figures_print(viewer_figures *f) {
    double sum[5] = { 0 }, bytes = 0;
    for (size_t i = 0; i < f->frames; i++) {
        const viewer_frame *fr = &f->frame[i];
        double v[5] = { fr->render_ms, fr->read_ms, fr->encode_ms, fr->transfer_ms, fr->decode_ms };
        for (int k = 0; k < 5; k++)
            sum[k] += v[k];
        bytes += (double)fr->bytes;
    }
    double n = f->frames ? (double)f->frames : 1.0, window_s = (f->end_ms - f->start_ms) / 1e3;
    double m2p_mean = 0;
    qsort(f->m2p, f->m2p_count, sizeof(double), by_value);
    for (size_t i = 0; i < f->m2p_count; i++)
        m2p_mean += f->m2p[i] / (double)f->m2p_count;
    double p95 = f->m2p_count ? f->m2p[(size_t)ceil(0.95 * (double)f->m2p_count) - 1] : 0;
    double max = f->m2p_count ? f->m2p[f->m2p_count - 1] : 0;
    printf("%-12s %7.1f %7.1f %7.1f %7.1f %9.1f %7.2f %7.2f %7.2f %8.2f %7.2f %8.2f", f->name,
           window_s > 0 ? (double)f->frames / window_s : 0, m2p_mean, p95, max, bytes / n / 1e3, sum[0] / n,
           sum[1] / n, sum[2] / n, sum[3] / n, sum[4] / n, window_s > 0 ? bytes * 8.0 / window_s / 1e6 : 0);
    if (f->presented)
        printf(" %llu/%llu/%llu", (unsigned long long)f->rendered, (unsigned long long)f->presented,
               (unsigned long long)f->spoiled);
    printf("  (%zu frames, %zu inputs%s)\n", f->frames, f->m2p_count,
           f->failed ? "; some not recorded: no memory" : "");
    free(f->frame);
    free(f->m2p);
    *f = (viewer_figures){ 0 };
}

void viewer_camera_init(viewer_camera *c, cv_render_settings *s, const cv_scene *scene) {
    cv_camera cam = cv_render_camera(s, scene, 0);
    memcpy(c->eye, cam.position, sizeof c->eye);
    memcpy(c->target, cam.target, sizeof c->target);
    memcpy(s->camera_eye, c->eye, sizeof c->eye);
    memcpy(s->camera_target, c->target, sizeof c->target);
    s->camera_fov_degrees = cam.vertical_fov * 180.0f / 3.14159265f;
}

void viewer_camera_step(viewer_camera *c, cv_render_settings *s) {
    float a = VIEWER_ORBIT_DEGREES * 3.14159265f / 180.0f, co = cosf(a), si = sinf(a);
    float dx = c->eye[0] - c->target[0], dz = c->eye[2] - c->target[2];
    c->eye[0] = c->target[0] + co * dx - si * dz;
    c->eye[2] = c->target[2] + si * dx + co * dz;
    memcpy(s->camera_eye, c->eye, sizeof c->eye);
}

size_t viewer_output_bytes(const cv_render_output *out) {
    size_t px = (size_t)out->width * out->height, rgba = px * 4 * sizeof(float);
    const float *planes[] = { out->radiance,   out->albedo, out->normal, out->position,
                              out->visibility, out->direct, out->motion, out->reflection };
    size_t bytes = out->depth ? px * sizeof(float) : 0;
    for (size_t i = 0; i < sizeof planes / sizeof planes[0]; i++)
        bytes += planes[i] ? rgba : 0;
    return bytes;
}
