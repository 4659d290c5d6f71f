/* corvid-view's command line: the server's options (address, token, TLS), the
 * stream's (codec, quality, size), the scene and devices, and the renderer's
 * settings options (corvid/render_options.h) for the first frame. --gpus,
 * --virtual-gpus and --adapters are taken out of argv before, by
 * cv_env_vulkan_gpu_args; their help is here. */
#ifndef CORVID_APPS_VIEW_ARGS_H
#define CORVID_APPS_VIEW_ARGS_H

#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>

#include "corvid/encode_types.h"
#include "corvid/render_settings.h"

typedef struct view_options {
    const char *scene;
    uint64_t stress_triangles; /* > 0 for --scene stress:N */
    uint32_t seed;
    const char *host;       /* NULL = 127.0.0.1 */
    uint32_t port;          /* 0 = any free port */
    const char *token_file; /* its first line is the token */
    const char *tls_cert, *tls_key;
    const char *nodes;           /* --nodes, or CORVID_NODES; NULL = local devices */
    cv_codec codec;              /* JPEG (default) or H264 */
    uint32_t quality;            /* JPEG starting quality; 0 = the encoder's default */
    uint32_t bitrate_kbps;       /* H.264 starting bitrate; 0 = the encoder's default */
    uint32_t max_accumulate;     /* --frames: a still view accumulates this many frames, then rests */
    cv_render_settings settings; /* the first frame's (width, height default 640x360) */
    uint32_t jobs;               /* gateway jobs rendering at once; 0 = the gateway's default */
    uint64_t max_scene_bytes;    /* largest model uploaded to the gateway; 0 = the gateway's default */
    const char *trace;           /* --trace FILE: the live's trace written there at the end; NULL = none */
    bool validation, quiet, help;
} view_options;

/* "--name value" and "--name=value" alike; every value checked as it is read, naming the
 * option. 0 = ok, 2 = bad usage (said on stderr). */
int view_args_parse(int argc, char **argv, view_options *o);

void view_args_usage(FILE *f);

#endif
