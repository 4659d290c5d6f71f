/* The host-derived output planes (see output_derive.h). */
#include "output_derive.h"

#include <math.h>
#include <stdlib.h>

#define DERIVE_PI 3.14159265358979f

cv_result render_output_derive(cv_render_output *out, const float camera_position[3], const render_scene_data *data) {
    size_t n = (size_t)out->width * out->height;
    float *depth = malloc(n * sizeof(float)), *direct = calloc(n * 4, sizeof(float));
    if (!depth || !direct) {
        free(depth);
        free(direct);
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "renderer: depth and direct planes (%ux%u)", out->width, out->height);
    }
    const float *sun = data->sun_direction;
    for (size_t i = 0; i < n; i++) {
        const float *p = &out->position[i * 4];
        if (p[3] == 0.0f) {
            depth[i] = INFINITY;
            continue;
        }
        float dx = p[0] - camera_position[0], dy = p[1] - camera_position[1], dz = p[2] - camera_position[2];
        depth[i] = sqrtf(dx * dx + dy * dy + dz * dz);
        const float *nm = &out->normal[i * 4];
        float ndl = -(nm[0] * sun[0] + nm[1] * sun[1] + nm[2] * sun[2]);
        float light = data->sun_irradiance * (ndl > 0.0f ? ndl : 0.0f) * out->visibility[i * 4] / DERIVE_PI;
        for (int k = 0; k < 3; k++)
            direct[i * 4 + k] = out->albedo[i * 4 + k] * data->sun_color[k] * light;
        direct[i * 4 + 3] = 1.0f;
    }
    out->depth = depth;
    out->direct = direct;
    return CV_OK;
}
