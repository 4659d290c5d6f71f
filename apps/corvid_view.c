/* corvid-view: the interactive viewer. Renders a scene live on local devices
 * (virtual GPUs on lavapipe by default) or on corvid-nodes' (--nodes), and
 * serves a page that shows the frames and sends the input back: open the
 * printed URL in a browser. The same port serves the REST gateway
 * (corvid/gateway.h), whose jobs render on devices of their own chosen as the
 * view's, and the page starts jobs of the scene it shows. Its command line is
 * view_args.c, its viewers view_session.c, its API view_api.c; the page is
 * web/page/ (embedded). */
#include <errno.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "corvid/bvh.h"
#include "corvid/gateway.h"
#include "corvid/live.h"
#include "corvid/live_trace.h"
#include "corvid/scene_import.h"
#include "corvid/scene_procedural.h"
#include "corvid/vulkan.h"
#include "corvid/web_server.h"
#include "cv_viewer_page.h"
#include "env_client.h"
#include "env_graph.h"
#include "env_log.h"
#include "env_vulkan.h"
#include "job_devices.h"
#include "render_devices.h"
#include "view_api.h"
#include "view_args.h"
#include "view_session.h"

/* One run of the program: what it made, freed by finish(). */
typedef struct view_run {
    view_options o;
    cv_vulkan_gpu_config gpu_config;
    char token[1040];
    cv_scene *scene;
    cv_bvh *bvh;
    cv_context *ctx;
    cv_device *devices[CV_MAX_DEVICES];
    uint32_t device_count;
    cv_renderer *renderer;
    view_session session;
    bool session_ready;
    cv_live *live;
    job_devices job_devices;
    cv_gateway *gateway;
    view_api api;
    bool api_ready;
    cv_live_trace *trace; /* --trace */
    cv_web_server *server;
} view_run;

/* The devices' choice against the environment (as corvid-render): 0 = go on, else the exit code. */
static int check_choices(view_run *run) {
    cv_vulkan_gpu_config *gpu = &run->gpu_config;
    bool local_choice = gpu->adapters || gpu->total || gpu->virtual_per_adapter;
    const char *env_nodes = getenv("CORVID_NODES");
    if (!run->o.nodes && !local_choice && env_nodes && env_nodes[0])
        run->o.nodes = env_nodes;
    if (run->o.nodes && local_choice) {
        fprintf(stderr,
                "corvid-view: --nodes renders on the nodes' devices; --gpus, --virtual-gpus and "
                "--adapters choose local ones: give one or the other\n");
        return 2;
    }
    if (!run->o.nodes && !local_choice)
        gpu->total = 2; /* the default: two virtual GPUs, so the view shows a split frame */
    if (gpu->total && !gpu->virtual_per_adapter)
        gpu->virtual_per_adapter = 1;
    return 0;
}

/* The environment (log, client, graph) and the token file: 0, or 1 after a message. */
static int read_environment(view_run *run) {
    env_log_apply();
    cv_graph_bake_desc graph_env = { 0 };
    cv_result r = cv_env_client_configure(CV_ENV_CLIENT_ALL);
    if (r == CV_OK)
        r = cv_env_graph_bake(&graph_env);
    if (r != CV_OK) {
        fprintf(stderr, "corvid-view: %s\n", cv_last_error());
        return 1;
    }
    run->o.settings.zero_copy = graph_env.zero_copy;
    run->o.settings.sync_transfers = graph_env.sync_transfers;
    if (!run->o.token_file)
        return 0;
    FILE *f = fopen(run->o.token_file, "r");
    if (!f || !fgets(run->token, sizeof run->token, f)) {
        fprintf(stderr, "corvid-view: --token-file %s: %s\n", run->o.token_file, f ? "empty" : strerror(errno));
        if (f)
            fclose(f);
        return 1;
    }
    fclose(f);
    run->token[strcspn(run->token, "\r\n")] = 0;
    if (!run->token[0] || strspn(run->token, "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789-._~") !=
                              strlen(run->token)) {
        fprintf(stderr,
                "corvid-view: --token-file %s: the first line must be a token of letters, digits and -._~ "
                "(it goes into the URL)\n",
                run->o.token_file);
        return 1;
    }
    return 0;
}

