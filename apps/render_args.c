/* corvid-render's command line (render_args.h): the program's own options in
 * one table, the settings options from the renderer's settings table. */
#include "render_args.h"

#include <errno.h>
#include <stddef.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "corvid/endpoint.h"
#include "corvid/parse.h"
#include "corvid/render_options.h"
#include "corvid/renderer.h"
#include "option_walk.h"

struct program_option;
/* Parses `value` into *o, or says why it refuses it (naming the option, the
 * value and the accepted range) and returns false. */
typedef bool (*option_fn)(options *o, const struct program_option *def, const char *value);

/* A row: an option (set NULL: taken before, by cv_env_vulkan_gpu_args; help NULL:
 * not in the help), or, with name NULL, a heading of the help (help NULL too:
 * the settings options go here). */
typedef struct program_option {
    const char *name, *metavar; /* metavar NULL: takes no value */
    option_fn set;
    size_t field;      /* the options member it sets (offsetof) */
    uint32_t min, max; /* a whole-number value's range (max 0: none) */
    const char *def;   /* its default, for the help; NULL: none said */
    const char *help;
} program_option;

static bool refuse(const char *name, const char *value, const char *expected) {
    fprintf(stderr, "corvid-render: %s: '%s' is not %s (see --help)\n", name, value, expected);
    return false;
}

static bool set_u32(const program_option *def, const char *value, uint32_t *out) {
    uint64_t v;
    if (!cv_parse_uint(value, def->min, def->max, &v)) {
        char expected[64];
        snprintf(expected, sizeof expected, "a whole number in %u..%u", def->min, def->max);
        return refuse(def->name, value, expected);
    }
    *out = (uint32_t)v;
    return true;
}

static bool opt_scene(options *o, const program_option *def, const char *value) {
    if (!value[0])
        return refuse(def->name, value, "a scene (room, stress:N or a file)");
    if (!strncmp(value, "stress:", 7) && !cv_parse_uint(value + 7, 1, UINT64_MAX, &o->stress_triangles))
        return refuse(def->name, value, "stress:N with N a whole number of triangles, at least 1");
    o->scene = value;
    return true;
}

static void *field_of(options *o, const program_option *def) { return (char *)o + def->field; }

static bool opt_u32(options *o, const program_option *def, const char *value) {
    return set_u32(def, value, field_of(o, def));
}

/* A finite float; strtof's ERANGE is also underflow (a denormal): finite, accepted. */
static bool opt_exposure(options *o, const program_option *def, const char *value) {
    char *end;
    errno = 0;
    float v = strtof(value, &end);
    if ((errno && errno != ERANGE) || end == value || *end || !isfinite(v))
        return refuse(def->name, value, "a finite number of stops");
    *(float *)field_of(o, def) = v;
    return true;
}

/* The prefix must end in a file name: "" or "dir/" would write the hidden
 * files ".exr" and ".png". */
static bool opt_out(options *o, const program_option *def, const char *value) {
    const char *slash = strrchr(value, '/');
    const char *file = slash ? slash + 1 : value;
    if (!file[0] || !strcmp(file, ".") || !strcmp(file, ".."))
        return refuse(def->name, value, "a path ending in a file name (such as out/frame)");
    o->out = value;
    return true;
}

bool render_args_nodes(options *o, const char *name, const char *value) {
    cv_endpoint nodes[CV_MAX_NODES];
    uint32_t count;
    if (cv_endpoints_parse(value, name, nodes, CV_MAX_NODES, &count) != CV_OK) {
        fprintf(stderr, "corvid-render: %s (see --help)\n", cv_last_error());
        return false;
    }
    o->nodes = value;
    return true;
}

static bool opt_nodes(options *o, const program_option *def, const char *value) {
    return render_args_nodes(o, def->name, value);
}

/* --dump-graph, --stats, --trace: a file name each. */
static bool opt_file(options *o, const program_option *def, const char *value) {
    if (!value[0])
        return refuse(def->name, value, "a file name");
    *(const char **)field_of(o, def) = value;
    return true;
}

/* The flags: --validation, --quiet, --list-adapters, --help and -h. */
static bool opt_flag(options *o, const program_option *def, const char *value) {
    (void)value;
    return *(bool *)field_of(o, def) = true;
}

#define REFERENCE_HELP \
    "render the CPU reference instead (ground truth for the renderer's image model): N samples per pixel, " \
    "unfiltered, float32 accumulation, on 2 threads; writes the same layers; no devices (so not with --gpus, " \
    "--nodes, --dump-graph, --stats, --trace and the like)"

