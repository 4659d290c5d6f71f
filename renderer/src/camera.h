/* Camera matrices for the G-buffer pass: right-handed view, Vulkan clip space
 * (y down, depth 0..1), column-major as GLSL reads a mat4; and the sun of a
 * render (the view and light controls are in render_settings.h). */
#ifndef CORVID_RENDER_CAMERA_H
#define CORVID_RENDER_CAMERA_H

#include "corvid/render_settings.h"
#include "corvid/scene.h"

/* view_proj = projection * view for an aspect ratio of width / height. */
void render_camera_view_proj(const cv_camera *camera, float aspect, float near_plane, float far_plane,
                             float view_proj[16]);

/* The unit direction the sun's light travels for settings `s` (checked):
 * the opposite of s->sun_toward when set, else `scene_sun`. */
void render_sun_direction(const cv_render_settings *s, const float scene_sun[3], float out[3]);

#endif