static cv_result load_scene(view_run *run) {
    const view_options *o = &run->o;
    cv_result r = !strcmp(o->scene, "room") ? cv_scene_make_room(o->seed, &run->scene)
                  : o->stress_triangles     ? cv_scene_make_stress(o->seed, o->stress_triangles, &run->scene)
                                            : cv_scene_import(o->scene, &run->scene);
    if (r == CV_OK && cv_scene_camera_count(run->scene) == 0) {
        r = cv_scene_check_framing(run->scene);
        if (r != CV_OK)
            r = cv_error(r, "--scene %s: %s", o->scene, cv_last_error());
    }
    if (r == CV_OK)
        r = cv_bvh_build_flat(run->scene, NULL, &run->bvh);
    return r;
}

/* The local devices or the nodes', each named on stderr; then the renderer. */
static cv_result create_renderer(view_run *run) {
    cv_vulkan_gpu_table table = { 0 };
    const char *nodes = run->o.nodes;
    cv_result r = nodes ? CV_OK : cv_env_vulkan_gpu_config(&run->gpu_config);
    if (r == CV_OK && !nodes)
        r = cv_vulkan_gpu_table_build(&run->gpu_config, &table);
    if (r == CV_OK && table.count > CV_MAX_DEVICES)
        r = cv_error(CV_ERROR_LIMIT_EXCEEDED, "%u devices requested; the renderer takes at most %u", table.count,
                     CV_MAX_DEVICES);
    if (r == CV_OK)
        r = cv_context_create(NULL, &run->ctx);
    if (r == CV_OK && nodes)
        r = render_node_devices(run->ctx, nodes, run->devices, &run->device_count, run->o.quiet);
    if (r == CV_OK && !nodes) {
        r = cv_vulkan_create_devices(run->ctx, &table, run->o.validation, run->devices);
        run->device_count = r == CV_OK ? table.count : 0;
    }
    for (uint32_t d = 0; r == CV_OK && !nodes && d < run->device_count && !run->o.quiet; d++)
        fprintf(stderr, "%s: %s%s\n", cv_device_label(run->devices[d]), cv_device_get_info(run->devices[d])->name,
                d == 0 ? ", primary (frames are encoded here)" : "");
    if (r == CV_OK)
        r = cv_renderer_create(run->devices, run->device_count, run->scene, run->bvh, &run->renderer);
    return r;
}

/* The gateway and the web server first, so that their refusals (a bad device choice, an
 * address in use, a host without a token) come before the scene and devices are made;
 * pages that connect early wait for the live. */
static cv_result start_server(view_run *run) {
    const view_options *o = &run->o;
    view_session_init(&run->session, &o->settings, o->codec);
    run->session_ready = true;
    run->job_devices.gpu_config = run->gpu_config;
    cv_result r = job_devices_configure(&run->job_devices, o->nodes, o->validation);
    if (r == CV_OK)
        r = cv_gateway_create(&(cv_gateway_desc){ .open_devices = job_devices_open,
                                                  .user = &run->job_devices,
                                                  .nodes = o->nodes,
                                                  .max_scene_bytes = o->max_scene_bytes,
                                                  .workers = o->jobs },
                              &run->gateway);
    if (r != CV_OK)
        return r;
    view_api_init(&run->api, &run->session, run->gateway, o->settings.width, o->settings.height);
    run->api_ready = true;
    size_t max_body = o->max_scene_bytes ? (size_t)o->max_scene_bytes : (size_t)256 << 20;
    cv_web_desc web = { .host = o->host,
                        .port = (uint16_t)o->port,
                        .token = run->token[0] ? run->token : NULL,
                        .tls_cert = o->tls_cert,
                        .tls_key = o->tls_key,
                        .max_body_bytes = max_body + 1,
                        .assets = cv_viewer_page,
                        .asset_count = cv_viewer_page_count,
                        .api = view_api_handle,
                        .api_user = &run->api,
                        .ws_open = view_session_open,
                        .ws_text = view_session_text,
                        .ws_close = view_session_close,
                        .ws_user = &run->session };
    return cv_web_server_start(&web, &run->server);
}

/* The scene of the page's jobs: the gateway's built-in room is the view's default one, a
 * model file is uploaded to the gateway's store; without one the page says why. */
static void register_job_scene(view_run *run) {
    const view_options *o = &run->o;
    if (!strcmp(o->scene, "room") && o->seed == 1) {
        view_api_register_scene(&run->api, NULL);
    } else if (!strcmp(o->scene, "room") || o->stress_triangles) {
        view_api_no_scene(&run->api,
                          "jobs render the built-in room (seed 1) or a model file; this view's scene "
                          "is another procedural one");
    } else if (view_api_register_scene(&run->api, o->scene) != CV_OK) {
        fprintf(stderr, "corvid-view: %s (the view goes on without jobs)\n", cv_last_error());
    }
}

