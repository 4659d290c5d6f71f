/* Random but valid command lists for the codec and recording tests, and a
 * field-by-field comparison of two lists.
 *
 * A random list holds every command type at least once (in table order first),
 * then `blocks` random blocks: single commands on a random allowed queue,
 * render passes with draws inside, marker pairs. Field values are random over
 * their whole range (handles with the right type tags, labels of any non-NUL
 * bytes, bindings and push constants up to their limits), so an encoding that
 * drops or narrows any field shows up. The same seed gives the same list. */
#ifndef CORVID_TEST_RANDOM_LIST_H
#define CORVID_TEST_RANDOM_LIST_H

#include <stdbool.h>
#include <stdint.h>

#include "corvid/command_list.h"

typedef struct test_rng {
    uint64_t state;
} test_rng;

uint64_t test_rng_next(test_rng *rng);
/* Uniform in [0, n), n > 0. */
uint32_t test_rng_below(test_rng *rng, uint32_t n);

/* Begins `list`, records the random list of `seed`, and ends it; returns the
 * end result (CV_OK unless recording rejects something it should not). */
cv_result random_list_record(cv_command_list *list, uint64_t seed, uint32_t blocks);

/* True if both lists hold the same commands, queues, field values, bytes,
 * labels and bindings, with the same spans; else prints the first difference
 * (prefixed with `what`) to stderr. */
bool lists_equal(const cv_command_list *a, const cv_command_list *b, const char *what);

#endif
