/* Helpers for the benchmarks: a monotonic clock, a parallel loop over index
 * ranges on pthreads (the same threads for every peer being compared), and a
 * description of the machine for the report header. */
#ifndef CORVID_BENCH_UTIL_H
#define CORVID_BENCH_UTIL_H

#include <stddef.h>
#include <stdint.h>

double bench_now(void); /* seconds, monotonic */

/* fn(ctx, begin, end) over [0, count) in chunks of `chunk`, on `threads` threads. */
typedef void (*bench_range_fn)(void *ctx, size_t begin, size_t end);
void bench_parallel(uint32_t threads, size_t count, size_t chunk, bench_range_fn fn, void *ctx);

/* "Intel(R) Xeon(R) ..., 2 online CPUs" into buf. */
void bench_machine(char *buf, size_t size);

#endif
