/* A job's request read and checked (job_request.h). */
#include "job_request.h"

#include <cjson/cJSON.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "corvid/render_options.h"

/* Applies one option's value text; the error names `field` instead of the option. */
static cv_result apply(const char *field, const char *option, const char *value, cv_render_settings *s) {
    const cv_render_setting *opt = cv_render_option_find(option, strlen(option));
    if (!opt)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "%s: no such setting", field);
    if (cv_render_option_apply(opt, value, s) == CV_OK)
        return CV_OK;
    char message[CV_ERROR_MESSAGE_MAX];
    const char *m = cv_last_error();
    size_t n = strlen(option);
    if (strncmp(m, option, n) == 0 && m[n] == ':' && m[n + 1] == ' ')
        m += n + 2;
    snprintf(message, sizeof(message), "%s", m);
    return cv_error(CV_ERROR_INVALID_ARGUMENT, "%s: %s", field, message);
}

/* A JSON value as an option's text: numbers as written ("%.17g" round-trips), strings as they are,
 * true/false as on/off. */
static cv_result value_text(const char *field, const cJSON *v, char *out, size_t size) {
    if (cJSON_IsNumber(v))
        snprintf(out, size, "%.17g", v->valuedouble);
    else if (cJSON_IsString(v))
        snprintf(out, size, "%s", v->valuestring);
    else if (cJSON_IsBool(v))
        snprintf(out, size, "%s", cJSON_IsTrue(v) ? "on" : "off");
    else
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "%s: must be a number, a string or true/false", field);
    return CV_OK;
}

/* width or height: a whole number within its row's range. */
static cv_result size_side(const cJSON *root, const char *field, cv_render_setting_id id, double *out) {
    const cv_render_setting *row = &cv_render_setting_rows[id];
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(root, field);
    *out = row->def;
    if (!v)
        return CV_OK;
    char range[128];
    cv_render_setting_range(row, range, sizeof(range));
    if (!cJSON_IsNumber(v) || !cv_render_setting_accepts(row, v->valuedouble) ||
        v->valuedouble != floor(v->valuedouble))
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "%s: must be a whole number in %s", field, range);
    *out = v->valuedouble;
    return CV_OK;
}

static cv_result parse_size(const cJSON *root, uint64_t max_pixels, cv_render_settings *s) {
    double w, h;
    cv_result r = size_side(root, "width", CV_RENDER_SETTING_width, &w);
    if (r == CV_OK)
        r = size_side(root, "height", CV_RENDER_SETTING_height, &h);
    if (r != CV_OK)
        return r;
    if (w * h > (double)max_pixels)
        return cv_error(CV_ERROR_INVALID_ARGUMENT,
                        "width, height: %.0fx%.0f is %.0f pixels, over the gateway's limit of %llu", w, h, w * h,
                        (unsigned long long)max_pixels);
    char text[64];
    snprintf(text, sizeof(text), "%.0fx%.0f", w, h);
    return apply("width, height", "--size", text, s);
}

/* camera {"eye": [3], "target": [3], "fov_degrees": n}: all three. */
static cv_result parse_camera(const cJSON *camera, cv_render_settings *s) {
    if (!cJSON_IsObject(camera))
        return cv_error(CV_ERROR_INVALID_ARGUMENT,
                        "camera: must be an object {\"eye\", \"target\", \"fov_degrees\"}");
    for (const cJSON *c = camera->child; c; c = c->next)
        if (strcmp(c->string, "eye") != 0 && strcmp(c->string, "target") != 0 &&
            strcmp(c->string, "fov_degrees") != 0)
            return cv_error(CV_ERROR_INVALID_ARGUMENT, "camera.%s: unknown field (eye, target, fov_degrees)",
                            c->string);
    double v[7];
    static const char *const vectors[2] = { "eye", "target" };
    for (int i = 0; i < 2; i++) {
        const cJSON *a = cJSON_GetObjectItemCaseSensitive(camera, vectors[i]);
        if (!cJSON_IsArray(a) || cJSON_GetArraySize(a) != 3)
            return cv_error(CV_ERROR_INVALID_ARGUMENT, "camera.%s: must be an array of 3 numbers", vectors[i]);
        for (int k = 0; k < 3; k++) {
            const cJSON *n = cJSON_GetArrayItem(a, k);
            if (!cJSON_IsNumber(n))
                return cv_error(CV_ERROR_INVALID_ARGUMENT, "camera.%s[%d]: must be a number", vectors[i], k);
            v[i * 3 + k] = n->valuedouble;
        }
    }
    const cJSON *fov = cJSON_GetObjectItemCaseSensitive(camera, "fov_degrees");
    if (!cJSON_IsNumber(fov))
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "camera.fov_degrees: must be a number");
    v[6] = fov->valuedouble;
    char text[512];
    snprintf(text, sizeof(text), "%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g", v[0], v[1], v[2], v[3], v[4], v[5], v[6]);
    return apply("camera", "--camera", text, s);
}

/* The exposure (EV of the PNG): a setting of the table the programs take as an option of their own. */
static cv_result set_exposure(const char *field, const cJSON *v, cv_render_settings *s) {
    const cv_render_setting *row = &cv_render_setting_rows[CV_RENDER_SETTING_exposure];
    char range[128];
    cv_render_setting_range(row, range, sizeof(range));
    if (!cJSON_IsNumber(v) || !cv_render_setting_accepts(row, v->valuedouble))
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "%s: must be a number in %s", field, range);
    s->exposure = (float)v->valuedouble;
    return CV_OK;
}

