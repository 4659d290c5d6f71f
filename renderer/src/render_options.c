/* The settings' command-line options and their help, made from the settings
 * table (corvid/render_options.h). */
#include "corvid/render_options.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "corvid/parse.h"

#define ROW(field) (&cv_render_setting_rows[CV_RENDER_SETTING_##field])

/* A finite float. strtof's ERANGE also means underflow (1e-45, a denormal,
 * or 1e-50, rounded to 0): a finite number, accepted; only overflow (inf) is
 * refused. */
static bool parse_float(const char *s, float *out) {
    char *end;
    errno = 0;
    float v = strtof(s, &end);
    if ((errno && errno != ERANGE) || end == s || *end || !isfinite(v))
        return false;
    *out = v;
    return true;
}

/* Exactly `count` comma-separated finite numbers. */
static bool parse_floats(const char *value, float *out, int count) {
    const char *s = value;
    for (int i = 0; i < count; i++) {
        char item[64];
        size_t len = strcspn(s, ",");
        if (len == 0 || len >= sizeof item || (i + 1 < count) != (s[len] == ','))
            return false;
        memcpy(item, s, len);
        item[len] = '\0';
        if (!parse_float(item, &out[i]))
            return false;
        s += len + (s[len] == ',');
    }
    return true;
}

/* What a value of the row's own option must be: "a whole number in <min>..<max>". */
static void expected_value(const cv_render_setting *row, char *out, size_t size) {
    char range[96];
    cv_render_setting_range(row, range, sizeof range);
    if (row->kind == CV_SETTING_ON_OFF || (row->flags & CV_SETTING_POW2))
        snprintf(out, size, "%s", range);
    else if (row->kind == CV_SETTING_F32)
        snprintf(out, size, "a finite number%s%s %s%s", row->unit[0] ? " of " : "", row->unit,
                 range[0] == '>' ? "" : "in ", range);
    else
        snprintf(out, size, "a whole number in %s", range);
}

static cv_result refuse(const char *option, const char *value, const char *expected) {
    return cv_error(CV_ERROR_INVALID_ARGUMENT, "%s: '%s' is not %s", option, value, expected);
}

/* A row's own option, in the row's option units (the none value 0 stores -1). */
static cv_result parse_plain(const cv_render_setting *row, const char *value, cv_render_settings *s) {
    char expected[128];
    expected_value(row, expected, sizeof expected);
    void *p = (char *)s + row->offset;
    uint64_t n;
    float f;
    switch (row->kind) {
    case CV_SETTING_U32:
    case CV_SETTING_I32:
        if (!cv_parse_uint(value, (uint64_t)row->min, (uint64_t)row->max, &n) ||
            !cv_render_setting_accepts(row, (double)n))
            return refuse(row->option, value, expected);
        if (row->kind == CV_SETTING_U32)
            *(uint32_t *)p = (uint32_t)n;
        else
            *(int32_t *)p = n == 0 && (row->flags & CV_SETTING_NONE) ? -1 : (int32_t)n;
        return CV_OK;
    case CV_SETTING_ON_OFF:
        if (strcmp(value, "on") != 0 && strcmp(value, "off") != 0)
            return refuse(row->option, value, expected);
        *(int32_t *)p = strcmp(value, "on") == 0 ? 1 : -1;
        return CV_OK;
    case CV_SETTING_F32:
        if (!parse_float(value, &f) || !cv_render_setting_accepts(row, f))
            return refuse(row->option, value, expected);
        *(float *)p = f == 0.0f && (row->flags & CV_SETTING_NONE) ? -1.0f : f;
        return CV_OK;
    case CV_SETTING_VEC3: break;
    }
    return cv_error(CV_ERROR_INVALID_ARGUMENT, "%s: set through a compound option", row->option);
}

