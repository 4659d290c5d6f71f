/* corvid-render: renders a scene with the hybrid renderer on one or more
 * Vulkan devices (real GPUs or virtual GPUs) and writes an EXR (HDR beauty and
 * AOV layers) and a tone-mapped PNG. */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "corvid/image_exr.h"
#include "corvid/image_files.h"
#include "corvid/image_png.h"
#include "corvid/renderer.h"
#include "corvid/scene_import.h"
#include "corvid/scene_procedural.h"
#include "corvid/tonemap.h"
#include "corvid/vulkan.h"

static void usage(FILE *f) {
    fprintf(f,
            "usage: corvid-render [options]\n"
            "Renders a scene (G-buffer raster, ray-traced soft shadows and AO split into column\n"
            "partitions across devices, filtering) and writes PREFIX.exr and PREFIX.png.\n\n"
            "  --scene S          room (default), stress:N (N triangles), or a model file (glTF, OBJ, ...)\n"
            "  --seed N           seed of procedural scenes (default 1)\n"
            "  --size WxH         image size (default 640x360)\n"
            "  --frames N         frames accumulated (default 4)\n"
            "  --ao-samples N     ambient occlusion rays per pixel per frame (default 4)\n"
            "  --ao-radius M      AO ray length in scene units (default 2%% of the scene diagonal)\n"
            "  --exposure EV      exposure of the PNG in stops (default 0)\n"
            "  --out PREFIX       output path without extension (default out/frame)\n"
            "  --gpus N           total devices (virtual GPUs are added to reach N)\n"
            "  --virtual-gpus N   device instances per adapter (or CORVID_VIRTUAL_GPUS=N)\n"
            "  --adapters LIST    comma-separated adapter names or indices (e.g. llvmpipe, H100, 0)\n"
            "  --validation       enable VK_LAYER_KHRONOS_validation\n"
            "  --list-adapters    print the Vulkan adapters and exit\n"
            "  --quiet            print only errors\n"
            "  --help             this text\n");
}

typedef struct options {
    const char *scene, *out;
    uint32_t seed;
    cv_render_settings settings;
    float exposure;
    bool validation, quiet, list_adapters;
} options;

static bool parse_u32(const char *s, uint32_t *out) {
    char *end;
    errno = 0;
    unsigned long v = strtoul(s, &end, 10);
    if (errno || end == s || *end || v > UINT32_MAX)
        return false;
    *out = (uint32_t)v;
    return true;
}

static bool parse_float(const char *s, float *out) {
    char *end;
    float v = strtof(s, &end);
    if (end == s || *end || !isfinite(v))
        return false;
    *out = v;
    return true;
}

/* 0 = ok, 1 = exit successfully (help), 2 = bad usage. */
static int parse_args(int argc, char **argv, options *o) {
    *o = (options){ .scene = "room", .out = "out/frame", .seed = 1 };
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        bool ok = true;
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            usage(stdout);
            return 1;
        } else if (!strcmp(a, "--validation")) {
            o->validation = true;
            continue;
        } else if (!strcmp(a, "--quiet")) {
            o->quiet = true;
            continue;
        } else if (!strcmp(a, "--list-adapters")) {
            o->list_adapters = true;
            continue;
        }
        static const char *const with_value[] = { "--scene", "--out", "--seed", "--size", "--frames",
                                                  "--ao-samples", "--ao-radius", "--exposure" };
        bool known = false;
        for (size_t k = 0; k < sizeof(with_value) / sizeof(with_value[0]); k++)
            known |= !strcmp(a, with_value[k]);
        if (!known) {
            fprintf(stderr, "corvid-render: unknown option '%s' (see --help)\n", a);
            return 2;
        }
        if (!v) {
            fprintf(stderr, "corvid-render: %s needs a value (see --help)\n", a);
            return 2;
        }
        if (!strcmp(a, "--scene")) {
            o->scene = v;
        } else if (!strcmp(a, "--out")) {
            o->out = v;
        } else if (!strcmp(a, "--seed")) {
            ok = parse_u32(v, &o->seed);
        } else if (!strcmp(a, "--size")) {
            unsigned w, h;
            char tail;
            ok = sscanf(v, "%ux%u%c", &w, &h, &tail) == 2 && w > 0 && h > 0 && w <= CV_MAX_TEXTURE_DIM &&
                 h <= CV_MAX_TEXTURE_DIM;
            o->settings.width = w;
            o->settings.height = h;
        } else if (!strcmp(a, "--frames")) {
            ok = parse_u32(v, &o->settings.frames) && o->settings.frames > 0;
        } else if (!strcmp(a, "--ao-samples")) {
            ok = parse_u32(v, &o->settings.ao_samples) && o->settings.ao_samples <= 32;
        } else if (!strcmp(a, "--ao-radius")) {
            ok = parse_float(v, &o->settings.ao_radius) && o->settings.ao_radius > 0;
        } else if (!strcmp(a, "--exposure")) {
            ok = parse_float(v, &o->exposure);
        }
        if (!ok) {
            fprintf(stderr, "corvid-render: bad value '%s' for %s (see --help)\n", v, a);
            return 2;
        }
        i++;
    }
    return 0;
}

