/* The frame graph: the renderer's textures and scene buffers imported, then
 * every pass module present declared in table order, each making its own
 * transients (frame_graph.h). */
#include "frame_graph.h"

#include <string.h>

#include "passes/passes.h"

#define RENDER_PASS_ENTRY(name) &render_pass_##name,
static const cv_render_pass_module *const table[] = { CV_RENDER_PASS_TABLE(RENDER_PASS_ENTRY) };
#undef RENDER_PASS_ENTRY

void render_graph_destroy(cv_render_frame *f) {
    cv_graph_destroy(f->graph);
    f->graph = NULL;
    f->graph_prebaked = false;
}

/* The renderer's textures and the scene buffers into the graph (the passes
 * make their own transients). */
static cv_result add_resources(cv_render_frame *f) {
    cv_graph *g = f->graph;
    cv_result res = CV_OK;
    for (int t = 0; t < TEX_COUNT && res == CV_OK; t++)
        res = cv_graph_import_texture(g, f->textures[t], &f->tex[t]);
    const struct {
        cv_buffer buffer;
        int slot;
    } imports[7] = { { f->vertices, BUF_VERTICES },       { f->materials, BUF_MATERIALS },
                     { f->lights, BUF_LIGHTS },           { f->uvs, BUF_UVS },
                     { f->image_table, BUF_IMAGE_TABLE }, { f->image_pool, BUF_IMAGE_POOL },
                     { f->blue_noise, BUF_BLUE_NOISE } };
    for (int i = 0; i < 7 && res == CV_OK; i++)
        res = cv_graph_import_buffer(g, imports[i].buffer, 0, &f->buf[imports[i].slot]);
    if (res == CV_OK && (f->info.reflections || f->alpha_mask))
        res = cv_graph_import_buffer(g, f->instances, 0, &f->buf[BUF_INSTANCES]);
    return res;
}

/* The graph calls each pass's record through its slot. */
static void record_slot(const cv_graph_pass_context *pc, cv_command_list *l, void *user) {
    const render_pass_slot *slot = user;
    slot->module->record(slot->frame, pc, l, slot->uses, slot->user);
}

static cv_result declare_pass(cv_render_frame *f, const cv_render_pass_module *m, void *user) {
    render_pass_slot *slot = &f->slots[f->slot_count++];
    *slot = (render_pass_slot){ .module = m, .user = user, .frame = f };
    if (m->present && !m->present(f))
        return CV_OK;
    cv_graph_builder *b = cv_graph_pass_begin(f->graph, &(cv_graph_pass_desc){ m->name, m->queue, m->policy,
                                                                               record_slot, slot });
    cv_result res = m->declare(f, b, slot->uses, user);
    cv_result end = cv_graph_pass_end(b, &slot->pass);
    return res != CV_OK ? res : end;
}

/* What every frame carries to the next (the accumulations), and what the
 * last frame leaves for readback (the planes, the display images): outputs,
 * so the passes writing them are kept on frames without the composite. */
static cv_result add_outputs(cv_render_frame *f) {
    bool moving = f->info.moving, reflect = f->info.reflections;
    const struct {
        int texture;
        bool wanted;
    } outputs[11 + RENDER_DISPLAY_SLOTS] = { { TEX_HISTORY, true },
                                             { TEX_HISTORY_POSITION, moving },
                                             { TEX_HISTORY_NORMAL, moving },
                                             { TEX_MOTION, moving },
                                             { TEX_REFLECT_HISTORY, reflect },
                                             { TEX_REFLECT_OWN, reflect },
                                             { TEX_REFLECT_OUT, reflect },
                                             { render_reflect_shown_texture(), reflect },
                                             { TEX_REFLECT_STATE, reflect && moving },
                                             { TEX_RADIANCE, true },
                                             { TEX_ALBEDO, true },
                                             { TEX_DISPLAY, true },
                                             { TEX_DISPLAY + 1, true },
                                             { TEX_DISPLAY + 2, true } };
    cv_result res = CV_OK;
    for (size_t i = 0; i < sizeof(outputs) / sizeof(outputs[0]) && res == CV_OK; i++)
        if (outputs[i].wanted)
            res = cv_graph_output(f->graph, f->tex[outputs[i].texture]);
    return res;
}

