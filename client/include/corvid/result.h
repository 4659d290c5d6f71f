/* Corvid result codes and error messages.
 *
 * Every fallible call returns a cv_result: CV_OK (0) or a negative error code.
 * A call that fails changes nothing. The code says what kind of failure it was;
 * cv_last_error() says, in words, exactly what was wrong (which handle, which
 * field, which limit) for the last failure on the calling thread.
 *
 * All codes live in one X-macro table so names, numbers and descriptions never
 * drift apart (the wire protocol carries the numbers). */
#ifndef CORVID_RESULT_H
#define CORVID_RESULT_H

#include <stdarg.h>

/* X(NAME, value, description) */
/* clang-format off */
#define CV_RESULT_TABLE(X)                                                                   \
    X(CV_OK, 0, "success")                                                                   \
    X(CV_ERROR_INVALID_ARGUMENT, -1, "invalid argument")                                     \
    X(CV_ERROR_INVALID_HANDLE, -2, "invalid handle (null or malformed)")                     \
    X(CV_ERROR_STALE_HANDLE, -3, "stale handle (its resource was destroyed)")                \
    X(CV_ERROR_WRONG_HANDLE_TYPE, -4, "handle of the wrong resource type")                   \
    X(CV_ERROR_OUT_OF_HANDLES, -5, "handle pool exhausted")                                  \
    X(CV_ERROR_OUT_OF_MEMORY, -6, "out of memory")                                           \
    X(CV_ERROR_OUT_OF_RANGE, -7, "offset, size or region out of range")                      \
    X(CV_ERROR_QUEUE_MISMATCH, -8, "command not allowed on this queue type")                 \
    X(CV_ERROR_NOT_LOADED, -9, "handle not loaded on this device")                           \
    X(CV_ERROR_ALREADY_LOADED, -10, "handle already loaded on this device")                  \
    X(CV_ERROR_FORMAT_MISMATCH, -11, "texture formats or sizes do not match")                \
    X(CV_ERROR_USAGE_MISMATCH, -12, "resource was not created with the needed usage")        \
    X(CV_ERROR_BAD_STATE, -13, "call not valid in the current state")                        \
    X(CV_ERROR_UNKNOWN_PIPELINE, -14, "no pipeline of that name in the registry")            \
    X(CV_ERROR_BINDING_MISMATCH, -15, "bindings do not match the pipeline's layout")         \
    X(CV_ERROR_LIMIT_EXCEEDED, -16, "a fixed limit was exceeded")                            \
    X(CV_ERROR_UNSUPPORTED, -17, "not supported by this device or backend")                  \
    X(CV_ERROR_DEVICE_LOST, -18, "device lost")                                              \
    X(CV_ERROR_BACKEND, -19, "the backend API reported an error")                            \
    X(CV_ERROR_TIMEOUT, -20, "timed out")                                                    \
    X(CV_ERROR_MALFORMED, -21, "malformed message or file")                                  \
    X(CV_ERROR_IO, -22, "input/output error")                                                \
    X(CV_ERROR_NOT_FOUND, -23, "not found")                                                  \
    X(CV_ERROR_CONNECTION, -24, "connection failed or dropped")                              \
    X(CV_ERROR_FOREIGN_HANDLE, -25, "handle belongs to another context")                     \
    X(CV_ERROR_ALREADY_EXISTS, -26, "already exists")                                        \
    X(CV_ERROR_HASH_MISMATCH, -27, "content does not match its hash")
/* clang-format on */

typedef enum cv_result {
#define CV_RESULT_ENUM(name, value, text) name = value,
    CV_RESULT_TABLE(CV_RESULT_ENUM)
#undef CV_RESULT_ENUM
} cv_result;

/* "CV_ERROR_STALE_HANDLE", or "CV_RESULT_UNKNOWN" for a value not in the table. */
const char *cv_result_name(cv_result r);
/* "stale handle (its resource was destroyed)". */
const char *cv_result_string(cv_result r);

/* The longest message kept, terminating NUL included; a longer one keeps its
 * first quarter and its end, cut in the middle by " [...] " (the reason that
 * follows a long path survives). */
#define CV_ERROR_MESSAGE_MAX 4096

/* The detailed message of the last failure on this thread ("" if none). */
const char *cv_last_error(void);
void cv_clear_error(void);

/* Records a formatted message for this thread and returns `code`, so an error
 * path reads `return cv_error(CV_ERROR_OUT_OF_RANGE, "copy of %u bytes ...", n);`.
 * Also logs it at CV_LOG_DEBUG with origin "error" (corvid/log.h; programs turn that on for
 * CORVID_LOG_ERRORS=1). */
cv_result cv_error(cv_result code, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
cv_result cv_verror(cv_result code, const char *fmt, va_list ap);

#endif