static cv_result load_scene(const options *o, cv_scene **out) {
    if (!strcmp(o->scene, "room"))
        return cv_scene_make_room(o->seed, out);
    if (!strncmp(o->scene, "stress:", 7)) {
        char *end;
        unsigned long long n = strtoull(o->scene + 7, &end, 10);
        if (end == o->scene + 7 || *end || n == 0)
            return cv_error(CV_ERROR_INVALID_ARGUMENT, "--scene %s: expected stress:N with N > 0 triangles", o->scene);
        return cv_scene_make_stress(o->seed, n, out);
    }
    return cv_scene_import(o->scene, out);
}

static void progress(uint32_t frame, uint32_t frames, void *user) {
    if (!*(bool *)user)
        fprintf(stderr, "\rframe %u/%u", frame, frames);
    if (!*(bool *)user && frame == frames)
        fputc('\n', stderr);
}

/* Where the frame goes: PREFIX.exr and PREFIX.png, reserved as temporaries
 * in their directory before anything is rendered, so that a destination that
 * cannot take them fails at once rather than after the whole render. */
typedef struct outputs {
    char *exr, *png;             /* final names */
    const char *exr_temp, *png_temp;
    cv_file_set *set;
    char *made;                  /* the folders this run created, to remove on failure; NULL if none */
    size_t made_top;             /* length of the top-most folder created */
} outputs;

/* A copy of `a` followed by `b`, or NULL without memory. */
static char *concat(const char *a, const char *b) {
    size_t na = strlen(a), nb = strlen(b);
    char *s = malloc(na + nb + 1);
    if (s) {
        memcpy(s, a, na);
        memcpy(s + na, b, nb + 1);
    }
    return s;
}

/* Creates the missing folders of PREFIX (like mkdir -p), remembering the
 * ones it made. */
static cv_result make_parent(const char *prefix, outputs *out) {
    char *dir = strdup(prefix);
    if (!dir)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "--out: no memory");
    char *slash = strrchr(dir, '/');
    if (!slash || slash == dir) {
        free(dir);
        return CV_OK;
    }
    *slash = '\0';
    size_t len = strlen(dir);
    for (char *p = dir + 1; p <= dir + len; p++) {
        if (*p != '/' && *p != '\0')
            continue;
        char c = *p;
        *p = '\0';
        if (mkdir(dir, 0777) == 0) {
            if (!out->made)
                out->made_top = strlen(dir);
            out->made = dir;
        } else if (errno != EEXIST) {
            cv_result r = cv_error(CV_ERROR_IO, "cannot create folder '%s': %s", dir, strerror(errno));
            *p = c;
            if (out->made != dir)
                free(dir);
            return r;
        }
        *p = c;
    }
    if (out->made != dir)
        free(dir);
    return CV_OK;
}

/* Removes what outputs_reserve made: temporaries, then created folders. */
static void outputs_discard(outputs *out) {
    cv_file_set_destroy(out->set);
    out->set = NULL;
    for (char *dir = out->made; dir && strlen(dir) >= out->made_top;) {
        rmdir(dir);
        char *slash = strrchr(dir, '/');
        if (!slash)
            break;
        *slash = '\0';
    }
}

static void outputs_free(outputs *out) {
    cv_file_set_destroy(out->set);
    free(out->made);
    free(out->exr);
    free(out->png);
}

static cv_result outputs_reserve(const char *prefix, outputs *out) {
    out->exr = concat(prefix, ".exr");
    out->png = concat(prefix, ".png");
    if (!out->exr || !out->png)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "--out: no memory");
    cv_result r = make_parent(prefix, out);
    if (r == CV_OK)
        r = cv_file_set_create(&out->set);
    if (r == CV_OK)
        r = cv_file_set_add(out->set, out->exr, &out->exr_temp);
    if (r == CV_OK)
        r = cv_file_set_add(out->set, out->png, &out->png_temp);
    if (r != CV_OK)
        return cv_error(r, "--out: %s", cv_last_error());
    return CV_OK;
}

/* Channel c of an RGBA image as its own plane. */
static float *plane(const float *rgba, size_t pixels, int c) {
    float *p = malloc(pixels * sizeof(float));
    for (size_t i = 0; p && i < pixels; i++)
        p[i] = rgba[i * 4 + c];
    return p;
}