static cv_result build(cv_render_frame *f, uint64_t rays, uint64_t reflect_rays) {
    for (uint32_t d = 0; d < f->count; d++)
        if (rays * CV_RAY_BYTES > cv_device_get_info(f->devices[d])->max_storage_buffer_range)
            return cv_error(CV_ERROR_LIMIT_EXCEEDED,
                            "renderer: %llu rays (%llu bytes) exceed device '%s''s storage "
                            "buffer range; use fewer AO samples, a smaller image or more devices",
                            (unsigned long long)rays, (unsigned long long)(rays * CV_RAY_BYTES),
                            cv_device_label(f->devices[d]));
    cv_result res = cv_graph_create(f->ctx, f->devices, f->count, &f->graph);
    if (res != CV_OK)
        return res;
    f->graph_generation++;
    f->graph_rays = rays;
    f->graph_reflect_rays = reflect_rays;
    memset(f->tex, 0, sizeof(f->tex));
    memset(f->buf, 0, sizeof(f->buf));
    f->slot_count = 0;
    res = add_resources(f);
    for (size_t i = 0; i < sizeof(table) / sizeof(table[0]) && res == CV_OK; i++)
        res = declare_pass(f, table[i], NULL);
    for (uint32_t i = 0; i < f->extra_count && res == CV_OK; i++)
        res = declare_pass(f, f->extra[i].module, f->extra[i].user);
    if (res == CV_OK)
        res = add_outputs(f);
    if (res != CV_OK)
        render_graph_destroy(f);
    return res;
}

cv_result render_graph_build(cv_render_frame *f, uint64_t rays) {
    const cv_render_settings *s = &f->settings;
    f->info.settings = s;
    f->info.width = f->width;
    f->info.height = f->height;
    cv_render_frame_view shape = f->info;
    shape.moving = s->orbit_degrees != 0.0f;
    shape.reflections = s->reflections == 1;
    shape.filter_iterations = (uint32_t)s->filter_iterations;
    uint64_t reflect_rays = render_reflect_capacity(f, s);
    if (f->graph && f->info.filter_iterations == shape.filter_iterations && f->graph_rays == rays &&
        f->info.moving == shape.moving && f->info.reflections == shape.reflections &&
        f->graph_reflect_rays == reflect_rays)
        return CV_OK;
    render_graph_destroy(f);
    f->info = shape;
    return build(f, rays, reflect_rays);
}

cv_result render_graph_rebuild(cv_render_frame *f) {
    render_graph_destroy(f);
    return build(f, f->graph_rays, f->graph_reflect_rays);
}

cv_graph_bake_desc render_graph_bake_desc(const cv_render_frame *f, const cv_partition *part) {
    const cv_render_settings *s = &f->settings;
    return (cv_graph_bake_desc){ .width = part ? part->width : f->width,
                                 .tile = part ? part->tile : s->tile,
                                 .partition = part,
                                 .zero_copy = (cv_graph_zero_copy)s->zero_copy,
                                 .sync_transfers = s->sync_transfers != 0 };
}

cv_result render_graph_enable_passes(cv_render_frame *f) {
    cv_result res = CV_OK;
    for (uint32_t i = 0; i < f->slot_count && res == CV_OK; i++) {
        const render_pass_slot *slot = &f->slots[i];
        if (slot->pass.id && slot->module->enabled)
            res = cv_graph_enable_pass(f->graph, slot->pass, slot->module->enabled(f));
    }
    return res;
}

cv_result render_graph_dump(cv_render_frame *f, FILE *text, FILE *dot) {
    cv_partition part;
    cv_result res = cv_graph_get_partition(f->graph, &part);
    if (res != CV_OK)
        return res;
    cv_render_frame_view frame = f->info;
    f->info.first = f->info.last = true;
    res = render_graph_enable_passes(f);
    f->info = frame;
    cv_graph_bake_desc bake = render_graph_bake_desc(f, &part);
    if (res == CV_OK)
        res = cv_graph_bake(f->graph, &bake);
    if (res == CV_OK && text)
        res = cv_graph_dump_text(f->graph, text);
    if (res == CV_OK && dot)
        res = cv_graph_dump_dot(f->graph, dot);
    return res;
}

cv_result render_graph_add_pass(cv_render_frame *f, const cv_render_pass_module *m, void *user) {
    if (!m || !m->name || !m->declare || !m->record)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "renderer: add pass: a module needs a name, declare and record");
    if (f->extra_count == RENDER_MAX_EXTRA_PASSES)
        return cv_error(CV_ERROR_LIMIT_EXCEEDED, "renderer: add pass '%s': %u passes added already (at most %u)",
                        m->name, f->extra_count, RENDER_MAX_EXTRA_PASSES);
    for (size_t i = 0; i < sizeof(table) / sizeof(table[0]); i++)
        if (strcmp(table[i]->name, m->name) == 0)
            return cv_error(CV_ERROR_ALREADY_EXISTS, "renderer: add pass '%s': the frame has a pass of that name",
                            m->name);
    for (uint32_t i = 0; i < f->extra_count; i++)
        if (strcmp(f->extra[i].module->name, m->name) == 0)
            return cv_error(CV_ERROR_ALREADY_EXISTS, "renderer: add pass '%s': added already", m->name);
    f->extra[f->extra_count].module = m;
    f->extra[f->extra_count].user = user;
    f->extra_count++;
    render_graph_destroy(f); /* the next render builds it with the pass */
    return CV_OK;
}
