/* Devices joining a renderer (cv_renderer_add_device: the scene, pipelines
 * and G-buffer uploaded to it) and leaving it (a secondary lost during a
 * render: the graph is rebuilt for the survivors). */
#ifndef CORVID_RENDER_DEVICE_JOIN_H
#define CORVID_RENDER_DEVICE_JOIN_H

#include "frame.h"

/* A secondary device that is gone for good (its node died or disconnected)
 * leaves: the frame graph is destroyed, to be built again for the others.
 * Returns how many devices were dropped. */
uint32_t render_devices_drop_lost(cv_render_frame *f);
/* Adds dev (checked: f's context, not yet a member, room, not lost, range)
 * from the next frame on; a device that cannot take the scene is left as it
 * was. */
cv_result render_devices_add(cv_render_frame *f, cv_device *dev);

#endif
