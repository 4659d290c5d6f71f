/* corvid-render: renders a scene with the hybrid renderer on one or more
 * Vulkan devices (real GPUs or virtual GPUs) and writes an EXR (HDR beauty and
 * AOV layers) and a tone-mapped PNG. */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "corvid/clock.h"
#include "corvid/endpoint.h"
#include "corvid/image_exr.h"
#include "corvid/image_files.h"
#include "corvid/image_png.h"
#include "corvid/parse.h"
#include "corvid/proxy.h"
#include "corvid/render_log.h"
#include "corvid/renderer.h"
#include "corvid/scene_import.h"
#include "corvid/scene_procedural.h"
#include "corvid/tonemap.h"
#include "corvid/vulkan.h"
#include "env_log.h"
#include "env_vulkan.h"
#include "render_exr.h"
#include "render_outputs.h"

/* The renderer's limits (cv_renderer_render refuses more). */
#define MAX_FRAMES 4096
#define MAX_AO_SAMPLES 32

static void usage(FILE *f) {
    fprintf(f,
            "usage: corvid-render [options]   (--option VALUE or --option=VALUE)\n"
            "Renders a scene (G-buffer raster, ray-traced soft shadows and AO split into column\n"
            "partitions across devices, filtering) and writes PREFIX.exr and PREFIX.png.\n\n"
            "  --scene S          room (default), stress:N (N triangles), or a model file (glTF, OBJ, ...)\n"
            "  --seed N           seed of procedural scenes, 0..4294967295 (default 1)\n"
            "  --size WxH         image size, each side 1..%u (default 640x360)\n"
            "  --frames N         frames accumulated, 1..%u (default 4)\n"
            "  --filter N         variance-guided a-trous filter iterations, 0..8 (default 2; 0 = unfiltered:\n"
            "                     also no reflection denoise)\n"
            "  --ao-samples N     ambient occlusion rays per pixel per frame, 1..%u (default 4;\n"
            "                     AO cannot be turned off, so 0 is refused)\n"
            "  --shadow-samples N rays toward the sun per pixel per frame: 1, 2, 4, 8, 16 or 32 (default 1;\n"
            "                     more rays, less noise in soft shadows)\n"
            "  --ao-radius M      AO ray length in scene units, > 0 (default 2%% of the scene diagonal)\n"
            "  --camera EX,EY,EZ,TX,TY,TZ,FOV\n"
            "                     the camera at eye EX,EY,EZ looking at TX,TY,TZ, vertical field of view\n"
            "                     FOV degrees in (0,170], up +y (default: the scene's camera)\n"
            "  --sun DX,DY,DZ,A   direction toward the sun (not 0,0,0) and its cone's half angle A\n"
            "                     degrees in [0,90), 0 = hard shadows (default: the scene's sun, 1.5)\n"
            "  --orbit D          the camera turns D degrees per frame about the vertical axis through\n"
            "                     its target (a moving camera: reprojected history, motion vectors)\n"
            "  --reflections on|off  GGX reflections (default on; off: no specular term)\n"
            "  --reflect-radius N spatial reuse radius of the reflection filter, pixels, 0..8 (default 1;\n"
            "                     0 = every pixel keeps its own samples)\n"
            "  --reflection-scale S  1 (default) or 0.5: half resolution, one reflection ray per 2x2\n"
            "                     pixels per frame\n"
            "  --reflection-samples N  reflection rays per traced pixel per frame: 1, 2, 4 or 8\n"
            "                     (default 1; each with a shadow ray at its hit; less noise in glossy\n"
            "                     reflections, at N times the reflection pass's cost)\n"
            "  --exposure EV      exposure of the PNG in stops (default 0)\n"
            "  --reference N      render the CPU reference instead (ground truth for the renderer's\n"
            "                     image model): N samples per pixel, 1..65536, unfiltered, float32\n"
            "                     accumulation, on 2 threads; writes the same layers; no devices (so not with\n"
            "                     --gpus, --nodes, --dump-graph, --stats, --trace and the like)\n"
            "  --out PREFIX       output path without extension, ending in a file name (default out/frame)\n"
            "  --gpus N           total devices (virtual GPUs are added to reach N); overrides\n"
            "                     --virtual-gpus and CORVID_VIRTUAL_GPUS\n"
            "  --virtual-gpus N   device instances per adapter (or CORVID_VIRTUAL_GPUS=N)\n"
            "  --adapters LIST    comma-separated adapter names or indices (e.g. llvmpipe, H100, 0)\n"
            "  --nodes LIST       render on the devices of remote corvid-nodes instead, HOST:PORT,...\n"
            "                     (or CORVID_NODES=LIST); the first node's first device is the primary\n"
            "  --dump-graph FILE  write the frame's render graph (passes, devices, cross-device copies)\n"
            "                     as text to FILE and as Graphviz dot to FILE.dot (not with --reference)\n"
            "  (--out, --stats, --trace and --dump-graph name distinct regular files, checked before\n"
            "  rendering and written together at the end; SIGINT/SIGTERM leave none of them half-made)\n"
            "  --stats FILE       write per-frame stats as JSON: wall time, per device its columns, rays,\n"
            "                     pass times and transfers; then a summary (not with --reference)\n"
            "  --trace FILE       write a Chrome/Perfetto trace (open in ui.perfetto.dev): a track per\n"
            "                     device with each pass and transfer of every frame (not with --reference)\n"
            "  --validation       enable VK_LAYER_KHRONOS_validation\n"
            "  --list-adapters    print the Vulkan adapters and exit\n"
            "  --quiet            print only errors\n"
            "  --help             this text\n"
            "Multi-GPU environment (docs/transfers.md):\n"
            "  CORVID_ZERO_COPY=auto|on|off         columns gathered without copies where devices share\n"
            "                                       memory (virtual GPUs of one adapter; default auto)\n"
            "  CORVID_TRANSFER_PATH=auto|device|shared|host-import|staged  force a copy path\n"
            "  CORVID_VGPU_DEVICE=auto|shared|separate  virtual GPUs on one VkDevice or one each\n"
            "  CORVID_LINK_QUEUE=compute|graphics|copy  the queue of GPU-side copies (default compute)\n"
            "  CORVID_CROSS_WAIT=auto|import|bridge     how a GPU waits for another device\n"
            "  CORVID_TRANSFER_ASYNC=0|1            0: every transfer synchronous (for comparisons); 1 default\n",
            CV_MAX_TEXTURE_DIM, MAX_FRAMES, MAX_AO_SAMPLES);
}

