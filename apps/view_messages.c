/* corvid-view's messages to the page (view_messages.h), built with cJSON. */
#include "view_messages.h"

#include <cjson/cJSON.h>
#include <math.h>
#include <string.h>

#include "view_input.h"

static cJSON *vec3(const float v[3]) {
    const double d[3] = { v[0], v[1], v[2] };
    return cJSON_CreateDoubleArray(d, 3);
}

/* The sun the renderer uses: the settings' direction, else toward the scene's first
 * directional light, else the renderer's default (scene_upload.c: travelling -0.3,-1,-0.2). */
static void sun_toward(const cv_render_settings *s, const cv_scene *scene, float out[3]) {
    if (s->sun_toward[0] || s->sun_toward[1] || s->sun_toward[2]) {
        memcpy(out, s->sun_toward, sizeof(float) * 3);
        return;
    }
    float dir[3] = { -0.3f, -1.0f, -0.2f };
    for (uint32_t l = 0; l < cv_scene_light_count(scene); l++) {
        const cv_light *light = cv_scene_light(scene, l);
        if (light->type == CV_LIGHT_DIRECTIONAL) {
            memcpy(dir, light->direction, sizeof dir);
            break;
        }
    }
    float len = sqrtf(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]);
    for (int k = 0; k < 3; k++)
        out[k] = -dir[k] / len;
}

/* A page setting: its value (in the option's units: none = 0, on/off = true/false), range and words. */
static cJSON *setting_json(const cv_render_settings *resolved, const cv_render_setting *row) {
    cJSON *o = cJSON_CreateObject();
    const void *p = (const char *)resolved + row->offset;
    double value = row->kind == CV_SETTING_U32   ? *(const uint32_t *)p
                   : row->kind == CV_SETTING_F32 ? *(const float *)p
                                                 : *(const int32_t *)p;
    if (row->kind == CV_SETTING_ON_OFF)
        cJSON_AddBoolToObject(o, "value", value > 0);
    else
        cJSON_AddNumberToObject(o, "value", value < 0 ? 0 : value); /* none: the option's 0 */
    cJSON_AddStringToObject(o, "kind",
                            row->kind == CV_SETTING_ON_OFF ? "on_off"
                            : row->kind == CV_SETTING_F32  ? "number"
                                                           : "whole");
    cJSON_AddNumberToObject(o, "min", row->min);
    /* An open-ended range (the AO radius, in scene units): a slider up to ten times the start. */
    cJSON_AddNumberToObject(o, "max", isfinite(row->max) ? row->max : fmax(1.0, 10.0 * value));
    cJSON_AddBoolToObject(o, "pow2", (row->flags & CV_SETTING_POW2) != 0);
    cJSON_AddStringToObject(o, "name", row->name);
    cJSON_AddStringToObject(o, "unit", row->unit);
    /* Its name in a gateway job's "settings" (the option without "--"; "sun" takes the cone with the
     * direction: "DX,DY,DZ,A"), so that the page's job panel starts jobs with the page's settings. */
    cJSON_AddStringToObject(o, "job", row->option ? row->option + 2 : row->field);
    return o;
}

char *view_hello_json(const cv_render_settings *s, const cv_scene *scene, cv_codec codec) {
    cv_render_settings r = cv_render_settings_resolve(s, scene);
    cv_camera cam = cv_render_camera(&r, scene, 0);
    float sun[3];
    sun_toward(s, scene, sun);
    cJSON *root = cJSON_CreateObject(), *camera = cJSON_CreateObject(), *settings = cJSON_CreateObject();
    cJSON_AddStringToObject(root, "type", "hello");
    cJSON_AddStringToObject(root, "codec", cv_codec_name(codec));
    cJSON_AddNumberToObject(root, "width", r.width);
    cJSON_AddNumberToObject(root, "height", r.height);
    cJSON_AddItemToObject(camera, "eye", vec3(cam.position));
    cJSON_AddItemToObject(camera, "target", vec3(cam.target));
    cJSON_AddItemToObject(camera, "up", vec3(cam.up));
    cJSON_AddNumberToObject(camera, "fov", cam.vertical_fov * 180.0 / M_PI);
    cJSON_AddItemToObject(root, "camera", camera);
    cJSON_AddItemToObject(root, "sun", vec3(sun));
    /* Whether the view's camera and sun are its own (else the scene's): a job from the page sets them only then. */
    cJSON_AddBoolToObject(root, "camera_set", s->camera_fov_degrees != 0);
    cJSON_AddBoolToObject(root, "sun_set", s->sun_toward[0] || s->sun_toward[1] || s->sun_toward[2]);
    for (uint32_t i = 0; i < view_page_setting_count; i++) {
        const cv_render_setting *row = &cv_render_setting_rows[view_page_settings[i]];
        cJSON_AddItemToObject(settings, row->field, setting_json(&r, row));
    }
    cJSON_AddItemToObject(root, "settings", settings);
    char *out = cJSON_PrintUnformatted(root);
    cJSON_Delete(root);
    return out;
}

