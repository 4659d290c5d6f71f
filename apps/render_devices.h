/* corvid-render's devices: the Vulkan adapters it lists, the devices of the
 * corvid-nodes it renders on (--nodes), and, between frames, a lost node
 * device tried again until its node answers. */
#ifndef CORVID_APPS_RENDER_DEVICES_H
#define CORVID_APPS_RENDER_DEVICES_H

#include <stdbool.h>
#include <stdint.h>

#include "corvid/renderer.h"

/* --list-adapters: prints them; the exit code. */
int render_list_adapters(void);

/* One proxy device per device of every node of `list` that answers. A node that cannot be reached at start
 * is named and left out (a render on the others beats none); one that answers with an error (a wrong token,
 * a protocol it does not speak) fails the render, as does no node answering at all. */
cv_result render_node_devices(cv_context *ctx, const char *list, cv_device **devices, uint32_t *count, bool quiet);

/* --nodes: a node device that was lost is tried again between frames (render_devices.c: a few times, some
 * seconds apart): once its node answers, a new device for it joins the renderer from the next frame
 * (cv_renderer_add_device), with a log line either way. */
typedef struct render_progress {
    bool quiet;
    cv_renderer *renderer;
    cv_context *ctx;
    cv_device **devices; /* a lost one is replaced by its rejoined device */
    uint32_t count;
    const char *nodes; /* the --nodes list; devices are labelled node<i>.gpu<j> (render_node_devices) */
    uint32_t tries[CV_MAX_DEVICES];
    double last_try[CV_MAX_DEVICES];
} render_progress;

/* The renderer's progress callback (user: a render_progress): the frame counter, and lost node devices
 * tried again. */
void render_progress_report(uint32_t frame, uint32_t frames, void *user);

#endif
