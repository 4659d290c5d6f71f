/* Fresh resources read as zeros on every backend (support/fresh_shapes.h):
 * markers written into resources of several sizes and formats must not show
 * up in new resources of the same shapes, twice over. */
#include "conformance.h"
#include "fresh_shapes.h"

void conformance_fresh_resources(world *w) {
    for (int round = 0; round < 2; round++) {
        fresh_leave_markers(w->ctx, w->dev);
        fresh_expect_zeros(w->ctx, w->dev, w->fx->name);
    }
}
