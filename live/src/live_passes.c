/* The live's per-pass text (live_passes.h). */
#include "live_passes.h"

#include <stdio.h>

void live_passes_format(const cv_render_frame_info *info, char *out, size_t size) {
    if (size == 0)
        return;
    size_t used = 0;
    out[0] = '\0';
    uint32_t left_out = info->timings_cut;
    for (uint32_t i = 0; i < info->timing_count; i++) {
        const cv_graph_timing *t = &info->timings[i];
        char line[CV_LABEL_MAX + 48];
        int n = snprintf(line, sizeof(line), "%s dev%u %.2f ms\n", t->name, t->device, t->ms);
        if (n < 0 || (size_t)n >= size - used) {
            left_out += info->timing_count - i;
            break;
        }
        snprintf(out + used, size - used, "%s", line);
        used += (size_t)n;
    }
    char more[32];
    int n = snprintf(more, sizeof(more), "+%u more\n", left_out);
    if (left_out && n > 0 && (size_t)n < size - used)
        snprintf(out + used, size - used, "%s", more);
}