static const program_option program_options[] = {
    { NULL, NULL, NULL, 0, 0, 0, NULL, "Scene and images:" },
    { "--scene", "S", opt_scene, offsetof(options, scene), 0, 0, "room",
      "room, stress:N (N triangles), or a model file (glTF, OBJ, ...)" },
    { "--seed", "N", opt_u32, offsetof(options, seed), 0, UINT32_MAX, "1", "seed of procedural scenes" },
    { "--out", "PREFIX", opt_out, offsetof(options, out), 0, 0, "out/frame",
      "output path without extension, ending in a file name" },
    { "--exposure", "EV", opt_exposure, offsetof(options, exposure), 0, 0, "0", "exposure of the PNG in stops" },
    { "--reference", "N", opt_u32, offsetof(options, reference), 1, CV_RENDER_REFERENCE_MAX_SAMPLES, NULL,
      REFERENCE_HELP },
    { NULL, NULL, NULL, 0, 0, 0, NULL, "Render settings:" },
    { NULL, NULL, NULL, 0, 0, 0, NULL, NULL },
    { NULL, NULL, NULL, 0, 0, 0, NULL, "Devices:" },
    { "--gpus", "N", NULL, 0, 0, 0, NULL,
      "total devices (virtual GPUs are added to reach N); overrides --virtual-gpus and CORVID_VIRTUAL_GPUS" },
    { "--virtual-gpus", "N", NULL, 0, 0, 0, NULL, "device instances per adapter (or CORVID_VIRTUAL_GPUS=N)" },
    { "--adapters", "LIST", NULL, 0, 0, 0, NULL,
      "comma-separated adapter names or indices (e.g. llvmpipe, H100, 0)" },
    { "--nodes", "LIST", opt_nodes, offsetof(options, nodes), 0, 0, NULL,
      "render on the devices of remote corvid-nodes instead, HOST:PORT,... (or CORVID_NODES=LIST); the first "
      "node's first device is the primary" },
    { "--validation", NULL, opt_flag, offsetof(options, validation), 0, 0, NULL,
      "enable VK_LAYER_KHRONOS_validation" },
    { "--list-adapters", NULL, opt_flag, offsetof(options, list_adapters), 0, 0, NULL,
      "print the Vulkan adapters and exit" },
    { NULL, NULL, NULL, 0, 0, 0, NULL,
      "Records (--out, --stats, --trace and --dump-graph name distinct regular files, checked before\n"
      "  rendering and written together at the end; SIGINT/SIGTERM leave none of them half-made):" },
    { "--dump-graph", "FILE", opt_file, offsetof(options, dump_graph), 0, 0, NULL,
      "write the frame's render graph (passes, devices, cross-device copies) as text to FILE and as Graphviz dot "
      "to FILE.dot (not with --reference)" },
    { "--stats", "FILE", opt_file, offsetof(options, stats), 0, 0, NULL,
      "write per-frame stats as JSON: wall time, per device its columns, rays, pass times and transfers; then a "
      "summary (not with --reference)" },
    { "--trace", "FILE", opt_file, offsetof(options, trace), 0, 0, NULL,
      "write a Chrome/Perfetto trace (open in ui.perfetto.dev): a track per device with each pass and transfer "
      "of every frame (not with --reference)" },
    { NULL, NULL, NULL, 0, 0, 0, NULL, "Other:" },
    { "--quiet", NULL, opt_flag, offsetof(options, quiet), 0, 0, NULL, "print only errors" },
    { "--help", NULL, opt_flag, offsetof(options, help), 0, 0, NULL, "this text (also -h)" },
    { "-h", NULL, opt_flag, offsetof(options, help), 0, 0, NULL, NULL },
};
#define PROGRAM_OPTION_COUNT (sizeof program_options / sizeof program_options[0])

static const program_option *program_option_find(const char *name, size_t len) {
    for (size_t k = 0; k < PROGRAM_OPTION_COUNT; k++) {
        const program_option *def = &program_options[k];
        if (def->set && strlen(def->name) == len && !strncmp(name, def->name, len))
            return def;
    }
    return NULL;
}

void render_args_usage(FILE *f) {
    fprintf(f,
            "usage: corvid-render [options]   (--option VALUE or --option=VALUE)\n"
            "Renders a scene (G-buffer raster, ray-traced soft shadows and AO split into column\n"
            "partitions across devices, filtering) and writes PREFIX.exr and PREFIX.png.\n");
    for (size_t k = 0; k < PROGRAM_OPTION_COUNT; k++) {
        const program_option *def = &program_options[k];
        char name[64], text[1024], range[64] = "";
        if (!def->name && !def->help) {
            cv_render_options_help(f);
            continue;
        }
        if (!def->help)
            continue;
        if (!def->name) {
            fprintf(f, "%s\n", def->help);
            continue;
        }
        snprintf(name, sizeof name, "%s%s%s", def->name, def->metavar ? " " : "", def->metavar ? def->metavar : "");
        if (def->max)
            snprintf(range, sizeof range, "%u..%u%s", def->min, def->max, def->def ? "; " : "");
        if (def->max || def->def)
            snprintf(text, sizeof text, "%s (%s%s%s)", def->help, range, def->def ? "default " : "",
                     def->def ? def->def : "");
        else
            snprintf(text, sizeof text, "%s", def->help);
        cv_render_help_entry(f, name, text);
    }
    fprintf(f,
            "Multi-GPU environment (docs/transfers.md):\n"
            "  CORVID_ZERO_COPY=auto|on|off         columns gathered without copies where devices share\n"
            "                                       memory (virtual GPUs of one adapter; default auto)\n"
            "  CORVID_TRANSFER_PATH=auto|device|shared|host-import|staged  force a copy path\n"
            "  CORVID_VGPU_DEVICE=auto|shared|separate  virtual GPUs on one VkDevice or one each\n"
            "  CORVID_LINK_QUEUE=compute|graphics|copy  the queue of GPU-side copies (default compute)\n"
            "  CORVID_CROSS_WAIT=auto|import|bridge     how a GPU waits for another device\n"
            "  CORVID_TRANSFER_ASYNC=0|1            0: every transfer synchronous (for comparisons); 1 default\n");
}

static const void *find_own(const char *name, size_t len, const char **canonical, bool *takes_value) {
    const program_option *def = program_option_find(name, len);
    if (def) {
        *canonical = def->name;
        *takes_value = def->metavar != NULL;
    }
    return def;
}

static bool set_own(void *o, const void *def, const char *value) {
    const program_option *d = def;
    return d->set(o, d, value);
}

int render_args_parse(int argc, char **argv, options *o) {
    *o = (options){ .scene = "room", .out = "out/frame", .seed = 1 };
    return option_walk_run(&(option_walk){ "corvid-render", find_own, set_own, o, &o->settings }, argc, argv);
}