typedef struct options {
    const char *scene, *out;
    const char *dump_graph;    /* --dump-graph FILE: text to FILE, dot to FILE.dot */
    const char *stats, *trace; /* --stats FILE, --trace FILE: JSON of every frame (cv_render_log) */
    const char *nodes;         /* --nodes, or CORVID_NODES; NULL = local devices */
    uint64_t stress_triangles; /* > 0 for --scene stress:N */
    uint32_t seed;
    uint32_t reference; /* --reference N: samples per pixel of the CPU reference; 0 = GPU render */
    cv_render_settings settings;
    float exposure;
    bool validation, quiet, list_adapters, help;
} options;

/* A finite float. strtof's ERANGE also means underflow (1e-45, a denormal,
 * or 1e-50, rounded to 0): a finite number, accepted; only overflow (inf) is
 * refused. */
static bool parse_float(const char *s, float *out) {
    char *end;
    errno = 0;
    float v = strtof(s, &end);
    if ((errno && errno != ERANGE) || end == s || *end || !isfinite(v))
        return false;
    *out = v;
    return true;
}

/* Option handlers: each parses its value into *o, or says why it refuses it
 * (naming the option, the value and the accepted range) and returns false. */
typedef bool (*option_fn)(options *o, const char *name, const char *value);

static bool refuse(const char *name, const char *value, const char *expected) {
    fprintf(stderr, "corvid-render: %s: '%s' is not %s (see --help)\n", name, value, expected);
    return false;
}

static bool set_u32(const char *name, const char *value, uint32_t min, uint32_t max, uint32_t *out) {
    uint64_t v;
    if (!cv_parse_uint(value, min, max, &v)) {
        char expected[64];
        snprintf(expected, sizeof expected, "a whole number in %u..%u", min, max);
        return refuse(name, value, expected);
    }
    *out = (uint32_t)v;
    return true;
}

static bool opt_scene(options *o, const char *name, const char *value) {
    if (!value[0])
        return refuse(name, value, "a scene (room, stress:N or a file)");
    if (!strncmp(value, "stress:", 7) && !cv_parse_uint(value + 7, 1, UINT64_MAX, &o->stress_triangles))
        return refuse(name, value, "stress:N with N a whole number of triangles, at least 1");
    o->scene = value;
    return true;
}

static bool opt_seed(options *o, const char *name, const char *value) {
    return set_u32(name, value, 0, UINT32_MAX, &o->seed);
}

static bool opt_size(options *o, const char *name, const char *value) {
    char expected[64];
    snprintf(expected, sizeof expected, "WxH with each side in 1..%u", CV_MAX_TEXTURE_DIM);
    const char *x = strchr(value, 'x');
    uint64_t w, h;
    char width[24];
    if (!x || (size_t)(x - value) >= sizeof width)
        return refuse(name, value, expected);
    snprintf(width, sizeof width, "%.*s", (int)(x - value), value);
    if (!cv_parse_uint(width, 1, CV_MAX_TEXTURE_DIM, &w) || !cv_parse_uint(x + 1, 1, CV_MAX_TEXTURE_DIM, &h))
        return refuse(name, value, expected);
    o->settings.width = (uint32_t)w;
    o->settings.height = (uint32_t)h;
    return true;
}

static bool opt_frames(options *o, const char *name, const char *value) {
    return set_u32(name, value, 1, MAX_FRAMES, &o->settings.frames);
}

/* --filter N: a-trous iterations, 0 = unfiltered (the settings' -1). */
static bool opt_filter(options *o, const char *name, const char *value) {
    uint32_t n;
    if (!set_u32(name, value, 0, 8, &n))
        return false;
    o->settings.filter_iterations = n ? (int32_t)n : -1;
    return true;
}

