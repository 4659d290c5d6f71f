/* corvid-view's input messages (view_input.h), read with cJSON. */
#include "view_input.h"

#include <cjson/cJSON.h>
#include <math.h>
#include <string.h>

const cv_render_setting_id view_page_settings[] = {
    CV_RENDER_SETTING_exposure,          CV_RENDER_SETTING_shadow_samples,     CV_RENDER_SETTING_ao_samples,
    CV_RENDER_SETTING_ao_radius,         CV_RENDER_SETTING_filter_iterations,  CV_RENDER_SETTING_reflections,
    CV_RENDER_SETTING_reflection_radius, CV_RENDER_SETTING_reflection_samples, CV_RENDER_SETTING_sun_cone_degrees,
};
const uint32_t view_page_setting_count = sizeof view_page_settings / sizeof view_page_settings[0];

static cv_result refuse(const char *field, const char *why) {
    return cv_error(CV_ERROR_INVALID_ARGUMENT, "input: %s: %s", field, why);
}

/* A whole number >= 0 (JSON numbers are doubles: exact up to 2^53). */
static cv_result read_count(const cJSON *v, const char *field, uint64_t *out) {
    if (!cJSON_IsNumber(v) || v->valuedouble < 0 || v->valuedouble > 9007199254740992.0 ||
        v->valuedouble != floor(v->valuedouble))
        return refuse(field, "not a whole number >= 0");
    *out = (uint64_t)v->valuedouble;
    return CV_OK;
}

static cv_result read_vec3(const cJSON *v, const char *field, float out[3]) {
    if (!cJSON_IsArray(v) || cJSON_GetArraySize(v) != 3)
        return refuse(field, "not an array of 3 numbers");
    for (int i = 0; i < 3; i++) {
        const cJSON *e = cJSON_GetArrayItem(v, i);
        if (!cJSON_IsNumber(e) || !isfinite(e->valuedouble) || fabs(e->valuedouble) > 1e30)
            return refuse(field, "not an array of 3 finite numbers");
        out[i] = (float)e->valuedouble;
    }
    return CV_OK;
}

static cv_result read_camera(const cJSON *cam, cv_render_settings *s) {
    if (!cJSON_IsObject(cam))
        return refuse("camera", "not an object {eye, target, fov}");
    for (const cJSON *c = cam->child; c; c = c->next) {
        char field[96];
        snprintf(field, sizeof field, "camera.%s", c->string);
        cv_result r = CV_OK;
        if (!strcmp(c->string, "eye"))
            r = read_vec3(c, field, s->camera_eye);
        else if (!strcmp(c->string, "target"))
            r = read_vec3(c, field, s->camera_target);
        else if (!strcmp(c->string, "fov")) {
            if (!cJSON_IsNumber(c) || !(c->valuedouble > 0) || c->valuedouble > CV_RENDER_MAX_FOV_DEGREES)
                return refuse(field, "not a number of degrees in (0, 170]");
            s->camera_fov_degrees = (float)c->valuedouble;
        } else
            return refuse(field, "unknown field (eye, target, fov)");
        if (r != CV_OK)
            return r;
    }
    /* The scene's camera is replaced only whole: eye, target and fov together. */
    if (s->camera_fov_degrees == 0)
        return refuse("camera", "eye, target and fov are needed the first time");
    return CV_OK;
}

static const cv_render_setting *page_setting(const char *name) {
    for (uint32_t i = 0; i < view_page_setting_count; i++)
        if (!strcmp(cv_render_setting_rows[view_page_settings[i]].field, name))
            return &cv_render_setting_rows[view_page_settings[i]];
    return NULL;
}

