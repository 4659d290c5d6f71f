/* corvid-render: renders a scene with the hybrid renderer on one or more
 * Vulkan devices (real GPUs or virtual GPUs) and writes an EXR (HDR beauty and
 * AOV layers) and a tone-mapped PNG. Its command line is render_args.c, its
 * devices render_devices.c, its output files render_outputs.c. */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "corvid/clock.h"
#include "env_client.h"
#include "env_graph.h"
#include "env_log.h"
#include "env_vulkan.h"
#include "corvid/image_exr.h"
#include "corvid/image_files.h"
#include "corvid/image_png.h"
#include "corvid/proxy.h"
#include "corvid/render_log.h"
#include "corvid/renderer.h"
#include "corvid/scene_import.h"
#include "corvid/scene_procedural.h"
#include "corvid/tonemap.h"
#include "corvid/vulkan.h"
#include "render_args.h"
#include "render_devices.h"
#include "render_exr.h"
#include "render_outputs.h"

/* One run of the program: what it made, freed by finish(). */
typedef struct render_run {
    options o;
    cv_vulkan_gpu_config gpu_config;
    double t0, t_bvh; /* start; the BVH build's milliseconds */
    cv_scene *scene;
    cv_bvh *bvh;
    cv_context *ctx;
    cv_renderer *renderer;
    cv_device *devices[CV_MAX_DEVICES];
    uint32_t device_count;
    cv_vulkan_gpu_table table;
    cv_render_output image;
    cv_render_stats stats;
    outputs out;
    cv_render_log *log;
    cv_render_observer observer;
} render_run;

/* What no single option decides: the device options against each other and
 * against --reference. 0 = go on; else the exit code (said on stderr). */
static int check_choices(render_run *run) {
    options *o = &run->o;
    cv_vulkan_gpu_config *gpu = &run->gpu_config;
    if (gpu->adapters && !gpu->adapters[0]) {
        fprintf(stderr, "corvid-render: --adapters: the list is empty (see --help)\n");
        return 2;
    }
    /* An explicit device count wins: the per-adapter count is then unused, so
     * CORVID_VIRTUAL_GPUS must not be read (and refused) for it. */
    if (gpu->total && !gpu->virtual_per_adapter)
        gpu->virtual_per_adapter = 1;
    if (o->list_adapters)
        return 0;
    bool local_choice = gpu->adapters || gpu->total || gpu->virtual_per_adapter;
    if (!o->nodes && !local_choice && !o->reference && getenv("CORVID_NODES") && getenv("CORVID_NODES")[0]) {
        if (!render_args_nodes(o, "CORVID_NODES", getenv("CORVID_NODES")))
            return 2;
    }
    /* --reference renders on the CPU, without devices or a render graph: an
     * option about those would be ignored, so it is refused instead. */
    if ((o->stats || o->trace || o->dump_graph) && o->reference) {
        fprintf(stderr,
                "corvid-render: --stats, --trace and --dump-graph record the GPU renderer's frames and graph; "
                "--reference renders on the CPU: give one or the other\n");
        return 2;
    }
    if ((o->nodes || local_choice || o->validation) && o->reference) {
        fprintf(stderr,
                "corvid-render: --reference renders on the CPU, on no device: --gpus, --virtual-gpus, --adapters, "
                "--nodes and --validation choose devices; give one or the other\n");
        return 2;
    }
    if (o->nodes && local_choice) {
        fprintf(stderr,
                "corvid-render: --nodes renders on the devices the nodes serve; --gpus, --virtual-gpus and "
                "--adapters choose local ones: give one or the other\n");
        return 2;
    }
    return 0;
}

static cv_result load_scene(const options *o, cv_scene **out) {
    if (!strcmp(o->scene, "room"))
        return cv_scene_make_room(o->seed, out);
    if (o->stress_triangles)
        return cv_scene_make_stress(o->seed, o->stress_triangles, out);
    return cv_scene_import(o->scene, out);
}

/* The output files reserved, the frame log, the scene and its BVH. */
static cv_result prepare(render_run *run) {
    options *o = &run->o;
    cv_result r = outputs_reserve(&run->out, o->out, o->stats, o->trace, o->dump_graph);
    if (r == CV_OK)
        outputs_catch_signals(&run->out);
    if (r == CV_OK && (o->stats || o->trace))
        r = cv_render_log_create(&run->log);
    if (r == CV_OK && run->log) {
        run->observer = cv_render_log_observer(run->log);
        o->settings.observer = &run->observer;
    }
    if (r == CV_OK)
        r = load_scene(o, &run->scene);
    if (r == CV_OK && !o->quiet)
        fprintf(stderr, "scene '%s': %llu triangles, %u instances, %u materials\n", o->scene,
                (unsigned long long)cv_scene_world_triangle_count(run->scene), cv_scene_instance_count(run->scene),
                cv_scene_material_count(run->scene));
    /* A scene without a camera of its own is shown by the framing camera,
     * which cannot show every scene: say so rather than render an empty sky. */
    if (r == CV_OK && cv_scene_camera_count(run->scene) == 0) {
        r = cv_scene_check_framing(run->scene);
        if (r != CV_OK)
            r = cv_error(r, "--scene %s: %s", o->scene, cv_last_error());
    }
    run->t_bvh = cv_now_ms();
    if (r == CV_OK)
        r = cv_bvh_build_flat(run->scene, NULL, &run->bvh);
    run->t_bvh = cv_now_ms() - run->t_bvh;
    return r;
}