static bool opt_reflections(options *o, const char *name, const char *value) {
    if (strcmp(value, "on") == 0 || strcmp(value, "off") == 0) {
        o->settings.reflections = strcmp(value, "on") == 0 ? 1 : -1;
        return true;
    }
    return refuse(name, value, "on or off");
}

static bool opt_reflect_radius(options *o, const char *name, const char *value) {
    uint32_t n;
    if (!set_u32(name, value, 0, 8, &n))
        return false;
    o->settings.reflection_radius = n ? (int32_t)n : -1;
    return true;
}

static bool opt_reflection_scale(options *o, const char *name, const char *value) {
    if (strcmp(value, "1") != 0 && strcmp(value, "0.5") != 0)
        return refuse(name, value, "1 or 0.5");
    o->settings.reflection_scale = strcmp(value, "1") == 0 ? 1.0f : 0.5f;
    return true;
}

/* A power of two in 1..max, refused with the list of them ("one of 1, 2, 4, 8"). */
static bool set_power_of_two(const char *name, const char *value, uint32_t max, uint32_t *out) {
    uint64_t n;
    if (!cv_parse_uint(value, 1, max, &n) || (n & (n - 1)) != 0) {
        char list[64] = "one of 1";
        for (uint32_t p = 2; p <= max && strlen(list) + 8 < sizeof list; p *= 2)
            snprintf(list + strlen(list), sizeof list - strlen(list), ", %u", p);
        return refuse(name, value, list);
    }
    *out = (uint32_t)n;
    return true;
}

static bool opt_reflection_samples(options *o, const char *name, const char *value) {
    return set_power_of_two(name, value, 8, &o->settings.reflection_samples);
}

static bool opt_ao_samples(options *o, const char *name, const char *value) {
    return set_u32(name, value, 1, MAX_AO_SAMPLES, &o->settings.ao_samples);
}

static bool opt_shadow_samples(options *o, const char *name, const char *value) {
    return set_power_of_two(name, value, 32, &o->settings.shadow_samples);
}

static bool opt_ao_radius(options *o, const char *name, const char *value) {
    if (!parse_float(value, &o->settings.ao_radius) || !(o->settings.ao_radius > 0.0f))
        return refuse(name, value, "a finite length > 0");
    return true;
}

/* Exactly `count` comma-separated finite numbers. */
static bool parse_floats(const char *value, float *out, int count) {
    const char *s = value;
    for (int i = 0; i < count; i++) {
        char item[64];
        size_t len = strcspn(s, ",");
        if (len == 0 || len >= sizeof item || (i + 1 < count) != (s[len] == ','))
            return false;
        memcpy(item, s, len);
        item[len] = '\0';
        if (!parse_float(item, &out[i]))
            return false;
        s += len + (s[len] == ',');
    }
    return true;
}

/* The renderer's own check of the view and light controls, named by option. */
static bool check_view(const options *o, const char *name, const char *value) {
    if (cv_render_settings_check(&o->settings) == CV_OK)
        return true;
    fprintf(stderr, "corvid-render: %s: '%s': %s (see --help)\n", name, value, cv_last_error());
    return false;
}

static bool opt_camera(options *o, const char *name, const char *value) {
    float v[7];
    if (!parse_floats(value, v, 7))
        return refuse(name, value, "7 finite numbers EX,EY,EZ,TX,TY,TZ,FOV");
    if (!(v[6] > 0.0f && v[6] <= CV_RENDER_MAX_FOV_DEGREES))
        return refuse(name, value, "EX,EY,EZ,TX,TY,TZ,FOV with FOV in (0,170] degrees (CV_RENDER_MAX_FOV_DEGREES)");
    memcpy(o->settings.camera_eye, v, sizeof(o->settings.camera_eye));
    memcpy(o->settings.camera_target, v + 3, sizeof(o->settings.camera_target));
    o->settings.camera_fov_degrees = v[6];
    return check_view(o, name, value);
}

/* --sun DX,DY,DZ,A: A = 0 is hard shadows (the settings' negative cone). */
static bool opt_sun(options *o, const char *name, const char *value) {
    float v[4];
    if (!parse_floats(value, v, 4))
        return refuse(name, value, "4 finite numbers DX,DY,DZ,A");
    if (v[0] == 0.0f && v[1] == 0.0f && v[2] == 0.0f)
        return refuse(name, value, "DX,DY,DZ,A with a direction other than 0,0,0");
    if (!(v[3] >= 0.0f && v[3] < 90.0f))
        return refuse(name, value, "DX,DY,DZ,A with A in [0,90) degrees");
    memcpy(o->settings.sun_toward, v, sizeof(o->settings.sun_toward));
    o->settings.sun_cone_degrees = v[3] > 0.0f ? v[3] : -1.0f;
    return check_view(o, name, value);
}

static bool opt_orbit(options *o, const char *name, const char *value) {
    if (!parse_float(value, &o->settings.orbit_degrees) || fabsf(o->settings.orbit_degrees) > 360.0f)
        return refuse(name, value, "a finite number of degrees per frame in -360..360");
    return true;
}