/* One setting by its field name, in the units of its option (0 = none where the row allows it). */
static cv_result read_setting(const cJSON *v, cv_render_settings *s) {
    char field[96], range[128];
    snprintf(field, sizeof field, "settings.%s", v->string);
    const cv_render_setting *row = page_setting(v->string);
    if (!row)
        return refuse(field, "unknown setting (docs/live-view.md lists the page's)");
    double x;
    if (row->kind == CV_SETTING_ON_OFF && cJSON_IsBool(v))
        x = cJSON_IsTrue(v) ? 1 : -1;
    else if (cJSON_IsNumber(v) && isfinite(v->valuedouble))
        x = v->valuedouble;
    else
        return refuse(field, row->kind == CV_SETTING_ON_OFF ? "not true or false" : "not a number");
    bool whole = row->kind == CV_SETTING_U32 || row->kind == CV_SETTING_I32;
    if ((row->kind != CV_SETTING_ON_OFF && !cv_render_setting_accepts(row, x)) || (whole && x != floor(x))) {
        cv_render_setting_range(row, range, sizeof range);
        char why[192];
        snprintf(why, sizeof why, "%g is outside %s", x, range);
        return refuse(field, why);
    }
    if (x == 0 && (row->flags & CV_SETTING_NONE))
        x = -1; /* the option's 0: none */
    void *p = (char *)s + row->offset;
    if (row->kind == CV_SETTING_U32)
        *(uint32_t *)p = (uint32_t)x;
    else if (row->kind == CV_SETTING_F32)
        *(float *)p = (float)x;
    else
        *(int32_t *)p = (int32_t)x;
    return CV_OK;
}

static cv_result read_settings(const cJSON *obj, cv_render_settings *s) {
    if (!cJSON_IsObject(obj))
        return refuse("settings", "not an object {name: value}");
    for (const cJSON *v = obj->child; v; v = v->next) {
        cv_result r = read_setting(v, s);
        if (r != CV_OK)
            return r;
    }
    return CV_OK;
}

static cv_result read_codec(const cJSON *v, view_input *in) {
    const char *name = cJSON_GetStringValue(v);
    if (name && !strcmp(name, "jpeg"))
        in->codec = CV_CODEC_JPEG;
    else if (name && !strcmp(name, "h264"))
        in->codec = CV_CODEC_H264;
    else
        return refuse("codec", "not \"jpeg\" or \"h264\"");
    in->has_codec = true;
    return CV_OK;
}

static cv_result read_number(const cJSON *v, const char *field, double *out) {
    if (!cJSON_IsNumber(v) || !isfinite(v->valuedouble) || v->valuedouble < 0)
        return refuse(field, "not a number >= 0");
    *out = v->valuedouble;
    return CV_OK;
}

/* One top-level field. */
static cv_result read_field(const cJSON *v, view_input *in) {
    const char *k = v->string;
    if (!strcmp(k, "seq")) {
        in->has_seq = true;
        return read_count(v, k, &in->seq);
    }
    if (!strcmp(k, "t")) /* the page's clock: the page measures with it */
        return cJSON_IsNumber(v) ? CV_OK : refuse(k, "not a number");
    if (!strcmp(k, "camera") || !strcmp(k, "sun") || !strcmp(k, "settings")) {
        in->changed = true;
        return !strcmp(k, "camera") ? read_camera(v, &in->settings)
               : !strcmp(k, "sun")  ? read_vec3(v, k, in->settings.sun_toward)
                                    : read_settings(v, &in->settings);
    }
    if (!strcmp(k, "ack")) {
        in->has_ack = true;
        return read_count(v, k, &in->ack);
    }
    if (!strcmp(k, "bytes_per_s"))
        return read_number(v, k, &in->bytes_per_s);
    if (!strcmp(k, "shown")) {
        in->has_shown = true;
        return read_count(v, k, &in->shown);
    }
    if (!strcmp(k, "m2p"))
        return read_number(v, k, &in->m2p_ms);
    if (!strcmp(k, "codec"))
        return read_codec(v, in);
    if (!strcmp(k, "keyframe")) {
        in->keyframe = cJSON_IsTrue(v);
        return cJSON_IsBool(v) ? CV_OK : refuse(k, "not true or false");
    }
    return refuse(k, "unknown field (seq, t, camera, sun, settings, ack, bytes_per_s, shown, m2p, codec, keyframe)");
}

cv_result view_input_parse(const char *text, const cv_render_settings *current, view_input *out) {
    *out = (view_input){ .settings = *current };
    cJSON *root = cJSON_Parse(text);
    if (!root)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "input: not JSON (near '%.20s')",
                        cJSON_GetErrorPtr() ? cJSON_GetErrorPtr() : "");
    cv_result r = cJSON_IsObject(root) ? CV_OK : refuse("message", "not a JSON object");
    for (const cJSON *v = root->child; r == CV_OK && v; v = v->next)
        r = read_field(v, out);
    cJSON_Delete(root);
    return r;
}
