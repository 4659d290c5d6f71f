/* Camera matrices for the G-buffer pass: right-handed view, Vulkan clip space
 * (y down, depth 0..1), column-major as GLSL reads a mat4. */
#ifndef CORVID_RENDER_CAMERA_H
#define CORVID_RENDER_CAMERA_H

#include "corvid/scene.h"

/* view_proj = projection * view for an aspect ratio of width / height. */
void render_camera_view_proj(const cv_camera *camera, float aspect, float near_plane, float far_plane,
                             float view_proj[16]);

#endif
