/* The log sink's settings from the environment, for programs (library code reads no environment).
 *
 *   CORVID_LOG_ERRORS=1   every error message (cv_error) also goes to the log as it is made, at
 *                         CV_LOG_DEBUG with origin "error"; without it the sink takes CV_LOG_INFO
 *
 *     int main(int argc, char **argv) {
 *         env_log_apply();    (stderr, "corvid <origin>: <message>" lines)
 *         ...
 *     }
 *
 * A program with a sink of its own passes env_log_level() to cv_log_set_sink. */
#ifndef CORVID_ENV_LOG_H
#define CORVID_ENV_LOG_H

#include "corvid/log.h"

/* CV_LOG_DEBUG when CORVID_LOG_ERRORS is set to anything but "" or "0", else CV_LOG_INFO. */
cv_log_level env_log_level(void);
/* The default (stderr) sink at env_log_level(). */
void env_log_apply(void);

#endif
