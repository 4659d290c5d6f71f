/* The frame's result read back from the primary into a cv_render_output:
 * the composite's planes, the G-buffer, the filtered visibility, motion and
 * reflection, and the planes derived on the host (output_derive.h). */
#ifndef CORVID_RENDER_READBACK_H
#define CORVID_RENDER_READBACK_H

#include "frame.h"

/* Fills *out after a render of `frames` frames; on failure *out is empty. */
cv_result render_read_output(const cv_render_frame *f, uint32_t frames, cv_render_output *out);

#endif
