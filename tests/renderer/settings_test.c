/* The settings table (corvid/render_settings.h) and the options made from it
 * (corvid/render_options.h), without a GPU: every default lies within its
 * range; each option takes its minimum and maximum and refuses what lies just
 * outside with a message naming the option, leaving the settings as they
 * were; the library's check refuses the same in the fields, naming the
 * setting; resolve fills the table's defaults; --help lists every option with
 * its range. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "corvid/render_options.h"
#include "corvid/render_settings.h"
#include "corvid/scene_procedural.h"

static const cv_render_setting *row_of(cv_render_setting_id id) { return &cv_render_setting_rows[id]; }

/* The rows set by an option of several values, tested with their own cases below. */
static bool compound(const cv_render_setting *row) {
    return !strcmp(row->option, "--size") || !strcmp(row->option, "--camera") || !strcmp(row->option, "--sun");
}

static void check_defaults(void) {
    for (int i = 0; i < CV_RENDER_SETTING_COUNT; i++) {
        const cv_render_setting *row = row_of(i);
        if (row->kind == CV_SETTING_VEC3 || (row->flags & CV_SETTING_SCENE))
            continue; /* 0 = the scene's, no default of the table's */
        bool ok = row->kind == CV_SETTING_ON_OFF ? row->def == 1 || row->def == -1
                                                 : cv_render_setting_accepts(row, row->def);
        if (!ok)
            fprintf(stderr, "FAILED: %s: default %g outside its range\n", row->field, row->def);
        CHECK(ok);
    }
}

/* `value` given to `row`'s option: accepted (and stored) or refused naming the option, settings unchanged. */
static void check_option(const cv_render_setting *row, const char *value, bool accepted) {
    cv_render_settings s = { .frames = 3 }, before = s;
    cv_result r = cv_render_option_apply(row, value, &s);
    if ((r == CV_OK) != accepted)
        fprintf(stderr, "FAILED: %s '%s' %s: %s\n", row->option, value, accepted ? "refused" : "accepted",
                cv_last_error());
    CHECK((r == CV_OK) == accepted);
    if (accepted) {
        CHECK(memcmp(&s, &before, sizeof s) != 0 || !strcmp(value, "0"));
        return;
    }
    CHECK_EQ_INT(r, CV_ERROR_INVALID_ARGUMENT);
    CHECK(strncmp(cv_last_error(), row->option, strlen(row->option)) == 0);
    CHECK(strstr(cv_last_error(), value) != NULL);
    CHECK(memcmp(&s, &before, sizeof s) == 0);
}

static void check_option_ends(const cv_render_setting *row) {
    char lo[32], hi[32], below[32], above[32];
    snprintf(lo, sizeof lo, "%.10g", row->min);
    snprintf(hi, sizeof hi, "%.10g", row->max);
    snprintf(below, sizeof below, "%.10g", row->min - 1);
    snprintf(above, sizeof above, "%.10g", row->max + 1);
    if (row->kind == CV_SETTING_ON_OFF) {
        check_option(row, "on", true);
        check_option(row, "off", true);
        check_option(row, "maybe", false);
        return;
    }
    check_option(row, lo, !(row->flags & CV_SETTING_MIN_OPEN));
    check_option(row, below, false);
    if (isinf(row->max))
        return;
    check_option(row, hi, !(row->flags & CV_SETTING_MAX_OPEN));
    check_option(row, above, false);
}

static void check_options(void) {
    for (int i = 0; i < CV_RENDER_SETTING_COUNT; i++) {
        const cv_render_setting *row = row_of(i);
        if (!row->option)
            continue;
        CHECK(cv_render_option_find(row->option, strlen(row->option)) != NULL);
        if (!compound(row))
            check_option_ends(row);
    }
    char max[32], over[32];
    double dim = row_of(CV_RENDER_SETTING_width)->max;
    snprintf(max, sizeof max, "%.0fx%.0f", dim, row_of(CV_RENDER_SETTING_height)->max);
    snprintf(over, sizeof over, "%.0fx1", dim + 1);
    const cv_render_setting *size = cv_render_option_find("--size=8x8", 6);
    CHECK(size == row_of(CV_RENDER_SETTING_width));
    check_option(size, "1x1", true);
    check_option(size, max, true);
    check_option(size, "0x1", false);
    check_option(size, over, false);
    char fov_max[64], fov_over[64];
    double fov = row_of(CV_RENDER_SETTING_camera_fov_degrees)->max;
    snprintf(fov_max, sizeof fov_max, "0,1,5,0,1,0,%g", fov);
    snprintf(fov_over, sizeof fov_over, "0,1,5,0,1,0,%g", fov + 1);
    const cv_render_setting *camera = cv_render_option_find("--camera", 8);
    check_option(camera, fov_max, true);
    check_option(camera, "0,1,5,0,1,0,0", false);
    check_option(camera, fov_over, false);
    check_option(camera, "1,1,1,1,1,1,45", false); /* the library's check: eye == target */
    CHECK(strstr(cv_last_error(), "equals its target") != NULL);
    char cone_max[64];
    snprintf(cone_max, sizeof cone_max, "0,1,0,%g", row_of(CV_RENDER_SETTING_sun_cone_degrees)->max);
    const cv_render_setting *sun = cv_render_option_find("--sun", 5);
    check_option(sun, "0,1,0,0", true);
    check_option(sun, cone_max, false);
    check_option(sun, "0,1,0,-1", false);
    check_option(sun, "0,0,0,1", false);
    CHECK(cv_render_option_find("--no-such-option", 16) == NULL);
    /* An option's none value: --filter 0 stores -1, which resolves to 0. */
    cv_render_settings s = { 0 };
    CHECK_OK(cv_render_option_apply(cv_render_option_find("--filter", 8), "0", &s));
    CHECK_EQ_INT(s.filter_iterations, -1);
}

