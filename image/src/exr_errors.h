/* Turning OpenEXRCore failures into cv_error results. The library reports
 * details through a callback; exr_capture_error keeps the latest message of
 * the calling thread so the cv_error can quote it. */
#ifndef CORVID_IMAGE_EXR_ERRORS_H
#define CORVID_IMAGE_EXR_ERRORS_H

#include <openexr.h>

#include "corvid/result.h"

/* The error_handler_fn given to every context we create. */
void exr_capture_error(exr_const_context_t ctxt, exr_result_t code, const char *msg);
void exr_clear_captured_error(void);

/* cv_error("<path>: <what>: <library message>") with `code`. */
cv_result exr_fail(cv_result code, const char *path, const char *what, exr_result_t rv);

/* The Corvid code for a library failure while reading: a file that is not a
 * valid or complete EXR is MALFORMED, a failed system call is IO. */
cv_result exr_read_result(exr_result_t rv, int read_errno);

#endif