static bool opt_reference(options *o, const char *name, const char *value) {
    return set_u32(name, value, 1, 65536, &o->reference);
}

static bool opt_exposure(options *o, const char *name, const char *value) {
    if (!parse_float(value, &o->exposure))
        return refuse(name, value, "a finite number of stops");
    return true;
}

/* The prefix must end in a file name: "" or "dir/" would write the hidden
 * files ".exr" and ".png". */
static bool opt_out(options *o, const char *name, const char *value) {
    const char *slash = strrchr(value, '/');
    const char *file = slash ? slash + 1 : value;
    if (!file[0] || !strcmp(file, ".") || !strcmp(file, ".."))
        return refuse(name, value, "a path ending in a file name (such as out/frame)");
    o->out = value;
    return true;
}

static bool opt_nodes(options *o, const char *name, const char *value) {
    cv_endpoint nodes[CV_MAX_NODES];
    uint32_t count;
    if (cv_endpoints_parse(value, name, nodes, CV_MAX_NODES, &count) != CV_OK) {
        fprintf(stderr, "corvid-render: %s (see --help)\n", cv_last_error());
        return false;
    }
    o->nodes = value;
    return true;
}

static bool opt_dump_graph(options *o, const char *name, const char *value) {
    if (!value[0])
        return refuse(name, value, "a file name");
    o->dump_graph = value;
    return true;
}

static bool opt_stats(options *o, const char *name, const char *value) {
    if (!value[0])
        return refuse(name, value, "a file name");
    o->stats = value;
    return true;
}

static bool opt_trace(options *o, const char *name, const char *value) {
    if (!value[0])
        return refuse(name, value, "a file name");
    o->trace = value;
    return true;
}

static bool opt_validation(options *o, const char *name, const char *value) {
    (void)name, (void)value;
    return o->validation = true;
}

static bool opt_quiet(options *o, const char *name, const char *value) {
    (void)name, (void)value;
    return o->quiet = true;
}

static bool opt_list_adapters(options *o, const char *name, const char *value) {
    (void)name, (void)value;
    return o->list_adapters = true;
}

static bool opt_help(options *o, const char *name, const char *value) {
    (void)name, (void)value;
    return o->help = true;
}

/* Every option of corvid-render but those cv_env_vulkan_gpu_args takes (--gpus,
 * --virtual-gpus, --adapters), which it removes from argv first. */
static const struct option_def {
    const char *name;
    bool takes_value;
    option_fn set;
} option_table[] = {
    { "--scene", true, opt_scene },
    { "--seed", true, opt_seed },
    { "--size", true, opt_size },
    { "--frames", true, opt_frames },
    { "--filter", true, opt_filter },
    { "--ao-samples", true, opt_ao_samples },
    { "--shadow-samples", true, opt_shadow_samples },
    { "--ao-radius", true, opt_ao_radius },
    { "--camera", true, opt_camera },
    { "--sun", true, opt_sun },
    { "--orbit", true, opt_orbit },
    { "--reflections", true, opt_reflections },
    { "--reflect-radius", true, opt_reflect_radius },
    { "--reflection-scale", true, opt_reflection_scale },
    { "--reflection-samples", true, opt_reflection_samples },
    { "--exposure", true, opt_exposure },
    { "--reference", true, opt_reference },
    { "--out", true, opt_out },
    { "--nodes", true, opt_nodes },
    { "--dump-graph", true, opt_dump_graph },
    { "--stats", true, opt_stats },
    { "--trace", true, opt_trace },
    { "--validation", false, opt_validation },
    { "--quiet", false, opt_quiet },
    { "--list-adapters", false, opt_list_adapters },
    { "--help", false, opt_help },
    { "-h", false, opt_help },
};

/* Takes "--name value" and "--name=value" alike. 0 = ok, 2 = bad usage. */
static int parse_args(int argc, char **argv, options *o) {
    *o = (options){ .scene = "room", .out = "out/frame", .seed = 1 };
    for (int i = 1; i < argc; i++) {
        const char *arg = argv[i], *eq = strchr(arg, '=');
        size_t len = eq ? (size_t)(eq - arg) : strlen(arg);
        const struct option_def *def = NULL;
        for (size_t k = 0; k < sizeof option_table / sizeof option_table[0]; k++)
            if (strlen(option_table[k].name) == len && !strncmp(arg, option_table[k].name, len))
                def = &option_table[k];
        if (!def) {
            fprintf(stderr, "corvid-render: unknown option '%.*s' (see --help)\n", (int)len, arg);
            return 2;
        }
        const char *value = eq ? eq + 1 : NULL;
        if (def->takes_value && !value) {
            if (i + 1 == argc) {
                fprintf(stderr, "corvid-render: %s needs a value (see --help)\n", def->name);
                return 2;
            }
            value = argv[++i];
        } else if (!def->takes_value && value) {
            fprintf(stderr, "corvid-render: %s takes no value (see --help)\n", def->name);
            return 2;
        }
        if (!def->set(o, def->name, value))
            return 2;
    }
    return 0;
}

