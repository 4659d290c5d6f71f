/* corvid-render's output files: PREFIX.exr and PREFIX.png, and the --stats,
 * --trace and --dump-graph files (and FILE.dot) when asked for. All of them
 * are reserved as temporaries in their folders before anything is rendered (a
 * destination that cannot take them fails at once, not after the render),
 * must be distinct files, are written to their temporaries, and are renamed
 * into place together only when every one is complete (a cv_file_set). On a
 * failure, or on SIGINT / SIGTERM, the temporaries and the folders --out
 * created are removed. */
#ifndef CORVID_APPS_RENDER_OUTPUTS_H
#define CORVID_APPS_RENDER_OUTPUTS_H

#include <stddef.h>

#include "corvid/image_files.h"

typedef struct outputs {
    char *exr, *png;                     /* final names */
    char *dot;                           /* --dump-graph's FILE.dot; NULL without it */
    const char *exr_temp, *png_temp;     /* where to write them */
    const char *stats_temp, *trace_temp; /* --stats, --trace; NULL when not asked for */
    const char *graph_temp, *dot_temp;   /* --dump-graph FILE and FILE.dot */
    cv_file_set *set;
    char *made;      /* the folders this run created, to remove on failure; NULL if none */
    size_t made_top; /* length of the top-most folder created */
} outputs;

/* The files asked for (stats, trace, graph may be NULL), reserved in that
 * order; refuses two options naming one file ("--trace: 'x' is also the
 * --stats file"). */
cv_result outputs_reserve(outputs *out, const char *prefix, const char *stats, const char *trace, const char *graph);

/* Removes the temporaries, then the folders outputs_reserve created. */
void outputs_discard(outputs *out);

void outputs_free(outputs *out);

/* From now until outputs_release_signals: SIGINT and SIGTERM remove every
 * temporary and the folders --out created, then exit 130 / 143. */
void outputs_catch_signals(const outputs *out);

/* Back to the default handling (after the files are in place). */
void outputs_release_signals(void);

#endif
