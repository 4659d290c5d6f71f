/* Result names, descriptions and the per-thread error message. */
#include "corvid/result.h"

#include <stdio.h>
#include <stdlib.h>

#include "corvid/log.h"

/* process-wide: one message per thread, the C library's errno's way: a failing call returns a code, and
 * the words stay with the thread that made the call until its next failure. */
static _Thread_local char last_error[CV_ERROR_MESSAGE_MAX];

const char *cv_result_name(cv_result r) {
    switch (r) {
#define CV_RESULT_NAME(name, value, text) \
    case name: return #name;
        CV_RESULT_TABLE(CV_RESULT_NAME)
#undef CV_RESULT_NAME
    }
    return "CV_RESULT_UNKNOWN";
}

const char *cv_result_string(cv_result r) {
    switch (r) {
#define CV_RESULT_TEXT(name, value, text) \
    case name: return text;
        CV_RESULT_TABLE(CV_RESULT_TEXT)
#undef CV_RESULT_TEXT
    }
    return "unknown result code";
}

const char *cv_last_error(void) { return last_error; }

void cv_clear_error(void) { last_error[0] = '\0'; }

/* A message longer than last_error keeps its start and its end, cut in the
 * middle: a long path is most of such a message, and the reason comes after
 * it ("<4000-character path>: File name too long" must still say why). The
 * cut does not split a UTF-8 character. */
static void keep_ends(const char *full, size_t len) {
    const char cut[] = " [...] ";
    size_t head = sizeof(last_error) / 4, tail = sizeof(last_error) - 1 - head - (sizeof cut - 1);
    while (head > 0 && ((unsigned char)full[head] & 0xC0) == 0x80)
        head--;
    size_t from = len - tail;
    while (from < len && ((unsigned char)full[from] & 0xC0) == 0x80)
        from++;
    snprintf(last_error, sizeof(last_error), "%.*s%s%s", (int)head, full, cut, full + from);
}

cv_result cv_verror(cv_result code, const char *fmt, va_list ap) {
    char message[sizeof(last_error)]; /* the arguments may quote last_error itself */
    va_list again;
    va_copy(again, ap);
    int len = vsnprintf(message, sizeof(message), fmt, ap);
    char *full = len >= (int)sizeof(message) ? malloc((size_t)len + 1) : NULL;
    if (full) {
        vsnprintf(full, (size_t)len + 1, fmt, again);
        keep_ends(full, (size_t)len);
        free(full);
    } else {
        snprintf(last_error, sizeof(last_error), "%s", message);
    }
    va_end(again);
    if (cv_log_enabled(CV_LOG_DEBUG))
        cv_log(CV_LOG_DEBUG, "error", "%s: %s", cv_result_name(code), last_error);
    return code;
}

cv_result cv_error(cv_result code, const char *fmt, ...) {
    va_list ap;
    va_start(ap, fmt);
    cv_verror(code, fmt, ap);
    va_end(ap);
    return code;
}
