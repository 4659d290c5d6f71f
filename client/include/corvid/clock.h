/* Time for measuring and for waiting: one monotonic clock and deadlines on it.
 *
 * Durations are measured with cv_now_ns / cv_now_ms (CLOCK_MONOTONIC: never
 * jumps with the wall clock). A deadline is an absolute point on that clock in
 * nanoseconds (uint64_t), made once before a wait loop so that spurious wakeups
 * and retries do not stretch the wait; CV_DEADLINE_NEVER waits forever. The
 * arithmetic saturates: a timeout too large to add lands on CV_DEADLINE_NEVER,
 * never wraps into the past.
 *
 * Condition variables that wait on deadlines are made with cv_cond_init, which
 * puts them on CLOCK_MONOTONIC (a default one, on CLOCK_REALTIME, would wait
 * an hour longer when the wall clock is set back an hour); cv_cond_wait_until
 * then waits on them.
 *
 *     uint64_t deadline = cv_deadline_after_ms(timeout_ms);
 *     pthread_mutex_lock(&q->lock);
 *     while (!q->ready && cv_cond_wait_until(&q->cond, &q->lock, deadline) == 0) {
 *     }
 *     bool timed_out = !q->ready;
 *
 *     double start = cv_now_ms();
 *     work();
 *     stats->work_ms = cv_now_ms() - start;
 */
#ifndef CORVID_CLOCK_H
#define CORVID_CLOCK_H

#include <pthread.h>
#include <stdbool.h>
#include <stdint.h>
#include <time.h>

/* A deadline that never passes. */
#define CV_DEADLINE_NEVER UINT64_MAX

/* CLOCK_MONOTONIC in nanoseconds and in (fractional) milliseconds. */
uint64_t cv_now_ns(void);
double cv_now_ms(void);

/* The deadline `ns` / `ms` from now; CV_DEADLINE_NEVER when that is past the clock's range,
 * and for ns == UINT64_MAX (a "forever" timeout passes through unchanged). */
uint64_t cv_deadline_after_ns(uint64_t ns);
uint64_t cv_deadline_after_ms(uint64_t ms);
/* The earlier of two deadlines (a wait in slices: cv_deadline_min(slice, overall)). */
uint64_t cv_deadline_min(uint64_t a, uint64_t b);
/* Whether the deadline has passed. Never for CV_DEADLINE_NEVER. */
bool cv_deadline_passed(uint64_t deadline);
/* Nanoseconds left until the deadline: 0 once it has passed, UINT64_MAX for CV_DEADLINE_NEVER. */
uint64_t cv_deadline_left_ns(uint64_t deadline);

/* The deadline as a CLOCK_MONOTONIC timespec, for calls that take one (pthread_cond_timedwait on a
 * cv_cond_init condition variable, sem_clockwait). CV_DEADLINE_NEVER maps to a time centuries away. */
struct timespec cv_deadline_timespec(uint64_t deadline);

/* Initialises a condition variable on CLOCK_MONOTONIC (pthread_cond_init's return). */
int cv_cond_init(pthread_cond_t *cond);
/* Waits on a cv_cond_init condition variable (mutex held) until signalled or the deadline
 * passes: 0 or ETIMEDOUT. CV_DEADLINE_NEVER waits without a timeout. */
int cv_cond_wait_until(pthread_cond_t *cond, pthread_mutex_t *mutex, uint64_t deadline);

#endif
