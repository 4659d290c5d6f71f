/* A pass written from scratch and added to the renderer's frame
 * (cv_renderer_add_pass, corvid/render_pass.h), on lavapipe with validation:
 * pass 'luminance' reads the composite's radiance and writes its Rec. 709
 * luminance, grey, into a texture of the test's own (test.luminance,
 * shaders/test_luminance.comp). docs/render-graph.md, "Writing a pass", walks
 * through this file. Checks:
 *  - the view equals the luminance of the radiance read back, computed on the
 *    CPU: within 2e-6 relative (+ 1e-7 absolute: the shader may fuse the
 *    multiply-adds, C does not), alpha exactly;
 *  - the pass is in the graph after the composite (the dump);
 *  - 1 and 2 virtual GPUs give the same view and radiance bytes (the pass is
 *    PRIMARY_ONLY: the graph keeps it on the primary);
 *  - a pass without record, a second pass named 'luminance' and one named as
 *    a table pass ('composite') are refused. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "corvid/render_pass.h"
#include "corvid/renderer.h"
#include "corvid/scene_procedural.h"
#include "corvid/vulkan.h"
#include "test_render.h"

enum { W = 64, H = 40 };

/* What the pass records with: the program's pipeline and target. */
typedef struct luminance_pass {
    cv_pipeline pipeline; /* test.luminance, loaded on the primary */
    cv_texture view;      /* RGBA32F W x H, on the primary */
} luminance_pass;

/* The pass's uses: one slot each. */
enum { USE_RADIANCE, USE_VIEW };

/* The composite writes the radiance on the last frame only. */
static bool on_last_frame(const cv_render_frame *f) { return cv_render_frame_get_view(f)->last; }

static cv_result declare(const cv_render_frame *f, cv_graph_builder *b, cv_graph_use *uses, void *user) {
    luminance_pass *p = user;
    cv_graph *g = cv_render_frame_graph(f);
    cv_graph_resource view;
    cv_result res = cv_graph_import_texture(g, p->view, &view);
    if (res == CV_OK) /* the program reads it after the render: an output, not culled */
        res = cv_graph_output(g, view);
    uses[USE_RADIANCE] = cv_graph_pass_read(b, cv_render_frame_target(f, CV_RENDER_TARGET_RADIANCE),
                                            CV_GRAPH_STORAGE_READ);
    uses[USE_VIEW] = cv_graph_pass_write(b, view, CV_GRAPH_STORAGE_WRITE, CV_GRAPH_TRANSFER_AUTO);
    return res;
}

static void record(const cv_render_frame *f, const cv_graph_pass_context *pc, cv_command_list *l,
                   const cv_graph_use *uses, void *user) {
    const luminance_pass *p = user;
    const cv_render_frame_view *v = cv_render_frame_get_view(f);
    struct {
        uint32_t width, height;
    } push = { v->width, v->height };
    cv_binding b[2] = { cv_graph_use_binding(pc, uses[USE_RADIANCE]), cv_graph_use_binding(pc, uses[USE_VIEW]) };
    cv_cmd_dispatch(l, pc->queue,
                    &(cv_dispatch_args){ .pipeline = p->pipeline,
                                         .bindings = b,
                                         .bindings_count = 2,
                                         .push = &push,
                                         .push_size = sizeof(push),
                                         .groups_x = (v->width + 7) / 8,
                                         .groups_y = (v->height + 7) / 8,
                                         .groups_z = 1 });
}

static const cv_render_pass_module luminance_module = { .name = "luminance",
                                                        .queue = CV_QUEUE_COMPUTE,
                                                        .policy = CV_MGPU_PRIMARY_ONLY,
                                                        .enabled = on_last_frame,
                                                        .declare = declare,
                                                        .record = record };

/* Renders on the first `gpus` devices of g with the pass added; fills the
 * radiance and the view (W * H * 4 floats each). */
