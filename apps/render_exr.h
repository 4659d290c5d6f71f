/* corvid-render's EXR: the beauty and one layer per pass / AOV of a
 * cv_render_output (layer names and channels in README.md, "Outputs"). */
#ifndef CORVID_APPS_RENDER_EXR_H
#define CORVID_APPS_RENDER_EXR_H

#include "corvid/renderer.h"

/* Writes every plane of `img` that is not NULL as its layer(s) to `path`. */
cv_result render_exr_write(const char *path, const cv_render_output *img);

#endif
