/* corvid-render's command line: the renderer's settings options (from the
 * settings table, corvid/render_options.h) and the program's own options
 * (scene, outputs, devices, records), parsed into one `options`, and --help.
 * --gpus, --virtual-gpus and --adapters are taken out of argv before, by
 * cv_env_vulkan_gpu_args; their help is here. */
#ifndef CORVID_APPS_RENDER_ARGS_H
#define CORVID_APPS_RENDER_ARGS_H

#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>

#include "corvid/render_settings.h"

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

/* Takes "--name value" and "--name=value" alike; every value is checked as
 * it is read, naming the option. 0 = ok, 2 = bad usage (said on stderr). */
int render_args_parse(int argc, char **argv, options *o);

/* --nodes LIST (or CORVID_NODES, `name`): false, said on stderr, when LIST is no list of endpoints. */
bool render_args_nodes(options *o, const char *name, const char *value);

void render_args_usage(FILE *f);

#endif
