/* corvid-view's command line (view_args.h): the program's options in one table,
 * the settings options from the renderer's settings table. */
#include "view_args.h"

#include <stddef.h>
#include <stdlib.h>
#include <string.h>

#include "corvid/endpoint.h"
#include "corvid/parse.h"
#include "corvid/render_options.h"
#include "corvid/renderer.h"
#include "option_walk.h"

struct view_option;
typedef bool (*option_fn)(view_options *o, const struct view_option *def, const char *value);

/* A row: an option (set NULL: taken before, by cv_env_vulkan_gpu_args), or, with
 * name NULL, a heading of the help (help NULL too: the settings options go here). */
typedef struct view_option {
    const char *name, *metavar; /* metavar NULL: a flag */
    option_fn set;
    size_t field;      /* the view_options member it sets (offsetof) */
    uint32_t min, max; /* a whole number's range */
    const char *def;   /* its default, for the help */
    const char *help;
} view_option;

static bool refuse(const char *name, const char *value, const char *expected) {
    fprintf(stderr, "corvid-view: %s: '%s' is not %s (see --help)\n", name, value, expected);
    return false;
}

static void *field_of(view_options *o, const view_option *def) { return (char *)o + def->field; }

static bool opt_u32(view_options *o, const view_option *def, const char *value) {
    uint64_t v;
    if (!cv_parse_uint(value, def->min, def->max, &v)) {
        char expected[64];
        snprintf(expected, sizeof expected, "a whole number in %u..%u", def->min, def->max);
        return refuse(def->name, value, expected);
    }
    *(uint32_t *)field_of(o, def) = (uint32_t)v;
    return true;
}

static bool opt_bytes(view_options *o, const view_option *def, const char *value) {
    if (!cv_parse_uint(value, 1, UINT64_MAX / 2, (uint64_t *)field_of(o, def)))
        return refuse(def->name, value, "a number of bytes, at least 1");
    return true;
}

static bool opt_text(view_options *o, const view_option *def, const char *value) {
    if (!value[0])
        return refuse(def->name, value, def->metavar[0] == 'F' ? "a file name" : "a value");
    *(const char **)field_of(o, def) = value;
    return true;
}

static bool opt_flag(view_options *o, const view_option *def, const char *value) {
    (void)value;
    return *(bool *)field_of(o, def) = true;
}

static bool opt_scene(view_options *o, const view_option *def, const char *value) {
    if (!value[0])
        return refuse(def->name, value, "a scene (room, stress:N or a file)");
    if (!strncmp(value, "stress:", 7) && !cv_parse_uint(value + 7, 1, UINT64_MAX, &o->stress_triangles))
        return refuse(def->name, value, "stress:N with N a whole number of triangles, at least 1");
    o->scene = value;
    return true;
}

static bool opt_codec(view_options *o, const view_option *def, const char *value) {
    if (!strcmp(value, "jpeg"))
        o->codec = CV_CODEC_JPEG;
    else if (!strcmp(value, "h264"))
        o->codec = CV_CODEC_H264;
    else
        return refuse(def->name, value, "jpeg or h264");
    return true;
}

static bool opt_nodes(view_options *o, const view_option *def, const char *value) {
    cv_endpoint nodes[CV_MAX_NODES];
    uint32_t count;
    if (cv_endpoints_parse(value, def->name, nodes, CV_MAX_NODES, &count) != CV_OK) {
        fprintf(stderr, "corvid-view: %s (see --help)\n", cv_last_error());
        return false;
    }
    o->nodes = value;
    return true;
}

/* --width and --height: the settings' size (the table's --size WxH sets both). */
static bool opt_side(view_options *o, const view_option *def, const char *value) {
    uint64_t v;
    if (!cv_parse_uint(value, 1, CV_MAX_TEXTURE_DIM, &v)) {
        char expected[64];
        snprintf(expected, sizeof expected, "a whole number of pixels in 1..%u", CV_MAX_TEXTURE_DIM);
        return refuse(def->name, value, expected);
    }
    *(uint32_t *)((char *)&o->settings + def->field) = (uint32_t)v;
    return true;
}

