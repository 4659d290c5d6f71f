/* The render graph's environment, for programs: CORVID_ZERO_COPY and
 * CORVID_TRANSFER_ASYNC, read into the cv_graph_bake_desc fields the graph
 * takes (graph.h: zero_copy, sync_transfers). The library itself never reads
 * the environment.
 *
 *     cv_graph_bake_desc bake = { .width = w, .tile = 8 };
 *     if (cv_env_graph_bake(&bake) != CV_OK) {              // at the start
 *         fprintf(stderr, "prog: %s\n", cv_last_error());   // names the variable
 *         return 1;
 *     }
 *
 * Variables (unset or empty: the default):
 *   CORVID_ZERO_COPY=auto|on|off  gathers through memory the devices share: auto
 *                                 (default) where they can, on or the bake fails,
 *                                 off copies (cv_graph_zero_copy)
 *   CORVID_TRANSFER_ASYNC=0|1     0: every transfer synchronous on the host, as
 *                                 before transfer rings (for comparisons); 1
 *                                 (default): asynchronous where the pair allows */
#ifndef CORVID_ENV_GRAPH_H
#define CORVID_ENV_GRAPH_H

#include "corvid/graph.h"

/* CORVID_ZERO_COPY into *out; a value other than auto, on or off is
 * CV_ERROR_INVALID_ARGUMENT naming it, and *out is left as it was. */
cv_result cv_env_graph_zero_copy(cv_graph_zero_copy *out);
/* CORVID_TRANSFER_ASYNC into *sync_transfers (true for "0"); a value other
 * than 0 or 1 is CV_ERROR_INVALID_ARGUMENT naming it, and *sync_transfers is
 * left as it was. */
cv_result cv_env_graph_sync_transfers(bool *sync_transfers);
/* Both into desc's zero_copy and sync_transfers; on a bad variable neither
 * is set. */
cv_result cv_env_graph_bake(cv_graph_bake_desc *desc);

#endif