/* settings {"ao-samples": 8, ...}: the options without "--"; size, frames and camera are the job's fields. */
static cv_result parse_settings(const cJSON *settings, cv_render_settings *s) {
    if (!cJSON_IsObject(settings))
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "settings: must be an object {\"<setting>\": value}");
    for (const cJSON *c = settings->child; c; c = c->next) {
        char field[160], option[160], value[512];
        snprintf(field, sizeof(field), "settings.%s", c->string);
        if (strcmp(c->string, "size") == 0 || strcmp(c->string, "frames") == 0 || strcmp(c->string, "camera") == 0)
            return cv_error(CV_ERROR_INVALID_ARGUMENT, "%s: give it as the job's field%s", field,
                            strcmp(c->string, "size") == 0 ? "s width and height" : "");
        snprintf(option, sizeof(option), "--%s", c->string);
        bool has_option = strncmp(c->string, "--", 2) != 0 && cv_render_option_find(option, strlen(option));
        if (!has_option && strcmp(c->string, "exposure") == 0) {
            cv_result r = set_exposure(field, c, s);
            if (r != CV_OK)
                return r;
            continue;
        }
        if (!has_option)
            return cv_error(CV_ERROR_INVALID_ARGUMENT,
                            "%s: no such setting (the options of corvid-render --help, "
                            "without their \"--\")",
                            field);
        cv_result r = value_text(field, c, value, sizeof(value));
        if (r == CV_OK)
            r = apply(field, option, value, s);
        if (r != CV_OK)
            return r;
    }
    return CV_OK;
}

static cv_result parse_scene(const cJSON *scene, char out[CV_SHA256_HEX_SIZE]) {
    uint8_t digest[CV_SHA256_SIZE];
    if (!scene) {
        snprintf(out, CV_SHA256_HEX_SIZE, "%s", GW_DEFAULT_SCENE);
        return CV_OK;
    }
    if (cJSON_IsString(scene) && strcmp(scene->valuestring, GW_DEFAULT_SCENE) == 0) {
        snprintf(out, CV_SHA256_HEX_SIZE, "%s", GW_DEFAULT_SCENE);
        return CV_OK;
    }
    if (!cJSON_IsString(scene) || !cv_sha256_parse_hex(scene->valuestring, digest))
        return cv_error(CV_ERROR_INVALID_ARGUMENT,
                        "scene: must be a model's SHA-256 (64 hex digits) or \"" GW_DEFAULT_SCENE "\"");
    cv_sha256_hex(digest, out);
    return CV_OK;
}

static cv_result parse_root(const cJSON *root, uint64_t max_pixels, gw_job_request *out) {
    static const char *const fields[] = { "scene", "width", "height", "frames", "camera", "settings" };
    for (const cJSON *c = root->child; c; c = c->next) {
        bool known = false;
        for (size_t i = 0; i < sizeof(fields) / sizeof(fields[0]); i++)
            known = known || strcmp(c->string, fields[i]) == 0;
        if (!known)
            return cv_error(CV_ERROR_INVALID_ARGUMENT,
                            "unknown field '%s' (a job has scene, width, height, frames, camera, settings)",
                            c->string);
    }
    cv_result r = parse_scene(cJSON_GetObjectItemCaseSensitive(root, "scene"), out->scene);
    const cJSON *settings = cJSON_GetObjectItemCaseSensitive(root, "settings");
    if (r == CV_OK && settings)
        r = parse_settings(settings, &out->settings);
    if (r == CV_OK)
        r = parse_size(root, max_pixels, &out->settings);
    const cJSON *frames = cJSON_GetObjectItemCaseSensitive(root, "frames");
    char text[64];
    if (r == CV_OK && frames && (r = value_text("frames", frames, text, sizeof(text))) == CV_OK)
        r = apply("frames", "--frames", text, &out->settings);
    const cJSON *camera = cJSON_GetObjectItemCaseSensitive(root, "camera");
    if (r == CV_OK && camera)
        r = parse_camera(camera, &out->settings);
    if (r == CV_OK && cv_render_settings_check(&out->settings) != CV_OK)
        r = cv_error(CV_ERROR_INVALID_ARGUMENT, "settings: %s", cv_last_error());
    return r;
}

cv_result gw_job_request_parse(const uint8_t *body, size_t size, uint64_t max_pixels, gw_job_request *out) {
    const char *end = NULL;
    cJSON *root = cJSON_ParseWithLengthOpts((const char *)body, size, &end, false);
    if (!root) {
        size_t at = end && end >= (const char *)body ? (size_t)(end - (const char *)body) : 0;
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "body: not valid JSON (near byte %zu)", at);
    }
    while (end < (const char *)body + size && (*end == ' ' || *end == '\t' || *end == '\r' || *end == '\n'))
        end++;
    gw_job_request req = { .settings = { 0 } };
    cv_result r = CV_OK;
    if (end != (const char *)body + size)
        r = cv_error(CV_ERROR_INVALID_ARGUMENT, "body: more after the JSON object (at byte %zu)",
                     (size_t)(end - (const char *)body));
    else if (!cJSON_IsObject(root))
        r = cv_error(CV_ERROR_INVALID_ARGUMENT, "body: must be a JSON object (a job)");
    if (r == CV_OK)
        r = parse_root(root, max_pixels, &req);
    cJSON_Delete(root);
    if (r == CV_OK)
        *out = req;
    return r;
}
