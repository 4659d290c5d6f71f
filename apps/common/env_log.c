/* The log sink's settings from the environment (env_log.h). */
#include "env_log.h"

#include <stdlib.h>
#include <string.h>

cv_log_level env_log_level(void) {
    const char *v = getenv("CORVID_LOG_ERRORS");
    return v && v[0] && strcmp(v, "0") != 0 ? CV_LOG_DEBUG : CV_LOG_INFO;
}

void env_log_apply(void) { cv_log_set_sink(NULL, NULL, env_log_level()); }
