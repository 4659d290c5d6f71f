/* Fresh resources must read as zeros: memory a new buffer or texture gets may
 * hold what an earlier owner left there (on a node, another session's data).
 * These helpers write a marker into resources of several sizes and formats
 * and check that new resources of the same shapes read as zeros; the
 * conformance suite runs them on every backend, the node suite across two
 * sessions of one node. */
#ifndef CORVID_TEST_FRESH_SHAPES_H
#define CORVID_TEST_FRESH_SHAPES_H

#include "corvid/device.h"

/* Creates every shape on dev, fills each with the marker byte, waits, and
 * destroys them (counted checks). */
void fresh_leave_markers(cv_context *ctx, cv_device *dev);
/* Creates every shape on dev and checks that each reads as zeros before any
 * write (counted checks; `where` names the case in failure messages). Returns
 * the number of nonzero bytes found. */
size_t fresh_expect_zeros(cv_context *ctx, cv_device *dev, const char *where);

#endif