/* "gbuffer dev0 1.20 ms\n..." as [{"pass":"gbuffer","device":"dev0","ms":1.2}, ...]. */
static cJSON *passes_json(const char *text) {
    cJSON *a = cJSON_CreateArray();
    char pass[64], device[64];
    double ms;
    int used;
    while (sscanf(text, "%63s %63s %lf ms%n", pass, device, &ms, &used) == 3) {
        cJSON *p = cJSON_CreateObject();
        cJSON_AddStringToObject(p, "pass", pass);
        cJSON_AddStringToObject(p, "device", device);
        cJSON_AddNumberToObject(p, "ms", ms);
        cJSON_AddItemToArray(a, p);
        text += used;
    }
    return a;
}

char *view_stats_json(const cv_live_stats *ls, const cv_web_stats *ws, double sent_bytes_per_s,
                      double received_bytes_per_s) {
    cJSON *o = cJSON_CreateObject();
    cJSON_AddStringToObject(o, "type", "stats");
    cJSON_AddNumberToObject(o, "fps", ls->fps);
    cJSON_AddNumberToObject(o, "rendered", (double)ls->rendered);
    cJSON_AddNumberToObject(o, "presented", (double)ls->presented);
    cJSON_AddNumberToObject(o, "spoiled", (double)ls->spoiled);
    cJSON_AddNumberToObject(o, "replaced", (double)ws->binary_replaced);
    cJSON_AddNumberToObject(o, "render_ms", ls->render_ms);
    cJSON_AddNumberToObject(o, "read_ms", ls->read_ms);
    cJSON_AddNumberToObject(o, "encode_ms", ls->encode_ms);
    cJSON_AddItemToObject(o, "passes", passes_json(ls->passes));
    cJSON_AddNumberToObject(o, "link_bytes_per_s", ls->link_bytes_per_s);
    cJSON_AddNumberToObject(o, "sent_bytes_per_s", sent_bytes_per_s);
    cJSON_AddNumberToObject(o, "received_bytes_per_s", received_bytes_per_s);
    cJSON_AddNumberToObject(o, "m2p_ms", ls->motion_to_photon_ms);
    cJSON_AddNumberToObject(o, "m2p_max_ms", ls->motion_to_photon_max_ms);
    cJSON_AddNumberToObject(o, "input_age_ms", ls->input_age_ms);
    cJSON_AddStringToObject(o, "codec", cv_codec_name(ls->codec));
    cJSON_AddNumberToObject(o, "quality", ls->quality);
    cJSON_AddNumberToObject(o, "bitrate_kbps", ls->bitrate_kbps);
    cJSON_AddNumberToObject(o, "accumulated", ls->accumulated);
    cJSON_AddNumberToObject(o, "input_seq", (double)ls->input_seq); /* the live's seq, not a page's */
    cJSON_AddNumberToObject(o, "width", ls->width);
    cJSON_AddNumberToObject(o, "height", ls->height);
    if (ls->failed)
        cJSON_AddStringToObject(o, "error", ls->error);
    char *out = cJSON_PrintUnformatted(o);
    cJSON_Delete(o);
    return out;
}

char *view_error_json(const char *message) {
    cJSON *o = cJSON_CreateObject();
    cJSON_AddStringToObject(o, "type", "error");
    cJSON_AddStringToObject(o, "error", message);
    char *out = cJSON_PrintUnformatted(o);
    cJSON_Delete(o);
    return out;
}
