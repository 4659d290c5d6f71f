/* What the context shares with device.c: the device list and the command
 * lists behind cmdlist handles. Lock order: a device's lock may be held while
 * taking the context's lock, never the other way round. */
#ifndef CORVID_CONTEXT_INTERNAL_H
#define CORVID_CONTEXT_INTERNAL_H

#include "corvid/context.h"
#include "corvid/device.h"

/* Attach/detach a device (called by cv_device_create/destroy). */
cv_result cv_context_attach_device(cv_context *ctx, cv_device *dev);
void cv_context_detach_device(cv_context *ctx, cv_device *dev);

/* The ended, error-free list behind h (BAD_STATE if still recording or failed). */
cv_result cv_context_executable_list(cv_context *ctx, uint64_t id, cv_command_list **out);

/* Device-side unload used when the context destroys a handle. */
void cv_device_forget(cv_device *dev, uint64_t id);

#endif
