/* The monotonic clock, deadlines on it and condition variables that wait for them (corvid/clock.h). */
#include "corvid/clock.h"

#include <errno.h>

#define NS_PER_S UINT64_C(1000000000)

uint64_t cv_now_ns(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (uint64_t)t.tv_sec * NS_PER_S + (uint64_t)t.tv_nsec;
}

double cv_now_ms(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec * 1e3 + (double)t.tv_nsec / 1e6;
}

uint64_t cv_deadline_after_ns(uint64_t ns) {
    uint64_t now = cv_now_ns();
    return ns >= CV_DEADLINE_NEVER - now ? CV_DEADLINE_NEVER : now + ns;
}

uint64_t cv_deadline_after_ms(uint64_t ms) {
    return ms > UINT64_MAX / 1000000u ? CV_DEADLINE_NEVER : cv_deadline_after_ns(ms * 1000000u);
}

uint64_t cv_deadline_min(uint64_t a, uint64_t b) { return a < b ? a : b; }

bool cv_deadline_passed(uint64_t deadline) { return deadline != CV_DEADLINE_NEVER && cv_now_ns() >= deadline; }

uint64_t cv_deadline_left_ns(uint64_t deadline) {
    if (deadline == CV_DEADLINE_NEVER)
        return UINT64_MAX;
    uint64_t now = cv_now_ns();
    return deadline > now ? deadline - now : 0;
}

struct timespec cv_deadline_timespec(uint64_t deadline) {
    return (struct timespec){ .tv_sec = (time_t)(deadline / NS_PER_S), .tv_nsec = (long)(deadline % NS_PER_S) };
}

int cv_cond_init(pthread_cond_t *cond) {
    pthread_condattr_t attr;
    pthread_condattr_init(&attr);
    pthread_condattr_setclock(&attr, CLOCK_MONOTONIC);
    int r = pthread_cond_init(cond, &attr);
    pthread_condattr_destroy(&attr);
    return r;
}

int cv_cond_wait_until(pthread_cond_t *cond, pthread_mutex_t *mutex, uint64_t deadline) {
    if (deadline == CV_DEADLINE_NEVER)
        return pthread_cond_wait(cond, mutex);
    struct timespec at = cv_deadline_timespec(deadline);
    int r = pthread_cond_timedwait(cond, mutex, &at);
    return r == ETIMEDOUT ? ETIMEDOUT : 0;
}