/* --dump-graph: the renderer's frame graph as text and as dot, to the
 * temporaries of FILE and FILE.dot (renamed into place with the images). */
static cv_result dump_graph(cv_renderer *renderer, const outputs *out) {
    FILE *text = fopen(out->graph_temp, "w"), *dot = fopen(out->dot_temp, "w");
    cv_result r = text && dot
                      ? cv_renderer_dump_graph(renderer, text, dot)
                      : cv_error(CV_ERROR_IO, "%s: %s", text ? out->dot_temp : out->graph_temp, strerror(errno));
    if (text && fclose(text) != 0 && r == CV_OK)
        r = cv_error(CV_ERROR_IO, "%s: %s", out->graph_temp, strerror(errno));
    if (dot && fclose(dot) != 0 && r == CV_OK)
        r = cv_error(CV_ERROR_IO, "%s: %s", out->dot_temp, strerror(errno));
    return r == CV_OK ? r : cv_file_set_name_error(out->set, cv_error(r, "--dump-graph: %s", cv_last_error()));
}

static cv_result load_scene(const options *o, cv_scene **out) {
    if (!strcmp(o->scene, "room"))
        return cv_scene_make_room(o->seed, out);
    if (o->stress_triangles)
        return cv_scene_make_stress(o->seed, o->stress_triangles, out);
    return cv_scene_import(o->scene, out);
}

/* --nodes: a node device that was lost is tried again between frames (at most REJOIN_TRIES times per device,
 * one try per REJOIN_EVERY_MS): once its node answers, a new device for it joins the renderer from the next
 * frame (cv_renderer_add_device), with a log line either way. */
#define REJOIN_TRIES 5u
#define REJOIN_EVERY_MS 2000.0
typedef struct render_progress {
    bool quiet;
    cv_renderer *renderer;
    cv_context *ctx;
    cv_device **devices; /* a lost one is replaced by its rejoined device */
    uint32_t count;
    const char *nodes; /* the --nodes list; devices are labelled node<i>.gpu<j> (create_node_devices) */
    uint32_t tries[CV_MAX_DEVICES];
    double last_try[CV_MAX_DEVICES];
} render_progress;

static void rejoin_lost(render_progress *rp, uint32_t frame) {
    for (uint32_t d = 1; rp->renderer && d < rp->count; d++) {
        cv_device *lost = rp->devices[d];
        if (!cv_device_is_lost(lost) || rp->tries[d] >= REJOIN_TRIES ||
            cv_now_ms() - rp->last_try[d] < REJOIN_EVERY_MS)
            continue;
        rp->tries[d]++;
        rp->last_try[d] = cv_now_ms();
        cv_endpoint nodes[CV_MAX_NODES];
        uint32_t node_count = 0, node = 0, gpu = 0;
        char adapter[16];
        if (sscanf(cv_device_label(lost), "node%u.gpu%u", &node, &gpu) != 2 ||
            cv_endpoints_parse(rp->nodes, "--nodes", nodes, CV_MAX_NODES, &node_count) != CV_OK || node >= node_count)
            continue;
        snprintf(adapter, sizeof(adapter), "%u", gpu);
        cv_device_desc desc = { .endpoint = nodes[node].text, .adapter = adapter };
        snprintf(desc.label, sizeof(desc.label), "%s", cv_device_label(lost));
        cv_proxy_node_info *info = malloc(sizeof(*info));
        cv_device *dev = NULL;
        cv_result r = info ? cv_proxy_query_node(desc.endpoint, 1000, info)
                           : cv_error(CV_ERROR_OUT_OF_MEMORY, "node info");
        free(info);
        if (r == CV_OK)
            r = cv_device_create(rp->ctx, cv_proxy_backend(), &desc, &dev);
        if (r == CV_OK)
            r = cv_renderer_add_device(rp->renderer, dev);
        if (r == CV_OK) {
            rp->devices[d] = dev;
            fprintf(stderr, "%scorvid-render: %s on node '%s' is back: it renders from frame %u on\n",
                    rp->quiet ? "" : "\n", desc.label, desc.endpoint, frame + 1);
        } else {
            fprintf(stderr, "%scorvid-render: %s on node '%s' lost; try %u of %u to rejoin it: %s\n",
                    rp->quiet ? "" : "\n", desc.label, desc.endpoint, rp->tries[d], REJOIN_TRIES, cv_last_error());
            if (dev)
                cv_device_destroy(dev);
        }
    }
}

static void progress(uint32_t frame, uint32_t frames, void *user) {
    render_progress *rp = user;
    if (!rp->quiet)
        fprintf(stderr, "\rframe %u/%u", frame, frames);
    if (!rp->quiet && frame == frames)
        fputc('\n', stderr);
    if (frame < frames)
        rejoin_lost(rp, frame);
}

/* The recorded frames to the --stats and --trace temporaries. */
static cv_result write_logs(const outputs *out, const cv_render_log *log, const cv_render_stats *stats) {
    cv_result r = CV_OK;
    if (out->stats_temp)
        r = cv_render_log_write_stats(log, stats, out->stats_temp);
    if (r == CV_OK && out->trace_temp)
        r = cv_render_log_write_trace(log, out->trace_temp);
    return r;
}