static void render_with_pass(const cv_test_gpus *g, uint32_t gpus, const cv_scene *scene, const cv_bvh *bvh,
                             float *radiance, float *view) {
    luminance_pass p = { 0 };
    cv_texture_desc desc = { .width = W,
                             .height = H,
                             .format = CV_FORMAT_RGBA32F,
                             .usage = CV_TEXTURE_USAGE_STORAGE,
                             .label = "luminance view" };
    CHECK_OK(cv_pipeline_create(g->ctx, "test.luminance", &p.pipeline));
    CHECK_OK(cv_device_load(g->devices[0], cv_any(p.pipeline)));
    CHECK_OK(cv_texture_create(g->ctx, &desc, &p.view));
    CHECK_OK(cv_device_load(g->devices[0], cv_any(p.view)));
    cv_renderer *r = NULL;
    CHECK_OK(cv_renderer_create(g->devices, gpus, scene, bvh, &r));
    CHECK_OK(cv_renderer_add_pass(r, &luminance_module, &p));
    cv_render_output out = { 0 };
    cv_render_settings s = { .width = W, .height = H, .frames = 2 };
    CHECK_OK(cv_renderer_render(r, &s, &out, NULL, NULL, NULL));
    if (out.radiance)
        memcpy(radiance, out.radiance, sizeof(float) * W * H * 4);
    CHECK_OK(cv_device_read_texture(g->devices[0], p.view, (cv_rect){ 0, 0, W, H }, view));
    char *dump = NULL;
    size_t dump_size = 0;
    FILE *text = open_memstream(&dump, &dump_size);
    CHECK_OK(cv_renderer_dump_graph(r, text, NULL));
    fclose(text);
    const char *composite = strstr(dump, "pass 'composite'"), *luminance = strstr(dump, "pass 'luminance'");
    CHECK(composite && luminance && luminance > composite);
    free(dump);
    cv_render_output_free(&out);
    cv_renderer_destroy(r);
    cv_destroy(g->ctx, cv_any(p.view));
    cv_destroy(g->ctx, cv_any(p.pipeline));
}

/* The view against the luminance of the radiance on the CPU. */
static void check_view(const float *radiance, const float *view) {
    uint32_t lit = 0, off = 0;
    double worst = 0.0;
    for (uint32_t i = 0; i < W * H; i++) {
        const float *c = &radiance[i * 4], *v = &view[i * 4];
        float l = 0.2126f * c[0] + 0.7152f * c[1] + 0.0722f * c[2];
        float tolerance = 2e-6f * fabsf(l) + 1e-7f;
        for (int k = 0; k < 3; k++) {
            double e = fabs((double)v[k] - l);
            worst = e > worst ? e : worst;
            off += e > tolerance;
        }
        off += v[3] != c[3];
        lit += l > 0.01f;
    }
    fprintf(stderr, "luminance: %u of %u pixels lit, largest difference %.3g\n", lit, W * H, worst);
    CHECK(lit > W * H / 2); /* the room fills most of the frame */
    CHECK_EQ_INT(off, 0);
}

static void check_refused(const cv_test_gpus *g, const cv_scene *scene, const cv_bvh *bvh) {
    cv_renderer *r = NULL;
    CHECK_OK(cv_renderer_create(g->devices, 1, scene, bvh, &r));
    cv_render_pass_module no_record = luminance_module, composite = luminance_module;
    no_record.record = NULL;
    composite.name = "composite";
    CHECK_RESULT(cv_renderer_add_pass(r, &no_record, NULL), CV_ERROR_INVALID_ARGUMENT);
    CHECK_RESULT(cv_renderer_add_pass(r, &composite, NULL), CV_ERROR_ALREADY_EXISTS);
    CHECK_OK(cv_renderer_add_pass(r, &luminance_module, NULL));
    CHECK_RESULT(cv_renderer_add_pass(r, &luminance_module, NULL), CV_ERROR_ALREADY_EXISTS);
    cv_renderer_destroy(r);
}

int main(void) {
    cv_test_gpus g;
    CHECK_OK(cv_test_gpus_open(2, &g));
    cv_scene *scene = NULL;
    cv_bvh *bvh = NULL;
    CHECK_OK(cv_scene_make_room(1, &scene));
    if (scene)
        CHECK_OK(cv_bvh_build_flat(scene, NULL, &bvh));
    float *radiance[2], *view[2];
    for (int k = 0; k < 2; k++) {
        radiance[k] = calloc(W * H * 4, sizeof(float));
        view[k] = calloc(W * H * 4, sizeof(float));
    }
    if (g.count && bvh) {
        for (uint32_t gpus = 1; gpus <= 2; gpus++) {
            render_with_pass(&g, gpus, scene, bvh, radiance[gpus - 1], view[gpus - 1]);
            check_view(radiance[gpus - 1], view[gpus - 1]);
        }
        CHECK(memcmp(radiance[0], radiance[1], sizeof(float) * W * H * 4) == 0);
        CHECK(memcmp(view[0], view[1], sizeof(float) * W * H * 4) == 0);
        check_refused(&g, scene, bvh);
    }
    for (int k = 0; k < 2; k++) {
        free(radiance[k]);
        free(view[k]);
    }
    cv_test_gpus_close(&g);
    CHECK_EQ_INT(cv_vulkan_validation_message_count(), 0);
    cv_bvh_destroy(bvh);
    cv_scene_destroy(scene);
    CHECK_NOTHING_LIVE();
    return check_report("renderer custom pass");
}
