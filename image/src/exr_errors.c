/* See exr_errors.h. */
#include <stdio.h>

#include "exr_errors.h"

/* process-wide (one per thread): OpenEXR's error callback receives no user pointer we own, so the message
 * of the failing call waits here for the same thread to read it right after. */
static _Thread_local char captured[512];

void exr_capture_error(exr_const_context_t ctxt, exr_result_t code, const char *msg) {
    (void)ctxt;
    snprintf(captured, sizeof captured, "%s", msg != NULL ? msg : exr_get_error_code_as_string(code));
}

void exr_clear_captured_error(void) { captured[0] = '\0'; }

cv_result exr_fail(cv_result code, const char *path, const char *what, exr_result_t rv) {
    const char *detail = captured[0] != '\0' ? captured : exr_get_default_error_message(rv);
    return cv_error(code, "%s: %s: %s (%s)", path, what, detail, exr_get_error_code_as_string(rv));
}

cv_result exr_read_result(exr_result_t rv, int read_errno) {
    switch (rv) {
    case EXR_ERR_OUT_OF_MEMORY: return CV_ERROR_OUT_OF_MEMORY;
    case EXR_ERR_FILE_ACCESS: return CV_ERROR_IO;
    case EXR_ERR_READ_IO:
        /* A short read (the file ends early) is a truncated file, not an
         * I/O failure; only a failing read call sets read_errno. */
        return read_errno != 0 ? CV_ERROR_IO : CV_ERROR_MALFORMED;
    case EXR_ERR_FEATURE_NOT_IMPLEMENTED: return CV_ERROR_UNSUPPORTED;
    default: return CV_ERROR_MALFORMED;
    }
}