/* Writes the EXR and PNG to their temporaries (main commits the set). */
static cv_result write_images(const options *o, outputs *out, const cv_render_output *img) {
    size_t n = (size_t)img->width * img->height;
    cv_result r = render_exr_write(out->exr_temp, img);
    uint8_t *rgb = r == CV_OK ? malloc(n * 3) : NULL;
    if (r == CV_OK && !rgb)
        r = cv_error(CV_ERROR_OUT_OF_MEMORY, "PNG pixels");
    if (r == CV_OK)
        r = cv_tonemap_to_srgb8(&(cv_tonemap_desc){ .exposure = o->exposure, .curve = CV_TONEMAP_ACES },
                                img->radiance, 4, img->width, img->height, rgb, 3);
    if (r == CV_OK)
        r = cv_png_write(out->png_temp, img->width, img->height, 3, rgb);
    free(rgb);
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
               info[i].ray_tracing_pipeline ? ", ray-tracing pipeline" : "",
               info[i].usable ? "" : ", unusable: ", info[i].usable ? "" : info[i].unusable_reason);
    return 0;
}

/* The devices of one node that answered, labelled node<i>.gpu<j>, appended at devices[*n]. */
static cv_result add_node_devices(cv_context *ctx, const cv_endpoint *node, uint32_t i,
                                  const cv_proxy_node_info *info, cv_device **devices, uint32_t *n, bool quiet) {
    cv_result r = CV_OK;
    for (uint32_t d = 0; r == CV_OK && d < info->device_count; d++) {
        if (*n == CV_MAX_DEVICES)
            return cv_error(CV_ERROR_LIMIT_EXCEEDED, "the nodes serve more than %u devices, the renderer's limit",
                            CV_MAX_DEVICES);
        char adapter[16];
        snprintf(adapter, sizeof(adapter), "%u", d);
        cv_device_desc desc = { .endpoint = node->text, .adapter = adapter };
        snprintf(desc.label, sizeof(desc.label), "node%u.gpu%u", i, d);
        r = cv_device_create(ctx, cv_proxy_backend(), &desc, &devices[*n]);
        if (r == CV_OK && !quiet)
            fprintf(stderr, "%s: %s on node '%s' (%s, its %s)%s\n", desc.label, cv_device_get_info(devices[*n])->name,
                    info->name, node->text, info->labels[d], *n == 0 ? ", primary" : "");
        if (r == CV_OK)
            (*n)++;
    }
    return r;
}

/* One proxy device per device of every node that answers. A node that cannot be reached at start is named
 * and left out (a render on the others beats none); one that answers with an error (a wrong token, a
 * protocol it does not speak) fails the render, as does no node answering at all. */
static cv_result create_node_devices(cv_context *ctx, const char *list, cv_device **devices, uint32_t *count,
                                     bool quiet) {
    cv_endpoint nodes[CV_MAX_NODES];
    uint32_t node_count, n = 0, answered = 0;
    cv_result r = cv_endpoints_parse(list, "--nodes", nodes, CV_MAX_NODES, &node_count);
    cv_proxy_node_info *info = malloc(sizeof(*info));
    if (r == CV_OK && !info)
        r = cv_error(CV_ERROR_OUT_OF_MEMORY, "node info");
    char down[1024] = "";
    for (uint32_t i = 0; r == CV_OK && i < node_count; i++) {
        r = cv_proxy_query_node(nodes[i].text, 10000, info);
        if (r == CV_ERROR_CONNECTION || r == CV_ERROR_TIMEOUT) {
            fprintf(stderr, "corvid-render: node '%s' did not answer, rendering without it: %s\n", nodes[i].text,
                    cv_last_error());
            size_t at = strlen(down);
            snprintf(down + at, sizeof(down) - at, "%s'%s'", at ? ", " : "", nodes[i].text);
            r = CV_OK;
            continue;
        }
        answered++;
        if (r == CV_OK)
            r = add_node_devices(ctx, &nodes[i], i, info, devices, &n, quiet);
    }
    free(info);
    if (r == CV_OK && answered == 0)
        r = cv_error(CV_ERROR_CONNECTION, "no node of --nodes answered (%s)", down);
    *count = n;
    return r;
}

