/* The settings table as data, and the checks and defaults that come from it
 * (corvid/render_settings.h). */
#include "corvid/render_settings.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

/* Each row's field has the C type of its kind. */
typedef uint32_t *field_ptr_CV_SETTING_U32;
typedef int32_t *field_ptr_CV_SETTING_I32;
typedef int32_t *field_ptr_CV_SETTING_ON_OFF;
typedef float *field_ptr_CV_SETTING_F32;
typedef float (*field_ptr_CV_SETTING_VEC3)[3];
#define CHECK_FIELD_TYPE(field, kind, ...) \
    _Static_assert(_Generic(&((cv_render_settings *)0)->field, field_ptr_##kind : 1, default : 0), \
                   "cv_render_settings." #field ": its type is not the table's " #kind);
CV_RENDER_SETTINGS_TABLE(CHECK_FIELD_TYPE)
#undef CHECK_FIELD_TYPE

const cv_render_setting cv_render_setting_rows[CV_RENDER_SETTING_COUNT] = {
#define SETTING_ROW(f, k, fl, opt, meta, lo, hi, d, nm, un, hlp) \
    { .field = #f, \
      .kind = k, \
      .flags = fl, \
      .option = opt, \
      .metavar = meta, \
      .min = lo, \
      .max = hi, \
      .def = d, \
      .name = nm, \
      .unit = un, \
      .help = hlp, \
      .offset = offsetof(cv_render_settings, f) },
    CV_RENDER_SETTINGS_TABLE(SETTING_ROW)
#undef SETTING_ROW
};

static void *field_of(const cv_render_setting *row, const cv_render_settings *s) { return (char *)s + row->offset; }

/* "1, 2, 4, 8" (or "0.5, 1"): the powers of two in the row's range. */
static void powers_of_two(const cv_render_setting *row, char *out, size_t size) {
    size_t at = 0;
    out[0] = '\0';
    for (double p = exp2(ceil(log2(row->min))); p <= row->max && at < size; p *= 2)
        at += (size_t)snprintf(out + at, size - at, "%s%g", at ? ", " : "", p);
}

void cv_render_setting_range(const cv_render_setting *row, char *out, size_t size) {
    char list[64];
    if (row->kind == CV_SETTING_ON_OFF) {
        snprintf(out, size, "on or off");
    } else if (row->kind == CV_SETTING_VEC3) {
        snprintf(out, size, "finite numbers");
    } else if (row->flags & CV_SETTING_POW2) {
        powers_of_two(row, list, sizeof list);
        snprintf(out, size, "one of %s", list);
    } else if (isinf(row->max)) {
        snprintf(out, size, "%s %g", row->flags & CV_SETTING_MIN_OPEN ? ">" : ">=", row->min);
    } else if (row->flags & (CV_SETTING_MIN_OPEN | CV_SETTING_MAX_OPEN)) {
        snprintf(out, size, "%c%g,%g%c", row->flags & CV_SETTING_MIN_OPEN ? '(' : '[', row->min, row->max,
                 row->flags & CV_SETTING_MAX_OPEN ? ')' : ']');
    } else {
        snprintf(out, size, "%.10g..%.10g", row->min, row->max);
    }
}

bool cv_render_setting_accepts(const cv_render_setting *row, double v) {
    bool above = row->flags & CV_SETTING_MIN_OPEN ? v > row->min : v >= row->min;
    bool below = row->flags & CV_SETTING_MAX_OPEN ? v < row->max : v <= row->max;
    int exponent;
    bool pow2 = !(row->flags & CV_SETTING_POW2) || frexp(v, &exponent) == 0.5;
    return above && below && pow2;
}

/* "renderer: AO samples 40 is outside <min>..<max>", "... is not one of <powers of two>", "... is not > 0". */
static cv_result refuse(const cv_render_setting *row, const char *value) {
    char range[96];
    cv_render_setting_range(row, range, sizeof range);
    if (row->kind == CV_SETTING_ON_OFF)
        snprintf(range, sizeof range, "1 (on) or -1 (off)");
    bool interval = row->kind != CV_SETTING_ON_OFF && !(row->flags & CV_SETTING_POW2) && !isinf(row->max);
    return cv_error(CV_ERROR_OUT_OF_RANGE, "renderer: %s %s%s%s is %s %s", row->name, value, row->unit[0] ? " " : "",
                    row->unit, interval ? "outside" : "not", range);
}

/* One field against its row: 0 is the default, negative is none where the row allows it. */
static cv_result check_field(const cv_render_setting *row, const cv_render_settings *s) {
    const void *p = field_of(row, s);
    char value[48];
    switch (row->kind) {
    case CV_SETTING_U32: {
        uint32_t v = *(const uint32_t *)p;
        snprintf(value, sizeof value, "%u", v);
        return v == 0 || cv_render_setting_accepts(row, v) ? CV_OK : refuse(row, value);
    }
    case CV_SETTING_I32: {
        int32_t v = *(const int32_t *)p;
        snprintf(value, sizeof value, "%d", v);
        return v == 0 || (v < 0 && (row->flags & CV_SETTING_NONE)) || cv_render_setting_accepts(row, v)
                   ? CV_OK
                   : refuse(row, value);
    }
    case CV_SETTING_ON_OFF: {
        int32_t v = *(const int32_t *)p;
        snprintf(value, sizeof value, "%d", v);
        return v == 0 || v == 1 || v == -1 ? CV_OK : refuse(row, value);
    }
    case CV_SETTING_F32: {
        float v = *(const float *)p;
        if (!isfinite(v))
            return cv_error(CV_ERROR_INVALID_ARGUMENT, "renderer: %s %g%s%s: not a finite number", row->name,
                            (double)v, row->unit[0] ? " " : "", row->unit);
        snprintf(value, sizeof value, "%g", (double)v);
        return v == 0.0f || (v < 0.0f && (row->flags & CV_SETTING_NONE)) || cv_render_setting_accepts(row, v)
                   ? CV_OK
                   : refuse(row, value);
    }
    case CV_SETTING_VEC3: {
        const float *v = p;
        if (!isfinite(v[0]) || !isfinite(v[1]) || !isfinite(v[2]))
            return cv_error(CV_ERROR_INVALID_ARGUMENT, "renderer: %s (%g, %g, %g): not finite numbers", row->name,
                            (double)v[0], (double)v[1], (double)v[2]);
        return CV_OK;
    }
    }
    return CV_OK;
}

cv_result cv_render_settings_check(const cv_render_settings *s) {
    if (!s)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_render_settings_check: NULL settings");
    for (int i = 0; i < CV_RENDER_SETTING_COUNT; i++) {
        cv_result r = check_field(&cv_render_setting_rows[i], s);
        if (r != CV_OK)
            return r;
    }
    const float *e = s->camera_eye, *t = s->camera_target;
    if (s->camera_fov_degrees != 0.0f && e[0] == t[0] && e[1] == t[1] && e[2] == t[2])
        return cv_error(CV_ERROR_INVALID_ARGUMENT,
                        "renderer: camera eye (%g, %g, %g) equals its target: no view direction", (double)e[0],
                        (double)e[1], (double)e[2]);
    /* render.reflect_shade's samples: reflection_samples images, one above the other, in one texture. */
    uint32_t samples = s->reflection_samples ? s->reflection_samples : 1;
    if (s->reflections != -1 && s->height > CV_MAX_TEXTURE_DIM / samples)
        return cv_error(CV_ERROR_OUT_OF_RANGE,
                        "renderer: %u reflection samples of a %u-row image need a sample texture of %llu rows "
                        "(limit %u): use fewer reflection samples, a lower image or no reflections",
                        s->reflection_samples, s->height, (unsigned long long)s->height * s->reflection_samples,
                        CV_MAX_TEXTURE_DIM);
    return CV_OK;
}

static float scene_diagonal(const cv_scene *scene) {
    float lo[3], hi[3];
    cv_scene_bounds(scene, lo, hi);
    return sqrtf((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                 (hi[2] - lo[2]) * (hi[2] - lo[2]));
}

/* A 0 field gets the row's default; a negative one, where it means none, 0. */
static void resolve_field(const cv_render_setting *row, cv_render_settings *s, const cv_scene *scene) {
    void *p = field_of(row, s);
    switch (row->kind) {
    case CV_SETTING_U32:
        if (*(uint32_t *)p == 0)
            *(uint32_t *)p = (uint32_t)row->def;
        break;
    case CV_SETTING_I32:
    case CV_SETTING_ON_OFF:
        if (*(int32_t *)p == 0)
            *(int32_t *)p = (int32_t)row->def;
        else if (*(int32_t *)p < 0 && (row->flags & CV_SETTING_NONE))
            *(int32_t *)p = 0;
        break;
    case CV_SETTING_F32: {
        float *v = p;
        if (*v == 0.0f && (row->flags & CV_SETTING_DIAGONAL))
            *v = scene_diagonal(scene) * (float)row->def;
        else if (*v == 0.0f && !(row->flags & CV_SETTING_SCENE))
            *v = (float)row->def;
        else if (*v < 0.0f && (row->flags & CV_SETTING_NONE))
            *v = 0.0f;
        break;
    }
    case CV_SETTING_VEC3: break;
    }
}

cv_render_settings cv_render_settings_resolve(const cv_render_settings *in, const cv_scene *scene) {
    cv_render_settings s = in ? *in : (cv_render_settings){ 0 };
    for (int i = 0; i < CV_RENDER_SETTING_COUNT; i++)
        resolve_field(&cv_render_setting_rows[i], &s, scene);
    return s;
}
