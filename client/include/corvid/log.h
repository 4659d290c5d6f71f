/* The log sink: where every library message goes.
 *
 * Library code never prints. It calls cv_log() with a level and an origin (the
 * module speaking: "rpc", "node", "error"), and the one sink of the process
 * decides: by default stderr, one line "corvid <origin>: <message>", messages
 * up to CV_LOG_INFO. A program sets the sink once at start (an embedding
 * application routes the lines into its own log); tests capture them.
 *
 *     static void to_my_log(cv_log_level level, const char *origin, const char *message, void *user) {
 *         my_log_write(user, level, origin, message);
 *     }
 *     cv_log_set_sink(to_my_log, my_log, CV_LOG_INFO);
 *     cv_log(CV_LOG_WARNING, "rpc", "stream from %s dropped: %s", peer, why);
 *
 * The sink is called with an internal lock held, one message at a time: lines
 * never interleave, and once cv_log_set_sink returns the previous sink is no
 * longer running. A sink must therefore not call cv_log or cv_log_set_sink.
 * cv_log_enabled is one atomic load, for callers whose message is costly to
 * build. */
#ifndef CORVID_LOG_H
#define CORVID_LOG_H

#include <stdbool.h>

typedef enum cv_log_level { CV_LOG_ERROR = 0, CV_LOG_WARNING, CV_LOG_INFO, CV_LOG_DEBUG } cv_log_level;

typedef void (*cv_log_fn)(cv_log_level level, const char *origin, const char *message, void *user);

/* One sink per process (process-wide: set by the program at start); NULL fn = stderr,
   "corvid <origin>: <message>\n". Messages above max_level are dropped. Thread-safe. */
void cv_log_set_sink(cv_log_fn fn, void *user, cv_log_level max_level);
/* Whether a message of `level` would reach the sink now. */
bool cv_log_enabled(cv_log_level level);
/* Formats and hands one message (no trailing newline) to the sink. */
void cv_log(cv_log_level level, const char *origin, const char *fmt, ...) __attribute__((format(printf, 3, 4)));

#endif