/* --size WxH */
static cv_result parse_size(const char *option, const char *value, cv_render_settings *s) {
    char expected[128], range[64];
    cv_render_setting_range(ROW(width), range, sizeof range);
    snprintf(expected, sizeof expected, "WxH with each side in %s", range);
    const char *x = strchr(value, 'x');
    uint64_t w, h;
    char width[24];
    if (!x || (size_t)(x - value) >= sizeof width)
        return refuse(option, value, expected);
    snprintf(width, sizeof width, "%.*s", (int)(x - value), value);
    if (!cv_parse_uint(width, 0, UINT32_MAX, &w) || !cv_render_setting_accepts(ROW(width), (double)w) ||
        !cv_parse_uint(x + 1, 0, UINT32_MAX, &h) || !cv_render_setting_accepts(ROW(height), (double)h))
        return refuse(option, value, expected);
    s->width = (uint32_t)w;
    s->height = (uint32_t)h;
    return CV_OK;
}

/* --camera EX,EY,EZ,TX,TY,TZ,FOV */
static cv_result parse_camera(const char *option, const char *value, cv_render_settings *s) {
    float v[7];
    char expected[128], range[64];
    if (!parse_floats(value, v, 7))
        return refuse(option, value, "7 finite numbers EX,EY,EZ,TX,TY,TZ,FOV");
    cv_render_setting_range(ROW(camera_fov_degrees), range, sizeof range);
    snprintf(expected, sizeof expected, "EX,EY,EZ,TX,TY,TZ,FOV with FOV in %s degrees", range);
    if (!cv_render_setting_accepts(ROW(camera_fov_degrees), v[6]))
        return refuse(option, value, expected);
    memcpy(s->camera_eye, v, sizeof(s->camera_eye));
    memcpy(s->camera_target, v + 3, sizeof(s->camera_target));
    s->camera_fov_degrees = v[6];
    return CV_OK;
}

/* --sun DX,DY,DZ,A: A = 0 is hard shadows (the settings' negative cone). */
static cv_result parse_sun(const char *option, const char *value, cv_render_settings *s) {
    float v[4];
    char expected[128], range[64];
    if (!parse_floats(value, v, 4))
        return refuse(option, value, "4 finite numbers DX,DY,DZ,A");
    if (v[0] == 0.0f && v[1] == 0.0f && v[2] == 0.0f)
        return refuse(option, value, "DX,DY,DZ,A with a direction other than 0,0,0");
    cv_render_setting_range(ROW(sun_cone_degrees), range, sizeof range);
    snprintf(expected, sizeof expected, "DX,DY,DZ,A with A in %s degrees", range);
    if (!cv_render_setting_accepts(ROW(sun_cone_degrees), v[3]))
        return refuse(option, value, expected);
    memcpy(s->sun_toward, v, sizeof(s->sun_toward));
    s->sun_cone_degrees = v[3] > 0.0f ? v[3] : -1.0f;
    return CV_OK;
}

/* The options that set several rows at once, named by their first row; `defaults` writes
 * their ranges and defaults for --help. */
static void size_defaults(char *out, size_t size) {
    char range[64];
    cv_render_setting_range(ROW(width), range, sizeof range);
    snprintf(out, size, "each side %s; default %gx%g", range, ROW(width)->def, ROW(height)->def);
}

static void camera_defaults(char *out, size_t size) {
    char range[64];
    cv_render_setting_range(ROW(camera_fov_degrees), range, sizeof range);
    snprintf(out, size, "FOV in %s; default: the scene's camera", range);
}

static void sun_defaults(char *out, size_t size) {
    char range[64];
    cv_render_setting_range(ROW(sun_cone_degrees), range, sizeof range);
    snprintf(out, size, "A in %s; default: the scene's sun, A %g", range, ROW(sun_cone_degrees)->def);
}

static const struct compound {
    cv_render_setting_id first;
    cv_result (*parse)(const char *option, const char *value, cv_render_settings *s);
    void (*defaults)(char *out, size_t size);
} compounds[] = {
    { CV_RENDER_SETTING_width, parse_size, size_defaults },
    { CV_RENDER_SETTING_camera_eye, parse_camera, camera_defaults },
    { CV_RENDER_SETTING_sun_toward, parse_sun, sun_defaults },
};

