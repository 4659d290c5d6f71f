/* A small set of resources loaded on one device, shared by the conformance
 * bodies, plus helpers to record and run a list in one call. */
#ifndef CORVID_CONFORMANCE_WORLD_H
#define CORVID_CONFORMANCE_WORLD_H

#include "fixture.h"

typedef struct world {
    const fixture *fx;
    cv_context *ctx;
    cv_device *dev;
    cv_buffer small;    /* 256 B, storage */
    cv_buffer big;      /* 64 KiB, storage|index|indirect|uniform */
    cv_buffer plain;    /* 1 KiB, uniform only */
    cv_texture rgba8;   /* 16x16, sampled|storage|color target */
    cv_texture rgba8_b; /* 16x16, same */
    cv_texture rgba32f; /* 16x16, sampled|storage */
    cv_texture sampled; /* 16x16 rgba8, sampled only */
    cv_texture depth;   /* 16x16 D32F */
    cv_sampler sampler;
    cv_pipeline fill, saxpy, gradient, sample_copy, triangle;
    cv_accel accel;         /* one triangle, data written */
    cv_accel accel_unbuilt; /* loaded, no data written */
    cv_buffer unloaded;     /* live handle, never loaded on dev */
    cv_buffer destroyed;    /* destroyed handle */
    cv_cmdlist list;
} world;

cv_result world_init(world *w, const fixture *fx);
void world_finish(world *w);

/* Begins w->list and returns the recorder. */
cv_command_list *world_begin(world *w);
/* Ends the list and submits it; the first failure's code (waits on success). */
cv_result world_end_and_run(world *w);

#endif
