/* Allocation of the big BVH arrays (hundreds of MB at 10M triangles): on
 * Linux they are backed by transparent huge pages where the system allows
 * it on request, which cuts the page-fault and page-clearing time of the
 * first touch several-fold. Free with free(). */
#ifndef CORVID_SCENE_BIG_ALLOC_H
#define CORVID_SCENE_BIG_ALLOC_H

#include <stddef.h>

/* Like malloc(size), never NULL for size 0 unless out of memory. */
void *cvs_big_alloc(size_t size);

#endif