/* Writes both files to their temporaries and renames them into place only
 * when both were written. */
static cv_result write_images(const options *o, outputs *out, const cv_render_output *img,
                              const cv_camera *camera) {
    size_t n = (size_t)img->width * img->height;
    cv_result r = CV_OK;
    float *depth = malloc(n * sizeof(float));
    float *planes[8] = { plane(img->albedo, n, 0), plane(img->albedo, n, 1), plane(img->albedo, n, 2),
                         plane(img->normal, n, 0), plane(img->normal, n, 1), plane(img->normal, n, 2),
                         plane(img->visibility, n, 0), plane(img->visibility, n, 1) };
    for (int i = 0; i < 8; i++)
        if (!planes[i])
            r = cv_error(CV_ERROR_OUT_OF_MEMORY, "output planes");
    if (!depth)
        r = cv_error(CV_ERROR_OUT_OF_MEMORY, "depth plane");
    for (size_t i = 0; r == CV_OK && i < n; i++) {
        const float *p = &img->position[i * 4];
        float dx = p[0] - camera->position[0], dy = p[1] - camera->position[1], dz = p[2] - camera->position[2];
        depth[i] = p[3] != 0.0f ? sqrtf(dx * dx + dy * dy + dz * dz) : INFINITY;
    }
    if (r == CV_OK) {
        cv_exr_layer layers[] = {
            { .channel_count = 4, .channels = { "R", "G", "B", "A" }, .type = CV_EXR_FLOAT,
              .interleaved = img->radiance },
            { .name = "albedo", .channel_count = 3, .channels = { "R", "G", "B" }, .type = CV_EXR_HALF,
              .planes = { planes[0], planes[1], planes[2] } },
            { .name = "normal", .channel_count = 3, .channels = { "X", "Y", "Z" }, .type = CV_EXR_FLOAT,
              .planes = { planes[3], planes[4], planes[5] } },
            { .name = "depth", .channel_count = 1, .channels = { "Z" }, .type = CV_EXR_FLOAT, .planes = { depth } },
            { .name = "shadow", .channel_count = 1, .channels = { "Y" }, .type = CV_EXR_HALF, .planes = { planes[6] } },
            { .name = "ao", .channel_count = 1, .channels = { "Y" }, .type = CV_EXR_HALF, .planes = { planes[7] } },
        };
        r = cv_exr_write(out->exr_temp, &(cv_exr_desc){ .width = img->width, .height = img->height, .compression = CV_EXR_ZIP,
                                               .layer_count = 6, .layers = layers });
    }
    uint8_t *rgb = r == CV_OK ? malloc(n * 3) : NULL;
    if (r == CV_OK && !rgb)
        r = cv_error(CV_ERROR_OUT_OF_MEMORY, "PNG pixels");
    if (r == CV_OK)
        r = cv_tonemap_to_srgb8(&(cv_tonemap_desc){ .exposure = o->exposure, .curve = CV_TONEMAP_ACES },
                                img->radiance, 4, img->width, img->height, rgb, 3);
    if (r == CV_OK)
        r = cv_png_write(out->png_temp, img->width, img->height, 3, rgb);
    if (r == CV_OK)
        r = cv_file_set_commit(out->set);
    free(rgb);
    free(depth);
    for (int i = 0; i < 8; i++)
        free(planes[i]);
    return r;
}

static int list_adapters(void) {
    cv_vulkan_adapter_info info[16];
    uint32_t count = 0;
    cv_result r = cv_vulkan_adapters(info, 16, &count);
    if (r != CV_OK) {
        fprintf(stderr, "corvid-render: %s\n", cv_last_error());
        return 1;
    }
    for (uint32_t i = 0; i < count && i < 16; i++)
        printf("%u: %s (%s)%s%s%s\n", info[i].index, info[i].name, info[i].driver,
               info[i].ray_tracing_pipeline ? ", ray-tracing pipeline" : "", info[i].usable ? "" : ", unusable: ",
               info[i].usable ? "" : info[i].unusable_reason);
    return 0;
}

static double now_ms(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec * 1e3 + ts.tv_nsec / 1e6;
}

