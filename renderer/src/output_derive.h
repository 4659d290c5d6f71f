/* Output planes derived on the host from the ones the GPU (or the CPU
 * reference) wrote, so both paths give them alike:
 *   depth:  distance from the camera's position to the G-buffer position
 *           (camera distance along the pixel's ray, not view-plane depth), one
 *           float per pixel; +infinity where the pixel sees sky;
 *   direct: the composite's direct sun light, RGBA: albedo * sun colour * sun
 *           irradiance * max(N.L, 0) * sun visibility / pi (render.composite's
 *           `albedo * direct` term, with the output's filtered visibility);
 *           alpha 1 on geometry; 0 everywhere on sky. */
#ifndef CORVID_RENDER_OUTPUT_DERIVE_H
#define CORVID_RENDER_OUTPUT_DERIVE_H

#include "corvid/render_output.h"
#include "scene_upload.h"

/* Allocates and fills out->depth and out->direct from out->position,
 * normal, albedo and visibility. On failure (no memory) both stay NULL. */
cv_result render_output_derive(cv_render_output *out, const float camera_position[3], const render_scene_data *data);

#endif