int main(int argc, char **argv) {
    env_log_apply();
    cv_vulkan_gpu_config gpu_config = { 0 };
    if (cv_env_vulkan_gpu_args(&argc, argv, &gpu_config) != CV_OK) {
        fprintf(stderr, "corvid-render: %s (see --help)\n", cv_last_error());
        return 2;
    }
    options o;
    if (parse_args(argc, argv, &o))
        return 2;
    if (o.help) {
        usage(stdout);
        return 0;
    }
    /* What no single option decides (--size with --reflection-samples). */
    if (cv_render_settings_check(&o.settings) != CV_OK) {
        fprintf(stderr, "corvid-render: %s (see --help)\n", cv_last_error());
        return 2;
    }
    if (gpu_config.adapters && !gpu_config.adapters[0]) {
        fprintf(stderr, "corvid-render: --adapters: the list is empty (see --help)\n");
        return 2;
    }
    /* An explicit device count wins: the per-adapter count is then unused, so
     * CORVID_VIRTUAL_GPUS must not be read (and refused) for it. */
    if (gpu_config.total && !gpu_config.virtual_per_adapter)
        gpu_config.virtual_per_adapter = 1;
    if (o.list_adapters)
        return list_adapters();
    bool local_choice = gpu_config.adapters || gpu_config.total || gpu_config.virtual_per_adapter;
    if (!o.nodes && !local_choice && !o.reference && getenv("CORVID_NODES") && getenv("CORVID_NODES")[0]) {
        if (!opt_nodes(&o, "CORVID_NODES", getenv("CORVID_NODES")))
            return 2;
    }
    /* --reference renders on the CPU, without devices or a render graph: an
     * option about those would be ignored, so it is refused instead. */
    if ((o.stats || o.trace || o.dump_graph) && o.reference) {
        fprintf(stderr,
                "corvid-render: --stats, --trace and --dump-graph record the GPU renderer's frames and graph; "
                "--reference renders on the CPU: give one or the other\n");
        return 2;
    }
    if ((o.nodes || local_choice || o.validation) && o.reference) {
        fprintf(stderr,
                "corvid-render: --reference renders on the CPU, on no device: --gpus, --virtual-gpus, --adapters, "
                "--nodes and --validation choose devices; give one or the other\n");
        return 2;
    }
    if (o.nodes && local_choice) {
        fprintf(stderr,
                "corvid-render: --nodes renders on the devices the nodes serve; --gpus, --virtual-gpus and "
                "--adapters choose local ones: give one or the other\n");
        return 2;
    }

    double t0 = cv_now_ms();
    cv_scene *scene = NULL;
    cv_bvh *bvh = NULL;
    cv_context *ctx = NULL;
    cv_renderer *renderer = NULL;
    cv_device *devices[CV_MAX_DEVICES] = { 0 };
    cv_vulkan_gpu_table table = { 0 };
    cv_render_output image = { 0 };
    cv_render_stats stats = { 0 };
    outputs out = { 0 };
    cv_render_log *log = NULL;
    cv_render_observer observer = { 0 };
    cv_result r = outputs_reserve(&out, o.out, o.stats, o.trace, o.dump_graph);
    if (r == CV_OK)
        outputs_catch_signals(&out);
    if (r == CV_OK && (o.stats || o.trace))
        r = cv_render_log_create(&log);
    if (r == CV_OK && log) {
        observer = cv_render_log_observer(log);
        o.settings.observer = &observer;
    }
    if (r == CV_OK)
        r = load_scene(&o, &scene);
    if (r == CV_OK && !o.quiet)
        fprintf(stderr, "scene '%s': %llu triangles, %u instances, %u materials\n", o.scene,
                (unsigned long long)cv_scene_world_triangle_count(scene), cv_scene_instance_count(scene),
                cv_scene_material_count(scene));
    /* A scene without a camera of its own is shown by the framing camera,
     * which cannot show every scene: say so rather than render an empty sky. */
    if (r == CV_OK && cv_scene_camera_count(scene) == 0) {
        r = cv_scene_check_framing(scene);
        if (r != CV_OK)
            r = cv_error(r, "--scene %s: %s", o.scene, cv_last_error());
    }
    double t_bvh = cv_now_ms();
    if (r == CV_OK)
        r = cv_bvh_build_flat(scene, NULL, &bvh);
    t_bvh = cv_now_ms() - t_bvh;
    if (r == CV_OK && o.reference) {
        r = cv_render_reference(scene, bvh, &o.settings, o.reference, 2, &image);
        if (r == CV_OK && !o.quiet)
            fprintf(stderr, "reference: %u samples per pixel in %.1f s\n", o.reference, (cv_now_ms() - t0) / 1e3);
    }
    if (r == CV_OK && !o.nodes && !o.reference)
        r = cv_env_vulkan_gpu_config(&gpu_config); /* the environment only where the table is used */
    if (r == CV_OK && !o.nodes && !o.reference)
        r = cv_vulkan_gpu_table_build(&gpu_config, &table);
    if (r == CV_OK && table.count > CV_MAX_DEVICES)
        r = cv_error(CV_ERROR_LIMIT_EXCEEDED, "%u devices requested; the renderer takes at most %u", table.count,
                     CV_MAX_DEVICES);
    if (r == CV_OK && !o.reference)
        r = cv_context_create(NULL, &ctx);
    uint32_t device_count = 0;
    if (r == CV_OK && o.reference) {
        /* no devices */
    } else if (r == CV_OK && o.nodes) {
        r = create_node_devices(ctx, o.nodes, devices, &device_count, o.quiet);
    } else if (r == CV_OK) {
        r = cv_vulkan_create_devices(ctx, &table, o.validation, devices);
        device_count = r == CV_OK ? table.count : 0;
    }
    if (r == CV_OK && !o.quiet && !o.nodes && !o.reference)
        for (uint32_t d = 0; d < table.count; d++) {
            const cv_device_info *info = cv_device_get_info(devices[d]);
            fprintf(stderr, "%s: %s (adapter %u, instance %u)%s, trace path %s, cross-device waits: %s\n",
                    cv_device_label(devices[d]), info->name, table.gpus[d].adapter, table.gpus[d].instance,
                    d == 0 ? ", primary" : "", info->trace_path[0] ? info->trace_path : "compute",
                    info->cross_wait[0] ? info->cross_wait : "-");
        }
    if (r == CV_OK && !o.reference)
        r = cv_renderer_create(devices, device_count, scene, bvh, &renderer);
    if (r == CV_OK && !o.reference)
        r = cv_renderer_render(renderer, &o.settings, &image, &stats, progress,
                               &(render_progress){ .quiet = o.quiet,
                                                   .renderer = o.nodes ? renderer : NULL,
                                                   .ctx = ctx,
                                                   .devices = devices,
                                                   .count = device_count,
                                                   .nodes = o.nodes });
    if (r == CV_OK && o.dump_graph)
        r = dump_graph(renderer, &out);
    cv_render_settings s = { 0 };
    if (r == CV_OK)
        s = cv_render_settings_resolve(&o.settings, scene);
    if (r == CV_OK)
        r = write_images(&o, &out, &image);
    if (r == CV_OK)
        r = write_logs(&out, log, &stats);
    if (r != CV_OK)
        r = cv_file_set_name_error(out.set, r); /* the files' names, not their temporaries' */
    if (r == CV_OK)
        r = cv_file_set_commit(out.set);
    if (r == CV_OK && !o.quiet && o.reference)
        printf("wrote %s and %s (%ux%u, CPU reference, %u samples x %u AO rays/pixel)\n", out.exr, out.png,
               image.width, image.height, o.reference, s.ao_samples);
    if (r == CV_OK && !o.quiet && !o.reference) {
        printf("wrote %s and %s (%ux%u, %u frames, %u shadow + %u AO rays/pixel/frame)\n", out.exr, out.png,
               image.width, image.height, stats.frames, s.shadow_samples, s.ao_samples);
        printf("bvh build %.1f ms; upload to %u devices %.1f ms; %.1f ms per frame; %.2f Mrays/s overall\n", t_bvh,
               stats.device_count, stats.upload_ms, stats.frame_ms,
               stats.rays_total / (stats.frame_ms * stats.frames) / 1e3);
        if (stats.setup_ms > 0)
            printf("graph set-up before the frames (first bake, transfer rings) %.1f ms\n", stats.setup_ms);
        for (uint32_t d = 0; d < stats.device_count; d++) {
            const cv_render_device_stats *ds = &stats.devices[d];
            printf("  %s: columns %u..%u, %llu rays, trace %.1f ms (%.2f Mrays/s)\n", cv_device_label(devices[d]),
                   ds->columns.x, ds->columns.x + ds->columns.width, (unsigned long long)ds->rays, ds->trace_ms,
                   ds->trace_ms > 0 ? ds->rays / ds->trace_ms / 1e3 : 0.0);
        }
        if (stats.reflection_rays)
            printf(
                "  reflections: %llu rays with their shadow rays, %u a traced pixel a frame (not in the rays "
                "and Mrays/s above)\n",
                (unsigned long long)stats.reflection_rays, 2 * s.reflection_samples);
        if (stats.alpha_rays)
            printf("  alpha mask: %llu ray slots re-traced past cut points (not in the rays above)\n",
                   (unsigned long long)stats.alpha_rays);
        printf("transfers between devices: %.1f MB in %.1f ms; total %.1f s\n", stats.transfer_bytes / 1e6,
               stats.transfer_ms, (cv_now_ms() - t0) / 1e3);
        if (o.stats || o.trace)
            printf("wrote%s%s%s%s (%u frames)\n", o.stats ? " stats " : "", o.stats ? o.stats : "",
                   o.trace ? " trace " : "", o.trace ? o.trace : "", cv_render_log_frame_count(log));
        for (uint32_t d = 0; o.nodes && d < device_count; d++) {
            cv_proxy_stats ps;
            if (cv_proxy_get_stats(devices[d], &ps) == CV_OK)
                printf(
                    "  %s: sent %.2f MB, received %.2f MB, %llu round trips + %llu waits for finished work; "
                    "scene data uploaded %.2f MB, already on the node %.2f MB\n",
                    cv_device_label(devices[d]), ps.bytes_sent / 1e6, ps.bytes_received / 1e6,
                    (unsigned long long)ps.round_trips, (unsigned long long)ps.blocking_waits,
                    ps.upload_bytes_sent / 1e6, ps.upload_bytes_skipped / 1e6);
        }
    }
    if (r == CV_OK && o.validation && cv_vulkan_validation_message_count())
        r = cv_error(CV_ERROR_BACKEND, "the validation layer reported %u messages",
                     cv_vulkan_validation_message_count());
    if (r != CV_OK)
        outputs_discard(&out);
    outputs_release_signals();
    outputs_free(&out);
    cv_render_log_destroy(log);
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