/* The local devices (--gpus, --adapters, ...) or the nodes' (--nodes), each named on stderr. */
static cv_result create_devices(render_run *run) {
    const options *o = &run->o;
    cv_vulkan_gpu_table *table = &run->table;
    /* The Vulkan variables (apps/common/env_vulkan.h) only where the table is used. */
    cv_result r = o->nodes ? CV_OK : cv_env_vulkan_gpu_config(&run->gpu_config);
    if (r == CV_OK && !o->nodes)
        r = cv_vulkan_gpu_table_build(&run->gpu_config, table);
    if (r == CV_OK && table->count > CV_MAX_DEVICES)
        r = cv_error(CV_ERROR_LIMIT_EXCEEDED, "%u devices requested; the renderer takes at most %u", table->count,
                     CV_MAX_DEVICES);
    if (r == CV_OK)
        r = cv_context_create(NULL, &run->ctx);
    if (r == CV_OK && o->nodes)
        return render_node_devices(run->ctx, o->nodes, run->devices, &run->device_count, o->quiet);
    if (r == CV_OK)
        r = cv_vulkan_create_devices(run->ctx, table, o->validation, run->devices);
    run->device_count = r == CV_OK ? table->count : 0;
    for (uint32_t d = 0; d < run->device_count && !o->quiet; d++) {
        const cv_device_info *info = cv_device_get_info(run->devices[d]);
        fprintf(stderr, "%s: %s (adapter %u, instance %u)%s, trace path %s, cross-device waits: %s\n",
                cv_device_label(run->devices[d]), info->name, table->gpus[d].adapter, table->gpus[d].instance,
                d == 0 ? ", primary" : "", info->trace_path[0] ? info->trace_path : "compute",
                info->cross_wait[0] ? info->cross_wait : "-");
    }
    return r;
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

/* The image: the CPU reference, or the renderer's frames on the devices (and --dump-graph's graph). */
static cv_result render(render_run *run) {
    const options *o = &run->o;
    if (o->reference) {
        cv_result r = cv_render_reference(run->scene, run->bvh, &o->settings, o->reference, 2, &run->image);
        if (r == CV_OK && !o->quiet)
            fprintf(stderr, "reference: %u samples per pixel in %.1f s\n", o->reference,
                    (cv_now_ms() - run->t0) / 1e3);
        return r;
    }
    cv_result r = create_devices(run);
    if (r == CV_OK)
        r = cv_renderer_create(run->devices, run->device_count, run->scene, run->bvh, &run->renderer);
    if (r == CV_OK)
        r = cv_renderer_render(run->renderer, &o->settings, &run->image, &run->stats, render_progress_report,
                               &(render_progress){ .quiet = o->quiet,
                                                   .renderer = o->nodes ? run->renderer : NULL,
                                                   .ctx = run->ctx,
                                                   .devices = run->devices,
                                                   .count = run->device_count,
                                                   .nodes = o->nodes });
    if (r == CV_OK && o->dump_graph)
        r = dump_graph(run->renderer, &run->out);
    return r;
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

/* The files written to their temporaries and renamed into place together. */
static cv_result write_outputs(render_run *run) {
    cv_result r = write_images(&run->o, &run->out, &run->image);
    if (r == CV_OK)
        r = write_logs(&run->out, run->log, &run->stats);
    if (r != CV_OK)
        r = cv_file_set_name_error(run->out.set, r); /* the files' names, not their temporaries' */
    if (r == CV_OK)
        r = cv_file_set_commit(run->out.set);
    return r;
}

/* What the GPU render did: per device its columns and rays, transfers, and the nodes' traffic. */
static void print_summary(const render_run *run, const cv_render_settings *s) {
    const options *o = &run->o;
    const cv_render_stats *st = &run->stats;
    printf("wrote %s and %s (%ux%u, %u frames, %u shadow + %u AO rays/pixel/frame)\n", run->out.exr, run->out.png,
           run->image.width, run->image.height, st->frames, s->shadow_samples, s->ao_samples);
    printf("bvh build %.1f ms; upload to %u devices %.1f ms; %.1f ms per frame; %.2f Mrays/s overall\n", run->t_bvh,
           st->device_count, st->upload_ms, st->frame_ms, st->rays_total / (st->frame_ms * st->frames) / 1e3);
    if (st->setup_ms > 0)
        printf("graph set-up before the frames (first bake, transfer rings) %.1f ms\n", st->setup_ms);
    for (uint32_t d = 0; d < st->device_count; d++) {
        const cv_render_device_stats *ds = &st->devices[d];
        printf("  %s: columns %u..%u, %llu rays, trace %.1f ms (%.2f Mrays/s)\n", cv_device_label(run->devices[d]),
               ds->columns.x, ds->columns.x + ds->columns.width, (unsigned long long)ds->rays, ds->trace_ms,
               ds->trace_ms > 0 ? ds->rays / ds->trace_ms / 1e3 : 0.0);
    }
    if (st->reflection_rays)
        printf(
            "  reflections: %llu rays with their shadow rays, %u a traced pixel a frame (not in the rays "
            "and Mrays/s above)\n",
            (unsigned long long)st->reflection_rays, 2 * s->reflection_samples);
    if (st->alpha_rays)
        printf("  alpha mask: %llu ray slots re-traced past cut points (not in the rays above)\n",
               (unsigned long long)st->alpha_rays);
    printf("transfers between devices: %.1f MB in %.1f ms; total %.1f s\n", st->transfer_bytes / 1e6, st->transfer_ms,
           (cv_now_ms() - run->t0) / 1e3);
    if (o->stats || o->trace)
        printf("wrote%s%s%s%s (%u frames)\n", o->stats ? " stats " : "", o->stats ? o->stats : "",
               o->trace ? " trace " : "", o->trace ? o->trace : "", cv_render_log_frame_count(run->log));
    for (uint32_t d = 0; o->nodes && d < run->device_count; d++) {
        cv_proxy_stats ps;
        if (cv_proxy_get_stats(run->devices[d], &ps) == CV_OK)
            printf(
                "  %s: sent %.2f MB, received %.2f MB, %llu round trips + %llu waits for finished work; "
                "scene data uploaded %.2f MB, already on the node %.2f MB\n",
                cv_device_label(run->devices[d]), ps.bytes_sent / 1e6, ps.bytes_received / 1e6,
                (unsigned long long)ps.round_trips, (unsigned long long)ps.blocking_waits, ps.upload_bytes_sent / 1e6,
                ps.upload_bytes_skipped / 1e6);
    }
}

/* Frees what the run made, keeps or discards its files by `r`, and says a failure: the exit code. */
static int finish(render_run *run, cv_result r) {
    if (r == CV_OK && run->o.validation && cv_vulkan_validation_message_count())
        r = cv_error(CV_ERROR_BACKEND, "the validation layer reported %u messages",
                     cv_vulkan_validation_message_count());
    if (r != CV_OK)
        outputs_discard(&run->out);
    outputs_release_signals();
    outputs_free(&run->out);
    cv_render_log_destroy(run->log);
    cv_render_output_free(&run->image);
    cv_renderer_destroy(run->renderer);
    cv_context_destroy(run->ctx);
    cv_bvh_destroy(run->bvh);
    cv_scene_destroy(run->scene);
    if (r != CV_OK) {
        fprintf(stderr, "corvid-render: %s: %s\n", cv_result_name(r), cv_last_error());
        return 1;
    }
    return 0;
}

/* The programs' environment (apps/common/): the log level, the client library's transfer path and node
 * connection options, and the frame graph's variables into the settings the renderer bakes with. 0, or 1
 * after a message. */
static int read_environment(cv_render_settings *settings) {
    env_log_apply();
    cv_graph_bake_desc graph_env = { 0 };
    cv_result r = cv_env_client_configure(CV_ENV_CLIENT_ALL);
    if (r == CV_OK)
        r = cv_env_graph_bake(&graph_env);
    if (r != CV_OK) {
        fprintf(stderr, "corvid-render: %s\n", cv_last_error());
        return 1;
    }
    settings->zero_copy = graph_env.zero_copy;
    settings->sync_transfers = graph_env.sync_transfers;
    return 0;
}

int main(int argc, char **argv) {
    render_run run = { 0 };
    if (cv_env_vulkan_gpu_args(&argc, argv, &run.gpu_config) != CV_OK) {
        fprintf(stderr, "corvid-render: %s (see --help)\n", cv_last_error());
        return 2;
    }
    int code = render_args_parse(argc, argv, &run.o);
    if (code)
        return code;
    if (run.o.help) {
        render_args_usage(stdout);
        return 0;
    }
    code = check_choices(&run);
    if (code)
        return code;
    code = read_environment(&run.o.settings);
    if (code)
        return code;
    if (run.o.list_adapters)
        return render_list_adapters();
    run.t0 = cv_now_ms();
    cv_result r = prepare(&run);
    if (r == CV_OK)
        r = render(&run);
    cv_render_settings s = r == CV_OK ? cv_render_settings_resolve(&run.o.settings, run.scene)
                                      : (cv_render_settings){ 0 };
    if (r == CV_OK)
        r = write_outputs(&run);
    if (r == CV_OK && !run.o.quiet && run.o.reference)
        printf("wrote %s and %s (%ux%u, CPU reference, %u samples x %u AO rays/pixel)\n", run.out.exr, run.out.png,
               run.image.width, run.image.height, run.o.reference, s.ao_samples);
    if (r == CV_OK && !run.o.quiet && !run.o.reference)
        print_summary(&run, &s);
    return finish(&run, r);
}
