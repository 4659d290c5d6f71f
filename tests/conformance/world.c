/* The conformance world (see world.h). */
#include "world.h"

#include <string.h>

#include "check.h"

static cv_result make_buffer(world *w, uint64_t size, uint32_t usage, const char *label, cv_buffer *out) {
    cv_buffer_desc d = { .size = size, .usage = usage };
    strncpy(d.label, label, sizeof(d.label) - 1);
    cv_result r = cv_buffer_create(w->ctx, &d, out);
    return r == CV_OK ? cv_device_load(w->dev, cv_any(*out)) : r;
}

static cv_result make_texture(world *w, cv_format f, uint32_t usage, const char *label, cv_texture *out) {
    cv_texture_desc d = { .width = 16, .height = 16, .format = f, .usage = usage };
    strncpy(d.label, label, sizeof(d.label) - 1);
    cv_result r = cv_texture_create(w->ctx, &d, out);
    return r == CV_OK ? cv_device_load(w->dev, cv_any(*out)) : r;
}

static cv_result make_pipeline(world *w, const char *name, cv_pipeline *out) {
    cv_result r = cv_pipeline_create(w->ctx, name, out);
    return r == CV_OK ? cv_device_load(w->dev, cv_any(*out)) : r;
}

/* A flat BVH of one triangle in the layout of client/include/corvid/bvh_gpu.h:
 * one two-child node whose first child is a leaf of triangle 0. */
static cv_result make_accel(world *w, bool write, const char *label, cv_accel *out) {
    cv_accel_desc d = { .triangle_count = 1, .node_count = 1 };
    strncpy(d.label, label, sizeof(d.label) - 1);
    cv_result r = cv_accel_create(w->ctx, &d, out);
    if (r == CV_OK)
        r = cv_device_load(w->dev, cv_any(*out));
    if (r != CV_OK || !write)
        return r;
    const float node[16] = { 0, 0, 0, 0, 1, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0 };
    uint32_t links[16];
    memcpy(links, node, sizeof(node));
    links[3] = 0x80000000u;                                       /* a_link: leaf, first triangle 0 */
    links[7] = 1;                                                 /* a_count */
    const float tri[12] = { 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0 }; /* v0, e1, e2 with ids 0 */
    return cv_device_write_accel(w->dev, *out, links, tri);
}

cv_result world_init(world *w, const fixture *fx) {
    memset(w, 0, sizeof(*w));
    w->fx = fx;
    cv_result r = cv_context_create(NULL, &w->ctx);
    if (r == CV_OK)
        r = fixture_device(fx, w->ctx, 0, &w->dev);
    const uint32_t color = CV_TEXTURE_USAGE_SAMPLED | CV_TEXTURE_USAGE_STORAGE | CV_TEXTURE_USAGE_COLOR_TARGET;
    if (r == CV_OK)
        r = make_buffer(w, 256, CV_BUFFER_USAGE_STORAGE, "small", &w->small);
    if (r == CV_OK)
        r = make_buffer(w, 65536, CV_BUFFER_USAGE_ALL, "big", &w->big);
    if (r == CV_OK)
        r = make_buffer(w, 1024, CV_BUFFER_USAGE_UNIFORM, "plain", &w->plain);
    if (r == CV_OK)
        r = make_texture(w, CV_FORMAT_RGBA8_UNORM, color, "rgba8", &w->rgba8);
    if (r == CV_OK)
        r = make_texture(w, CV_FORMAT_RGBA8_UNORM, color, "rgba8_b", &w->rgba8_b);
    if (r == CV_OK)
        r = make_texture(w, CV_FORMAT_RGBA32F, 0, "rgba32f", &w->rgba32f);
    if (r == CV_OK)
        r = make_texture(w, CV_FORMAT_RGBA8_UNORM, CV_TEXTURE_USAGE_SAMPLED, "sampled", &w->sampled);
    if (r == CV_OK)
        r = make_texture(w, CV_FORMAT_D32F, 0, "depth", &w->depth);
    if (r == CV_OK)
        r = cv_sampler_create(w->ctx, &(cv_sampler_desc){ .filter = CV_FILTER_NEAREST }, &w->sampler);
    if (r == CV_OK)
        r = cv_device_load(w->dev, cv_any(w->sampler));
    if (r == CV_OK)
        r = make_pipeline(w, "test.fill_u32", &w->fill);
    if (r == CV_OK)
        r = make_pipeline(w, "test.saxpy", &w->saxpy);
    if (r == CV_OK)
        r = make_pipeline(w, "test.gradient", &w->gradient);
    if (r == CV_OK)
        r = make_pipeline(w, "test.sample_copy", &w->sample_copy);
    if (r == CV_OK)
        r = make_pipeline(w, "test.triangle", &w->triangle);
    if (r == CV_OK)
        r = make_accel(w, true, "one triangle", &w->accel);
    if (r == CV_OK)
        r = make_accel(w, false, "unbuilt", &w->accel_unbuilt);
    if (r == CV_OK)
        r = cv_buffer_create(w->ctx, &(cv_buffer_desc){ .size = 256, .label = "unloaded" }, &w->unloaded);
    if (r == CV_OK)
        r = make_buffer(w, 256, 0, "destroyed", &w->destroyed);
    if (r == CV_OK)
        r = cv_buffer_destroy(w->ctx, w->destroyed);
    if (r == CV_OK)
        r = cv_cmdlist_create(w->ctx, &w->list);
    return r;
}

void world_finish(world *w) {
    const fixture *fx = w->fx;
    cv_context_destroy(w->ctx); /* destroys the device and every handle */
    memset(w, 0, sizeof(*w));
    fixture_settle(fx);
    CHECK_NOTHING_LIVE();
}

cv_command_list *world_begin(world *w) {
    cv_command_list *l = NULL;
    cv_cmdlist_begin(w->ctx, w->list, &l);
    return l;
}

cv_result world_end_and_run(world *w) {
    cv_command_list *l = NULL;
    cv_result r = cv_cmdlist_get(w->ctx, w->list, &l);
    if (r == CV_OK)
        r = cv_command_list_end(l);
    uint64_t ticket = 0;
    if (r == CV_OK)
        r = cv_device_submit(w->dev, w->list, &ticket);
    if (r == CV_OK)
        r = cv_device_wait(w->dev, ticket, UINT64_MAX);
    return r;
}