static const struct compound *compound_of(const cv_render_setting *row) {
    for (size_t i = 0; i < sizeof compounds / sizeof compounds[0]; i++)
        if (!strcmp(cv_render_setting_rows[compounds[i].first].option, row->option))
            return &compounds[i];
    return NULL;
}

const cv_render_setting *cv_render_option_find(const char *name, size_t len) {
    for (int i = 0; i < CV_RENDER_SETTING_COUNT; i++) {
        const char *option = cv_render_setting_rows[i].option;
        if (option && strlen(option) == len && !strncmp(option, name, len))
            return &cv_render_setting_rows[i];
    }
    return NULL;
}

cv_result cv_render_option_apply(const cv_render_setting *option, const char *value, cv_render_settings *s) {
    if (!option || !option->option || !value || !s)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_render_option_apply: NULL argument or a row without option");
    cv_render_settings next = *s;
    const struct compound *c = compound_of(option);
    cv_result r = c ? c->parse(option->option, value, &next) : parse_plain(option, value, &next);
    if (r != CV_OK)
        return r;
    if (cv_render_settings_check(&next) != CV_OK) {
        char why[512];
        snprintf(why, sizeof why, "%s", cv_last_error());
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "%s: '%s': %s", option->option, value, why);
    }
    *s = next;
    return CV_OK;
}

/* A row's default as its option writes it. */
static void default_text(const cv_render_setting *row, char *out, size_t size) {
    if (row->kind == CV_SETTING_ON_OFF)
        snprintf(out, size, "%s", row->def > 0 ? "on" : "off");
    else if (row->flags & CV_SETTING_DIAGONAL)
        snprintf(out, size, "%g x the scene's diagonal", row->def);
    else
        snprintf(out, size, "%.10g", row->def);
}

void cv_render_help_entry(FILE *f, const char *name_and_metavar, const char *text) {
    enum { INDENT = 21, WIDTH = 100 };
    int column = fprintf(f, "  %-18s ", name_and_metavar);
    bool line_start = true;
    if (column > INDENT)
        column += fprintf(f, " ");
    while (*text) {
        text += strspn(text, " ");
        size_t word = strcspn(text, " ");
        if (!word)
            break;
        if (!line_start && column + 1 + (int)word > WIDTH)
            column = fprintf(f, "\n%*s", INDENT, "") - 1, line_start = true;
        column += fprintf(f, "%s%.*s", line_start ? "" : " ", (int)word, text);
        line_start = false;
        text += word;
    }
    fputc('\n', f);
}

/* The help text of the rows that option `first` sets (the same text once), with `tail` in brackets. */
static void option_help(FILE *f, int first, const char *tail) {
    const cv_render_setting *row = &cv_render_setting_rows[first];
    char name[64], text[1024];
    size_t at = 0;
    snprintf(name, sizeof name, "%s %s", row->option, row->metavar);
    text[0] = '\0';
    for (int i = first; i < CV_RENDER_SETTING_COUNT; i++) {
        const cv_render_setting *r = &cv_render_setting_rows[i];
        bool again = i > first && !strcmp(r->help, cv_render_setting_rows[i - 1].help);
        if (r->option && !strcmp(r->option, row->option) && !again && at < sizeof text)
            at += (size_t)snprintf(text + at, sizeof text - at, "%s%s", at ? ", " : "", r->help);
    }
    if (at < sizeof text)
        snprintf(text + at, sizeof text - at, " (%s)", tail);
    cv_render_help_entry(f, name, text);
}

void cv_render_options_help(FILE *f) {
    for (int i = 0; i < CV_RENDER_SETTING_COUNT; i++) {
        const cv_render_setting *row = &cv_render_setting_rows[i];
        if (!row->option || cv_render_option_find(row->option, strlen(row->option)) != row)
            continue;
        const struct compound *c = compound_of(row);
        char tail[256], range[96], def[64];
        if (c) {
            c->defaults(tail, sizeof tail);
        } else {
            cv_render_setting_range(row, range, sizeof range);
            default_text(row, def, sizeof def);
            snprintf(tail, sizeof tail, "%s; default %s", range, def);
        }
        option_help(f, i, tail);
    }
}
