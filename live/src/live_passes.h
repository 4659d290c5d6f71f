/* The live's "ms per pass per device" text: one line per pass instance and
 * transfer of a frame, from the renderer's observer report
 * (corvid/render_observer.h), as cv_live_stats.passes holds it. */
#ifndef CORVID_LIVE_PASSES_H
#define CORVID_LIVE_PASSES_H

#include <stddef.h>

#include "corvid/render_observer.h"

/* "gbuffer dev0 1.20 ms\ntrace dev1 3.40 ms\n..." into out (size bytes, NUL
 * included); from the first line that does not fit on, lines are left out
 * whole, and a last line says how many ("+3 more\n") when it fits. */
void live_passes_format(const cv_render_frame_info *info, char *out, size_t size);

#endif
