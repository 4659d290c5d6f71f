/* The steps' history rule (step_history.h), row by row of the settings table,
 * so that a setting added to the table restarts the image when it changes. */
#include "step_history.h"

#include <string.h>

bool render_step_goes_on(const cv_render_settings *history, const cv_render_settings *next) {
    for (int i = 0; i < CV_RENDER_SETTING_COUNT; i++) {
        const cv_render_setting *row = &cv_render_setting_rows[i];
        if (i == CV_RENDER_SETTING_frames || i == CV_RENDER_SETTING_first_frame)
            continue;
        size_t size = row->kind == CV_SETTING_VEC3 ? 3 * sizeof(float) : sizeof(uint32_t);
        if (memcmp((const char *)history + row->offset, (const char *)next + row->offset, size) != 0)
            return false;
    }
    return true;
}