#define O(field) offsetof(view_options, field)
static const view_option view_option_rows[] = {
    { NULL, NULL, NULL, 0, 0, 0, NULL, "Server:" },
    { "--port", "N", opt_u32, O(port), 0, 65535, "8080", "TCP port of the page (0: any free port, printed)" },
    { "--host", "ADDR", opt_text, O(host), 0, 0, "127.0.0.1",
      "address to listen on; other than loopback needs --token-file" },
    { "--token-file", "FILE", opt_text, O(token_file), 0, 0, NULL,
      "a file whose first line is the token the page and the API must present (the printed URL carries it)" },
    { "--tls-cert", "FILE", opt_text, O(tls_cert), 0, 0, NULL,
      "serve HTTPS with this PEM certificate (and --tls-key)" },
    { "--tls-key", "FILE", opt_text, O(tls_key), 0, 0, NULL, "the certificate's PEM private key" },
    { NULL, NULL, NULL, 0, 0, 0, NULL, "Stream:" },
    { "--codec", "jpeg|h264", opt_codec, 0, 0, 0, "jpeg",
      "frames to the page as JPEG images or an H.264 stream (WebCodecs in the browser)" },
    { "--quality", "N", opt_u32, O(quality), 1, 100, "85", "starting JPEG quality (then adapted to the link)" },
    { "--bitrate", "KBPS", opt_u32, O(bitrate_kbps), 1, 1000000, NULL,
      "starting H.264 bitrate (then adapted to the link; default about 0.12 bit per pixel)" },
    { "--width", "N", opt_side, offsetof(cv_render_settings, width), 0, 0, "640", "image width in pixels" },
    { "--height", "N", opt_side, offsetof(cv_render_settings, height), 0, 0, "360", "image height in pixels" },
    { NULL, NULL, NULL, 0, 0, 0, NULL, "Scene:" },
    { "--scene", "S", opt_scene, 0, 0, 0, "room", "room, stress:N (N triangles), or a model file (glTF, OBJ, ...)" },
    { "--seed", "N", opt_u32, O(seed), 0, UINT32_MAX, "1", "seed of procedural scenes" },
    { NULL, NULL, NULL, 0, 0, 0, NULL,
      "Render settings of the first frame (the page changes them; --frames: a still view accumulates\n"
      "  this many frames, then rests until the view changes; default 256):" },
    { NULL, NULL, NULL, 0, 0, 0, NULL, NULL },
    { NULL, NULL, NULL, 0, 0, 0, NULL,
      "Jobs (the REST gateway of docs/gateway.md on the same port, under /api/v1; jobs render on devices of\n"
      "  their own, chosen as the view's):" },
    { "--jobs", "N", opt_u32, O(jobs), 1, 64, "2", "jobs rendering at once" },
    { "--max-scene-bytes", "N", opt_bytes, O(max_scene_bytes), 0, 0, "268435456",
      "largest model a job may upload (413 above)" },
    { NULL, NULL, NULL, 0, 0, 0, NULL, "Devices:" },
    { "--gpus", "N", NULL, 0, 0, 0, "2", "total local devices (virtual GPUs are added to reach N)" },
    { "--virtual-gpus", "N", NULL, 0, 0, 0, NULL, "device instances per adapter (or CORVID_VIRTUAL_GPUS=N)" },
    { "--adapters", "LIST", NULL, 0, 0, 0, NULL, "comma-separated adapter names or indices (e.g. llvmpipe, 0)" },
    { "--nodes", "LIST", opt_nodes, 0, 0, 0, NULL,
      "render on the devices of remote corvid-nodes instead, HOST:PORT,... (or CORVID_NODES=LIST); frames are "
      "encoded on the first node's first device, the primary" },
    { "--validation", NULL, opt_flag, O(validation), 0, 0, NULL, "enable VK_LAYER_KHRONOS_validation" },
    { NULL, NULL, NULL, 0, 0, 0, NULL, "Other:" },
    { "--quiet", NULL, opt_flag, O(quiet), 0, 0, NULL, "print only the URL and errors" },
    { "--trace", "FILE", opt_text, O(trace), 0, 0, NULL,
      "write the live's trace there when stopped (Chrome/Perfetto JSON: render, read, encode, link and send per "
      "frame, spoiled frames; docs/live.md)" },
    { "--help", NULL, opt_flag, O(help), 0, 0, NULL, "this text (also -h)" },
    { "-h", NULL, opt_flag, O(help), 0, 0, NULL, NULL },
};
#undef O
#define VIEW_OPTION_COUNT (sizeof view_option_rows / sizeof view_option_rows[0])

static const view_option *view_option_find(const char *name, size_t len) {
    for (size_t k = 0; k < VIEW_OPTION_COUNT; k++) {
        const view_option *def = &view_option_rows[k];
        if (def->set && strlen(def->name) == len && !strncmp(name, def->name, len))
            return def;
    }
    return NULL;
}

void view_args_usage(FILE *f) {
    fprintf(f,
            "usage: corvid-view [options]   (--option VALUE or --option=VALUE)\n"
            "Renders a scene live and serves it to a browser: open the printed URL, then orbit (drag),\n"
            "pan (shift-drag or right-drag), zoom (wheel), move (WASD, arrows), change the sun and the\n"
            "settings, and save the frame as PNG or EXR. The protocol is in docs/live-view.md.\n");
    for (size_t k = 0; k < VIEW_OPTION_COUNT; k++) {
        const view_option *def = &view_option_rows[k];
        char name[64], text[1024];
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
        if (def->def)
            snprintf(text, sizeof text, "%s (default %s)", def->help, def->def);
        else
            snprintf(text, sizeof text, "%s", def->help);
        cv_render_help_entry(f, name, text);
    }
    fprintf(f, "Stop with Ctrl-C (SIGINT) or SIGTERM.\n");
}

static const void *find_own(const char *name, size_t len, const char **canonical, bool *takes_value) {
    const view_option *def = view_option_find(name, len);
    if (def) {
        *canonical = def->name;
        *takes_value = def->metavar != NULL;
    }
    return def;
}

static bool set_own(void *o, const void *def, const char *value) {
    const view_option *d = def;
    return d->set(o, d, value);
}

int view_args_parse(int argc, char **argv, view_options *o) {
    *o = (view_options){ .scene = "room", .seed = 1, .port = 8080, .codec = CV_CODEC_JPEG };
    if (option_walk_run(&(option_walk){ "corvid-view", find_own, set_own, o, &o->settings }, argc, argv))
        return 2;
    o->max_accumulate = o->settings.frames;
    o->settings.frames = 0;
    if (!o->settings.width)
        o->settings.width = 640;
    if (!o->settings.height)
        o->settings.height = 360;
    if (o->codec == CV_CODEC_H264 && (o->settings.width % 2 || o->settings.height % 2)) {
        fprintf(stderr, "corvid-view: --codec h264 needs an even width and height (%ux%u given)\n", o->settings.width,
                o->settings.height);
        return 2;
    }
    if (!o->tls_cert != !o->tls_key) {
        fprintf(stderr, "corvid-view: --tls-cert and --tls-key go together (see --help)\n");
        return 2;
    }
    return 0;
}