/* The live loop over the renderer, handed to the viewers. */
static cv_result start_live(view_run *run) {
    const view_options *o = &run->o;
    cv_live_desc live = { .renderer = run->renderer,
                          .primary = run->devices[0],
                          .settings = o->settings,
                          .codec = o->codec,
                          .encode = { .quality = o->quality, .bitrate_kbps = o->bitrate_kbps },
                          .max_accumulate = o->max_accumulate,
                          .frame = view_session_frame,
                          .user = &run->session };
    cv_result r = o->trace ? cv_live_trace_create(&run->trace) : CV_OK;
    live.trace = run->trace;
    if (r == CV_OK)
        r = cv_live_start(&live, &run->live);
    if (r == CV_OK)
        view_session_attach(&run->session, run->live, run->scene);
    return r;
}

/* Until SIGINT or SIGTERM (blocked in every thread, taken here): stats four times a second. */
static void serve_until_signal(view_run *run, const sigset_t *stop) {
    const char *host = run->o.host ? run->o.host : "127.0.0.1";
    printf("corvid-view: open http%s://%s:%u/%s%s\n", run->o.tls_cert ? "s" : "", host,
           cv_web_server_port(run->server), run->token[0] ? "?token=" : "", run->token);
    fflush(stdout);
    for (;;) {
        struct timespec quarter = { .tv_sec = 0, .tv_nsec = 250 * 1000 * 1000 };
        int sig = sigtimedwait(stop, NULL, &quarter);
        if (sig == SIGINT || sig == SIGTERM)
            break;
        view_session_tick(&run->session, run->server);
    }
    if (!run->o.quiet)
        fprintf(stderr, "corvid-view: stopping\n");
}

static int finish(view_run *run, cv_result r) {
    cv_web_server_stop(run->server); /* first: no input reaches the live or the gateway any more */
    cv_gateway_destroy(run->gateway);
    if (run->api_ready)
        view_api_finish(&run->api);
    cv_live_stats st = { 0 };
    if (run->live)
        cv_live_get_stats(run->live, &st);
    cv_live_stop(run->live);
    if (r == CV_OK && run->trace) {
        r = cv_live_trace_write(run->trace, run->o.trace);
        if (r == CV_OK && !run->o.quiet)
            fprintf(stderr, "corvid-view: trace written to %s\n", run->o.trace);
    }
    cv_live_trace_destroy(run->trace);
    if (run->session_ready)
        view_session_finish(&run->session);
    cv_renderer_destroy(run->renderer);
    cv_context_destroy(run->ctx);
    cv_bvh_destroy(run->bvh);
    cv_scene_destroy(run->scene);
    if (r == CV_OK && run->live && !run->o.quiet)
        fprintf(stderr, "corvid-view: %llu frames rendered, %llu sent, %llu spoiled\n",
                (unsigned long long)st.rendered, (unsigned long long)st.presented, (unsigned long long)st.spoiled);
    if (r != CV_OK) {
        fprintf(stderr, "corvid-view: %s: %s\n", cv_result_name(r), cv_last_error());
        return 1;
    }
    return 0;
}

int main(int argc, char **argv) {
    view_run run = { 0 };
    /* Before any thread starts, so that every thread inherits the mask and only
     * serve_until_signal takes the signals. */
    sigset_t stop;
    sigemptyset(&stop);
    sigaddset(&stop, SIGINT);
    sigaddset(&stop, SIGTERM);
    pthread_sigmask(SIG_BLOCK, &stop, NULL);
    signal(SIGPIPE, SIG_IGN); /* a page that goes away is a closed connection, not a crash */
    if (cv_env_vulkan_gpu_args(&argc, argv, &run.gpu_config) != CV_OK) {
        fprintf(stderr, "corvid-view: %s (see --help)\n", cv_last_error());
        return 2;
    }
    int code = view_args_parse(argc, argv, &run.o);
    if (code)
        return code;
    if (run.o.help) {
        view_args_usage(stdout);
        return 0;
    }
    code = check_choices(&run);
    if (!code)
        code = read_environment(&run);
    if (code)
        return code;
    cv_result r = start_server(&run);
    if (r == CV_OK)
        r = load_scene(&run);
    if (r == CV_OK)
        register_job_scene(&run);
    if (r == CV_OK)
        r = create_renderer(&run);
    if (r == CV_OK)
        r = start_live(&run);
    if (r == CV_OK)
        serve_until_signal(&run, &stop);
    return finish(&run, r);
}
