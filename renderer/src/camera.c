/* Camera matrices, the camera and sun that cv_render_settings' view and light
 * controls pick, and the orbiting camera (see camera.h and render_settings.h). */
#include "camera.h"

#include <math.h>
#include <string.h>

#include "corvid/render_settings.h"

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

cv_result cv_render_camera_check(const cv_render_settings *s, const cv_scene *scene) {
    if (s->camera_fov_degrees > 0.0f)
        return CV_OK; /* cv_render_settings_check's range */
    cv_camera c = cv_render_camera(s, scene, s->first_frame);
    double degrees = (double)c.vertical_fov * (180.0 / 3.14159265358979);
    /* A file's camera of exactly the limit, rounded to radians in float, passes. */
    if (degrees > CV_RENDER_MAX_FOV_DEGREES * (1.0 + 1e-6))
        return cv_error(CV_ERROR_OUT_OF_RANGE,
                        "renderer: the scene's camera %u has a vertical fov of %g degrees, over the limit of %g (the "
                        "near plane would cut what the image's edges see): set a camera with --camera",
                        s->camera, degrees, (double)CV_RENDER_MAX_FOV_DEGREES);
    return CV_OK;
}

/* v turned by `radians` about the unit axis a (Rodrigues). */
static void rotate(const float v[3], const float a[3], float radians, float out[3]) {
    float c = cosf(radians), s = sinf(radians), k = dot3(a, v) * (1.0f - c), x[3];
    cross3(a, v, x);
    for (int i = 0; i < 3; i++)
        out[i] = v[i] * c + x[i] * s + a[i] * k;
}

cv_camera cv_render_camera(const cv_render_settings *s, const cv_scene *scene, uint32_t frame) {
    cv_camera cam;
    if (s->camera_fov_degrees > 0.0f) {
        cam = (cv_camera){ .vertical_fov = s->camera_fov_degrees * 3.14159265f / 180.0f, .up = { 0.0f, 1.0f, 0.0f } };
        memcpy(cam.position, s->camera_eye, sizeof(cam.position));
        memcpy(cam.target, s->camera_target, sizeof(cam.target));
        float f[3] = { cam.target[0] - cam.position[0], cam.target[1] - cam.position[1],
                       cam.target[2] - cam.position[2] };
        normalize3(f);
        if (fabsf(f[1]) > 0.999f) /* straight up or down: +y is no up */
            cam.up[1] = 0.0f, cam.up[2] = 1.0f;
    } else {
        cam = s->camera < cv_scene_camera_count(scene) ? *cv_scene_camera(scene, s->camera)
                                                       : cv_scene_framing_camera(scene);
    }
    if (s->orbit_degrees != 0.0f && frame != 0) {
        /* In double: frame * degrees is exact enough for thousands of frames. */
        float angle = (float)fmod((double)s->orbit_degrees * frame, 360.0) * 3.14159265f / 180.0f;
        float axis[3] = { cam.up[0], cam.up[1], cam.up[2] };
        normalize3(axis);
        float rel[3] = { cam.position[0] - cam.target[0], cam.position[1] - cam.target[1],
                         cam.position[2] - cam.target[2] },
              turned[3];
        rotate(rel, axis, angle, turned);
        for (int i = 0; i < 3; i++)
            cam.position[i] = cam.target[i] + turned[i];
    }
    return cam;
}

void render_sun_direction(const cv_render_settings *s, const float scene_sun[3], float out[3]) {
    const float *d = s->sun_toward;
    if (d[0] == 0.0f && d[1] == 0.0f && d[2] == 0.0f) {
        memmove(out, scene_sun, 3 * sizeof(float)); /* out may be scene_sun */
        return;
    }
    for (int i = 0; i < 3; i++)
        out[i] = -d[i];
    normalize3(out);
}
