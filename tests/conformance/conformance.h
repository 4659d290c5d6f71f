/* Conformance test bodies, run on every backend fixture. */
#ifndef CORVID_CONFORMANCE_H
#define CORVID_CONFORMANCE_H

#include "world.h"

void conformance_bad_lists(world *w);
void conformance_resources(world *w);
void conformance_fresh_resources(world *w);
void conformance_data_movement(world *w);
void conformance_resubmit(world *w);
void conformance_lifetimes(world *w);
void conformance_timings(world *w);
void conformance_indirect(world *w);
void conformance_encode(world *w);
void conformance_transfers(const fixture *fx);
void conformance_parallel(const fixture *fx);

#endif
