/* Which cv_renderer_step goes on with the image of the steps before it: the
 * settings rule of renderer.h, from the settings table. */
#ifndef CORVID_RENDER_STEP_HISTORY_H
#define CORVID_RENDER_STEP_HISTORY_H

#include <stdbool.h>

#include "corvid/render_settings.h"

/* Whether resolved settings `next` continue the history of `history`: every
 * setting of the table equal but frames and first_frame (the observer is no
 * setting). Equal as stored: a float's -0 is not its 0. */
bool render_step_goes_on(const cv_render_settings *history, const cv_render_settings *next);

#endif
