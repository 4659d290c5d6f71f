/* Pass 'accumulate' (primary, every frame): this frame's visibility into the
 * running mean; for a moving camera, into the reprojected history, keeping
 * this frame's G-buffer beside it (render_accumulate.comp). The accumulation
 * carries over from frame to frame (a graph output), so the pass is kept on
 * frames without the composite. */
#include "passes.h"

enum {
    USE_VISIBILITY,
    USE_HISTORY,
    USE_HISTORY_WRITE,
    USE_MOTION, /* moving camera */
    USE_REPROJECTED,
    USE_POSITION,
    USE_NORMAL,
    USE_HISTORY_POSITION,
    USE_HISTORY_NORMAL,
};

static cv_result declare(const cv_render_frame *f, cv_graph_builder *b, cv_graph_use *u, void *user) {
    (void)user;
    u[USE_VISIBILITY] = cv_graph_pass_read(b, f->tex[TEX_VISIBILITY], CV_GRAPH_STORAGE_READ);
    u[USE_HISTORY] = cv_graph_pass_read(b, f->tex[TEX_HISTORY], CV_GRAPH_STORAGE_READ);
    u[USE_HISTORY_WRITE] = cv_graph_pass_write(b, f->tex[TEX_HISTORY], CV_GRAPH_STORAGE_WRITE,
                                               CV_GRAPH_TRANSFER_AUTO);
    if (f->info.moving) {
        static const int reads[4] = { TEX_MOTION, TEX_REPROJECTED, TEX_POSITION, TEX_NORMAL };
        for (int i = 0; i < 4; i++)
            u[USE_MOTION + i] = cv_graph_pass_read(b, f->tex[reads[i]], CV_GRAPH_STORAGE_READ);
        u[USE_HISTORY_POSITION] = cv_graph_pass_write(b, f->tex[TEX_HISTORY_POSITION], CV_GRAPH_STORAGE_WRITE,
                                                      CV_GRAPH_TRANSFER_AUTO);
        u[USE_HISTORY_NORMAL] = cv_graph_pass_write(b, f->tex[TEX_HISTORY_NORMAL], CV_GRAPH_STORAGE_WRITE,
                                                    CV_GRAPH_TRANSFER_AUTO);
    }
    return CV_OK;
}

/* A still camera's pass reads and writes only the visibility and the
 * history: the slots it does not use get the history again. */
static void record(const cv_render_frame *f, const cv_graph_pass_context *pc, cv_command_list *l,
                   const cv_graph_use *u, void *user) {
    (void)user;
    bool moving = f->info.moving;
    struct {
        uint32_t width, height, frame, flags;
    } push = { f->width, f->height, f->info.frame, moving ? 1u : 0u };
    static const int slots[8] = { USE_VISIBILITY, USE_HISTORY, USE_MOTION,           USE_REPROJECTED,
                                  USE_POSITION,   USE_NORMAL,  USE_HISTORY_POSITION, USE_HISTORY_NORMAL };
    cv_binding b[8];
    for (int i = 0; i < 8; i++)
        b[i] = cv_graph_use_binding(pc, u[moving || i < 2 ? slots[i] : USE_HISTORY]);
    render_dispatch_image(f, l, pc->queue, PIPE_ACCUMULATE, b, 8, &push, sizeof(push));
}

const cv_render_pass_module render_pass_accumulate = { .name = "accumulate",
                                                       .queue = CV_QUEUE_COMPUTE,
                                                       .policy = CV_MGPU_PRIMARY_ONLY,
                                                       .declare = declare,
                                                       .record = record };
