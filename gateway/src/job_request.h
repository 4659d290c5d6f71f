/* A job's request (POST /api/v1/jobs) read from its JSON body and checked
 * whole before anything starts: the fields
 *
 *   {"scene": "<sha256>" | "default", "width": 64, "height": 48, "frames": 4,
 *    "camera": {"eye": [x, y, z], "target": [x, y, z], "fov_degrees": 45},
 *    "settings": {"ao-samples": 8, "reflections": "off", "sun": "0,1,0,1.5", ...}}
 *
 * all optional (the table's defaults; "default" is the built-in room). The
 * settings are the programs' options without their "--" (corvid/render_options.h):
 * each value (a number, a string, true/false for on/off) goes through
 * cv_render_option_apply, so its name, range and message are the table's.
 * Errors are CV_ERROR_INVALID_ARGUMENT naming the field ("settings.ao-samples:
 * '40' is not a whole number in 1..32", "unknown field 'colour'"). */
#ifndef CORVID_GATEWAY_JOB_REQUEST_H
#define CORVID_GATEWAY_JOB_REQUEST_H

#include <stddef.h>
#include <stdint.h>

#include "corvid/render_settings.h"
#include "corvid/result.h"
#include "corvid/sha256.h"

#define GW_DEFAULT_SCENE "default"

typedef struct gw_job_request {
    char scene[CV_SHA256_HEX_SIZE]; /* 64 lowercase hex digits, or GW_DEFAULT_SCENE */
    cv_render_settings settings;    /* checked with cv_render_settings_check */
} gw_job_request;

/* max_pixels: the most width * height accepted. */
cv_result gw_job_request_parse(const uint8_t *body, size_t size, uint64_t max_pixels, gw_job_request *out);

#endif
