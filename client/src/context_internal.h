/* What the context shares with the devices attached to it (device.c): the
 * command lists behind cmdlist handles, and the attachment itself. The context
 * sits below the devices: it never calls device code, it calls the ops a
 * member registered when it attached. Lock order: a member's lock may be held
 * while taking the context's lock, never the other way round. */
#ifndef CORVID_CONTEXT_INTERNAL_H
#define CORVID_CONTEXT_INTERNAL_H

#include "corvid/context.h"

/* What the context asks of an attached member (a device), without its lock held. */
typedef struct cv_context_member_ops {
    /* Handle `id` was destroyed: drop the member's representation of it. */
    void (*forget)(void *member, uint64_t id);
    /* The context is being destroyed: the member goes now (and detaches itself). */
    void (*destroy)(void *member);
} cv_context_member_ops;

/* Attach/detach a member (called by cv_device_create/destroy). */
cv_result cv_context_attach(cv_context *ctx, void *member, const cv_context_member_ops *ops);
void cv_context_detach(cv_context *ctx, void *member);

/* The ended, error-free list behind h (BAD_STATE if still recording or failed). */
cv_result cv_context_executable_list(cv_context *ctx, uint64_t id, cv_command_list **out);

#endif