int main(int argc, char **argv) {
    cv_vulkan_gpu_config gpu_config = { 0 };
    if (cv_vulkan_gpu_args(&argc, argv, &gpu_config) != CV_OK) {
        fprintf(stderr, "corvid-render: %s (see --help)\n", cv_last_error());
        return 2;
    }
    options o;
    int parsed = parse_args(argc, argv, &o);
    if (parsed)
        return parsed == 1 ? 0 : 2;
    if (o.list_adapters)
        return list_adapters();

    double t0 = now_ms();
    cv_scene *scene = NULL;
    cv_bvh *bvh = NULL;
    cv_context *ctx = NULL;
    cv_renderer *renderer = NULL;
    cv_device *devices[CV_VULKAN_MAX_GPUS] = { 0 };
    cv_vulkan_gpu_table table = { 0 };
    cv_render_output image = { 0 };
    cv_render_stats stats = { 0 };
    outputs out = { 0 };
    cv_result r = outputs_reserve(o.out, &out);
    if (r == CV_OK)
        r = load_scene(&o, &scene);
    if (r == CV_OK && !o.quiet)
        fprintf(stderr, "scene '%s': %llu triangles, %u instances, %u materials\n", o.scene,
                (unsigned long long)cv_scene_world_triangle_count(scene), cv_scene_instance_count(scene),
                cv_scene_material_count(scene));
    double t_bvh = now_ms();
    if (r == CV_OK)
        r = cv_bvh_build_flat(scene, NULL, &bvh);
    t_bvh = now_ms() - t_bvh;
    if (r == CV_OK)
        r = cv_vulkan_gpu_table_build(&gpu_config, &table);
    if (r == CV_OK && table.count > CV_RENDER_MAX_DEVICES)
        r = cv_error(CV_ERROR_LIMIT_EXCEEDED, "%u devices requested; the renderer takes at most %u", table.count,
                     CV_RENDER_MAX_DEVICES);
    if (r == CV_OK)
        r = cv_context_create(NULL, &ctx);
    if (r == CV_OK)
        r = cv_vulkan_create_devices(ctx, &table, o.validation, devices);
    if (r == CV_OK && !o.quiet)
        for (uint32_t d = 0; d < table.count; d++) {
            const cv_device_info *info = cv_device_get_info(devices[d]);
            fprintf(stderr, "%s: %s (adapter %u, instance %u)%s, trace path %s\n", cv_device_label(devices[d]),
                    info->name, table.gpus[d].adapter, table.gpus[d].instance, d == 0 ? ", primary" : "",
                    info->trace_path[0] ? info->trace_path : "compute");
        }
    if (r == CV_OK)
        r = cv_renderer_create(devices, table.count, scene, bvh, &renderer);
    if (r == CV_OK)
        r = cv_renderer_render(renderer, &o.settings, &image, &stats, progress, &o.quiet);
    cv_render_settings s = { 0 };
    cv_camera camera = { 0 };
    if (r == CV_OK) {
        s = cv_render_settings_resolve(&o.settings, scene);
        camera = s.camera < cv_scene_camera_count(scene) ? *cv_scene_camera(scene, s.camera)
                                                         : cv_scene_framing_camera(scene);
    }
    if (r == CV_OK)
        r = write_images(&o, &out, &image, &camera);
    if (r == CV_OK && !o.quiet) {
        printf("wrote %s and %s (%ux%u, %u frames, %u AO rays/pixel/frame)\n", out.exr, out.png, image.width,
               image.height, stats.frames, s.ao_samples);
        printf("bvh build %.1f ms; upload to %u devices %.1f ms; %.1f ms per frame; %.2f Mrays/s overall\n", t_bvh,
               stats.device_count, stats.upload_ms, stats.frame_ms,
               stats.rays_total / (stats.frame_ms * stats.frames) / 1e3);
        for (uint32_t d = 0; d < stats.device_count; d++) {
            const cv_render_device_stats *ds = &stats.devices[d];
            printf("  %s: columns %u..%u, %llu rays, trace %.1f ms (%.2f Mrays/s)\n", cv_device_label(devices[d]),
                   ds->columns.x, ds->columns.x + ds->columns.width, (unsigned long long)ds->rays, ds->trace_ms,
                   ds->trace_ms > 0 ? ds->rays / ds->trace_ms / 1e3 : 0.0);
        }
        printf("transfers between devices: %.1f MB in %.1f ms; total %.1f s\n", stats.transfer_bytes / 1e6,
               stats.transfer_ms, (now_ms() - t0) / 1e3);
    }
    if (r == CV_OK && o.validation && cv_vulkan_validation_message_count())
        r = cv_error(CV_ERROR_BACKEND, "the validation layer reported %u messages",
                     cv_vulkan_validation_message_count());
    if (r != CV_OK)
        outputs_discard(&out);
    outputs_free(&out);
    cv_render_output_free(&image);
    cv_renderer_destroy(renderer);
    cv_context_destroy(ctx);
    cv_bvh_destroy(bvh);
    cv_scene_destroy(scene);
    if (r != CV_OK) {
        fprintf(stderr, "corvid-render: %s: %s\n", cv_result_name(r), cv_last_error());
        return 1;
    }
    return 0;
}
