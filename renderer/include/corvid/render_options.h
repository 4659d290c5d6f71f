/* The programs' command-line options for the renderer's settings, made from
 * CV_RENDER_SETTINGS_TABLE (corvid/render_settings.h): corvid-render and
 * corvid-view parse and explain them here, so a setting's option, range,
 * default and help are the table's in every program.
 *
 * An option is a row of the table with an option name ("--frames"); the rows
 * that share a compound option (--size WxH, --camera EX,EY,EZ,TX,TY,TZ,FOV,
 * --sun DX,DY,DZ,A) are set together by it, and the option is named by its
 * first row. Every settings option takes a value.
 *
 *   cv_render_settings s = { 0 };
 *   const cv_render_setting *opt = cv_render_option_find("--frames", 8);
 *   if (opt && cv_render_option_apply(opt, "5000", &s) != CV_OK)
 *       fprintf(stderr, "prog: %s\n", cv_last_error()); // "--frames: '5000' is not a whole number in <min>..<max>"
 *   cv_render_options_help(stdout);                     // "  --frames N   frames accumulated ... (<min>..<max>; default <def>)"
 *
 * A program's own options can print their help lines with
 * cv_render_help_entry, in the same layout. */
#ifndef CORVID_RENDER_OPTIONS_H
#define CORVID_RENDER_OPTIONS_H

#include <stdio.h>

#include "corvid/render_settings.h"

/* The option whose name is the first `len` characters of `name` (so
 * "--frames=4" can be looked up with len 8): its first row, or NULL when no
 * setting has that option. */
const cv_render_setting *cv_render_option_find(const char *name, size_t len);

/* Parses `value` as the option's value into *s, then checks the result as
 * cv_render_settings_check does. On failure *s is unchanged and the error
 * (CV_ERROR_INVALID_ARGUMENT) names the option, the value and what it must be:
 * "--frames: '5000' is not a whole number in <min>..<max>", or the check's message
 * after "--camera: '1,1,1,1,1,1,45': ". */
cv_result cv_render_option_apply(const cv_render_setting *option, const char *value, cv_render_settings *s);

/* One help line per settings option, in the table's order: its name and
 * metavar, its help text, its range and its default. */
void cv_render_options_help(FILE *f);

/* A help entry in the options' layout: "  --name VALUE      text", the text
 * wrapped at 100 columns under its first line. */
void cv_render_help_entry(FILE *f, const char *name_and_metavar, const char *text);

#endif
