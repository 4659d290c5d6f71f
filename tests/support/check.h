/* Minimal assertions for Corvid's C tests: each failed check prints where and
 * why and is counted; check_report() checks that nothing the test made is
 * still live, prints a summary and gives main's exit code. Checks do not
 * abort, so one run reports every failure. */
#ifndef CORVID_TEST_CHECK_H
#define CORVID_TEST_CHECK_H

#include <inttypes.h>
#include <stdint.h>
#include <stdio.h>
#include "corvid/context.h"
#include "corvid/result.h"

extern int check_failures;
extern int check_count;

#define CHECK(cond) \
    do { \
        check_count++; \
        if (!(cond)) { \
            check_failures++; \
            fprintf(stderr, "%s:%d: CHECK failed: %s\n", __FILE__, __LINE__, #cond); \
        } \
    } while (0)

#define CHECK_EQ_INT(a, b) \
    do { \
        long long check_a_ = (long long)(a), check_b_ = (long long)(b); \
        check_count++; \
        if (check_a_ != check_b_) { \
            check_failures++; \
            fprintf(stderr, "%s:%d: CHECK_EQ_INT failed: %s = %lld, %s = %lld\n", __FILE__, __LINE__, #a, check_a_, \
                    #b, check_b_); \
        } \
    } while (0)

/* Expects `expr` (a cv_result) to equal `code`; prints both names and the error message. */
#define CHECK_RESULT(expr, code) \
    do { \
        cv_result check_r_ = (expr); \
        check_count++; \
        if (check_r_ != (code)) { \
            check_failures++; \
            fprintf(stderr, "%s:%d: %s returned %s, expected %s (%s)\n", __FILE__, __LINE__, #expr, \
                    cv_result_name(check_r_), cv_result_name(code), cv_last_error()); \
        } \
    } while (0)

#define CHECK_OK(expr) CHECK_RESULT(expr, CV_OK)

/* Checks that every context and device the test created has been destroyed
 * (libuv's way: each test proves it cleaned up). check_report() checks it
 * itself, so every test ends with it; use it midway, after destroying what one
 * phase of a test made. */
#define CHECK_NOTHING_LIVE() \
    do { \
        CHECK_EQ_INT(cv_live_contexts(), 0); \
        CHECK_EQ_INT(cv_live_devices(), 0); \
    } while (0)

/* Another count of live objects that check_report() checks is zero, e.g. the
 * Vulkan backend's memory blocks or the nodes a test started: the support code
 * that creates such objects registers their counter (again: no change). */
void check_live_counter(const char *what, uint32_t (*count)(void));

/* Checks that nothing the test made is live (contexts, devices and graphs,
 * then the registered counters), prints "<name>: N passed, N failed" and
 * returns the process exit code. Call it last, after destroying everything the
 * test made; tests/check/check_live_test.c shows it failing a leak. */
int check_report(const char *name);

/* How many times a test repeats the same code: `full` normally, `sanitized`
 * in the ASan and TSan builds (tests/CMakeLists.txt says what may be cut). */
#ifdef CORVID_TEST_SANITIZED
#define CV_TEST_REPEATS(full, sanitized) (sanitized)
#else
#define CV_TEST_REPEATS(full, sanitized) (full)
#endif

#endif