/* The library's check on the fields: each row's max + 1 refused, naming the setting; 0 (the default) passes. */
static void check_fields(void) {
    cv_render_settings zero = { 0 };
    CHECK_OK(cv_render_settings_check(&zero));
    for (int i = 0; i < CV_RENDER_SETTING_COUNT; i++) {
        const cv_render_setting *row = row_of(i);
        if (row->kind == CV_SETTING_VEC3 || isinf(row->max) || row->max >= UINT32_MAX)
            continue;
        cv_render_settings s = { 0 };
        void *p = (char *)&s + row->offset;
        if (row->kind == CV_SETTING_U32)
            *(uint32_t *)p = (uint32_t)row->max + 1;
        else if (row->kind == CV_SETTING_F32)
            *(float *)p = (float)row->max + 1.0f;
        else
            *(int32_t *)p = (int32_t)row->max + 2; /* on/off: 2 */
        CHECK_EQ_INT(cv_render_settings_check(&s), CV_ERROR_OUT_OF_RANGE);
        if (!strstr(cv_last_error(), row->name))
            fprintf(stderr, "FAILED: %s: '%s' does not name '%s'\n", row->field, cv_last_error(), row->name);
        CHECK(strstr(cv_last_error(), row->name) != NULL);
    }
    cv_render_settings nan_orbit = { .orbit_degrees = NAN };
    CHECK_EQ_INT(cv_render_settings_check(&nan_orbit), CV_ERROR_INVALID_ARGUMENT);
    CHECK(strstr(cv_last_error(), "orbit") != NULL);
}

static void check_resolve(void) {
    cv_scene *scene = NULL;
    CHECK_OK(cv_scene_make_room(1, &scene));
    cv_render_settings r = cv_render_settings_resolve(&(cv_render_settings){ .reflection_radius = -1 }, scene);
    CHECK_EQ_INT(r.width, row_of(CV_RENDER_SETTING_width)->def);
    CHECK_EQ_INT(r.frames, row_of(CV_RENDER_SETTING_frames)->def);
    CHECK_EQ_INT(r.band_rays, CV_RENDER_BAND_RAYS);
    CHECK_EQ_INT(r.filter_iterations, row_of(CV_RENDER_SETTING_filter_iterations)->def);
    CHECK_EQ_INT(r.reflections, 1);
    CHECK_EQ_INT(r.reflection_radius, 0); /* none */
    CHECK(r.sun_cone_degrees == (float)row_of(CV_RENDER_SETTING_sun_cone_degrees)->def);
    CHECK(r.ao_radius > 0.0f && r.camera_fov_degrees == 0.0f); /* the scene's camera stays */
    CHECK_OK(cv_render_settings_check(&r));
    cv_scene_destroy(scene);
}

static void check_help(void) {
    char *text = NULL;
    size_t size = 0;
    FILE *f = open_memstream(&text, &size);
    CHECK(f != NULL);
    if (!f)
        return;
    cv_render_options_help(f);
    fclose(f);
    for (int i = 0; i < CV_RENDER_SETTING_COUNT; i++) {
        const cv_render_setting *row = row_of(i);
        if (!row->option || row->kind == CV_SETTING_VEC3)
            continue;
        char range[96];
        cv_render_setting_range(row, range, sizeof range);
        bool listed = strstr(text, row->option) && strstr(text, range);
        if (!listed)
            fprintf(stderr, "FAILED: help lacks %s or its range %s\n", row->option, range);
        CHECK(listed);
    }
    free(text);
}

int main(void) {
    check_defaults();
    check_options();
    check_fields();
    check_resolve();
    check_help();
    CHECK_NOTHING_LIVE();
    return check_report("render_settings");
}
