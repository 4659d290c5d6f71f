/* Camera matrices (see camera.h). */
#include "camera.h"

#include <math.h>
#include <string.h>

static void normalize3(float v[3]) {
    float l = sqrtf(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    if (l > 0.0f)
        for (int i = 0; i < 3; i++)
            v[i] /= l;
}

static void cross3(const float a[3], const float b[3], float out[3]) {
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}

static float dot3(const float a[3], const float b[3]) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

/* m[col * 4 + row] */
static void multiply(const float a[16], const float b[16], float out[16]) {
    float r[16];
    for (int c = 0; c < 4; c++)
        for (int row = 0; row < 4; row++) {
            float s = 0.0f;
            for (int k = 0; k < 4; k++)
                s += a[k * 4 + row] * b[c * 4 + k];
            r[c * 4 + row] = s;
        }
    memcpy(out, r, sizeof(r));
}

void render_camera_view_proj(const cv_camera *camera, float aspect, float near_plane, float far_plane,
                             float view_proj[16]) {
    float f[3] = { camera->target[0] - camera->position[0], camera->target[1] - camera->position[1],
                   camera->target[2] - camera->position[2] };
    normalize3(f);
    float s[3], u[3];
    cross3(f, camera->up, s);
    normalize3(s);
    cross3(s, f, u);
    const float *e = camera->position;
    float view[16] = {
        s[0], u[0], -f[0], 0, s[1], u[1], -f[1], 0, s[2], u[2], -f[2], 0, -dot3(s, e), -dot3(u, e), dot3(f, e), 1,
    };
    float t = 1.0f / tanf(camera->vertical_fov * 0.5f);
    float range = far_plane - near_plane;
    /* Vulkan: clip y points down, depth maps [near, far] to [0, 1]. */
    float proj[16] = {
        t / aspect, 0, 0, 0, 0, -t, 0, 0, 0, 0, -far_plane / range, -1, 0, 0, -far_plane * near_plane / range, 0,
    };
    multiply(proj, view, view_proj);
}
