/* Running work on all cores with plain pthreads: the thread count policy and
 * a dynamically scheduled parallel loop over index ranges. */
#ifndef CORVID_SCENE_PARALLEL_H
#define CORVID_SCENE_PARALLEL_H

#include <stddef.h>
#include <stdint.h>

#define CVS_MAX_THREADS 256u

/* `requested`, or the number of online CPUs when 0; clamped to 1..CVS_MAX_THREADS. */
uint32_t cvs_thread_count(uint32_t requested);

/* Called with disjoint [begin, end) ranges covering [0, count); `worker` is
 * 0..threads-1 (for per-thread scratch). */
typedef void (*cvs_range_fn)(void *ctx, size_t begin, size_t end, uint32_t worker);

/* Runs fn over [0, count) in chunks of `chunk` items on up to `threads`
 * threads (the caller's included). Falls back to fewer threads when thread
 * creation fails; never fails itself. */
void cvs_parallel_for(uint32_t threads, size_t count, size_t chunk, cvs_range_fn fn, void *ctx);

#endif
